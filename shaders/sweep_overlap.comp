#version 450
// One overlap test of the placement sweep (docs/method.md section 5): for every pose, does a column of
// the static volume (A's side, on A's lattice) share a set bit with the column of the moving volume
// (B's side) that the pull mapping puts under it? Every constraint is one or two such tests.
//
// One invocation handles one work item = (pose, block of rows x block of columns of the static
// volume). The host sizes the blocks so that rows * columns * zwords * (1 + frames) stays under
// lavapipe's per-invocation loop cap. Culling is exact: only rows and columns that are occupied in
// the static volume and inside the moving volume's mapped bounding box are visited, and a column's
// frames are only compared when the unions overlap (a coarse test that proves "no overlap").
//
// Result: mode ANY sets bit 0 of the pose's first flag word when any overlap exists; modes
// PER_FRAME_ALL and PER_FRAME set bit t of the pose's flag words for every frame t with an overlap
// (PER_FRAME_ALL: every frame is needed, so an item stops at its first frame without one).
#extension GL_GOOGLE_include_directive : require
#include "sweep_pose_map.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const int MAX_FRAME_WORDS = 16;

layout(std430, set = 0, binding = 0) readonly buffer StaticBits { uint static_bits[]; };    // [y][x][slot][word]
layout(std430, set = 0, binding = 1) readonly buffer StaticRows { ivec2 static_rows[]; };   // occupied x range per row
layout(std430, set = 0, binding = 2) readonly buffer MovingBits { uint moving_bits[]; };    // [y][x][slot][word]
struct Angle {
    i64vec2 trig;  // cos, sin in fixed point
    ivec4 bounds;  // moving volume's mapped columns at offset 0: x_first, y_first, x_last, y_last (global)
};
layout(std430, set = 0, binding = 3) readonly buffer Angles {
    i64vec2 root_a;
    i64vec2 root_b;
    Angle angles[];
};
layout(std430, set = 0, binding = 4) readonly buffer Poses { ivec4 poses[]; };  // (angle, i, j, unused)
layout(std430, set = 0, binding = 5) buffer Flags { uint flags[]; };
// PER_FRAME tests only: each frame's occupied box, static (local columns) and moving (per angle
// and frame, mapped at offset 0, global columns). Disjoint boxes prove a frame has no overlap.
layout(std430, set = 0, binding = 6) readonly buffer StaticFrameBoxes { ivec4 static_frame_boxes[]; };
layout(std430, set = 0, binding = 7) readonly buffer MovingFrameBoxes { ivec4 moving_frame_boxes[]; };

const int MODE_ANY = 0;
const int MODE_PER_FRAME_ALL = 1;
const int MODE_PER_FRAME = 2;

layout(push_constant) uniform Params {
    uint item_base;
    uint item_count;
    int static_x0, static_y0, static_nx, static_ny;
    int moving_x0, moving_y0, moving_nx, moving_ny;
    int slots, zwords, frames, mode;
    int columns_per_item, rows_per_item, items_x;
    // This dispatch runs work items chunk_first .. chunk_first + chunks_in_wave - 1 of each pose: the
    // host sends a pose's items in waves and drops the poses an earlier wave already decided.
    int chunk_first, chunks_in_wave;
    // Implicit poses (explicit_poses == 0): every (i, j) of the range for angles angle_first...
    int range_i0, range_j0, range_ni, range_nj;
    int angle_first, explicit_poses, flag_words, flag_offset;
    // z words where both volumes have bits: the only words that can overlap.
    int word_first, word_last;
    // PER_FRAME: a work item is (pose, block of frames, spatial block); with a single spatial block
    // an item sees every column, so a frame without overlap decides the pose and ends the item.
    int frames_per_item, spatial_items;
} params;

void main() {
    uint item = params.item_base + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= params.item_count) return;
    uint pose = item / uint(params.chunks_in_wave);
    int chunk = params.chunk_first + int(item % uint(params.chunks_in_wave));

    ivec3 p;  // angle, i, j
    if (params.explicit_poses != 0) {
        p = poses[pose].xyz;
    } else {
        uint per_angle = uint(params.range_ni) * uint(params.range_nj);
        uint rest = pose % per_angle;
        p = ivec3(params.angle_first + int(pose / per_angle), params.range_i0 + int(rest % uint(params.range_ni)),
                  params.range_j0 + int(rest / uint(params.range_ni)));
    }
    Angle angle = angles[p.x];
    // The moving volume's mapped box at this pose, in the static volume's local columns.
    ivec4 box = angle.bounds + ivec4(p.y, p.z, p.y, p.z) - ivec4(params.static_x0, params.static_y0, params.static_x0, params.static_y0);
    int frame_block = 0;
    if (params.mode != MODE_ANY) {
        frame_block = chunk / params.spatial_items;
        chunk = chunk % params.spatial_items;
    }
    int block_x = chunk % params.items_x, block_y = chunk / params.items_x;
    int y_first = max(block_y * params.rows_per_item, box.y);
    int y_last = min(min(block_y * params.rows_per_item + params.rows_per_item, params.static_ny) - 1, box.w);
    int x_lo = max(block_x * params.columns_per_item, box.x);
    int x_hi = min(min(block_x * params.columns_per_item + params.columns_per_item, params.static_nx) - 1, box.z);

    uint found[MAX_FRAME_WORDS];
    for (int w = 0; w < MAX_FRAME_WORDS; ++w) found[w] = 0u;
    bool hit = false;
    const uint column_words = uint(params.slots * params.zwords);
    const ivec4 to_local = ivec4(p.y - params.static_x0, p.z - params.static_y0, p.y - params.static_x0, p.z - params.static_y0);

    if (params.mode != MODE_ANY) {
        // Frame by frame, only over the columns where both frame boxes meet; a frame is done at its
        // first overlap.
        int t_first = frame_block * params.frames_per_item;
        int t_last = min(params.frames, t_first + params.frames_per_item) - 1;
        for (int t = t_first; t <= t_last; ++t) {
            ivec4 sb = static_frame_boxes[t];
            ivec4 mb = moving_frame_boxes[uint(p.x) * uint(params.frames) + uint(t)] + to_local;
            int fy_first = max(y_first, max(sb.y, mb.y)), fy_last = min(y_last, min(sb.w, mb.w));
            int fx_first = max(x_lo, max(sb.x, mb.x)), fx_last = min(x_hi, min(sb.z, mb.z));
            uint slot = uint((1 + t) * params.zwords);
            bool frame_found = false;
            for (int y = fy_first; y <= fy_last && !frame_found; ++y) {
                for (int x = fx_first; x <= fx_last && !frame_found; ++x) {
                    i64vec2 source = source_column(int64_t(params.static_x0 + x - p.y), int64_t(params.static_y0 + y - p.z),
                                                   angle.trig, root_a, root_b);
                    int64_t bx = source.x - int64_t(params.moving_x0), by = source.y - int64_t(params.moving_y0);
                    if (bx < 0 || by < 0 || bx >= int64_t(params.moving_nx) || by >= int64_t(params.moving_ny)) continue;
                    uint s = (uint(y) * uint(params.static_nx) + uint(x)) * column_words + slot;
                    uint m = (uint(by) * uint(params.moving_nx) + uint(bx)) * column_words + slot;
                    for (int w = params.word_first; w <= params.word_last; ++w)
                        if ((static_bits[s + uint(w)] & moving_bits[m + uint(w)]) != 0u) { frame_found = true; break; }
                }
            }
            if (frame_found) found[t >> 5] |= 1u << uint(t & 31);
            else if (params.mode == MODE_PER_FRAME_ALL && params.spatial_items == 1) break;  // no overlap anywhere at frame t: the pose fails
        }
        uint flag = uint(params.flag_offset) + pose * uint(params.flag_words);
        for (int w = 0; w < params.flag_words; ++w)
            if (found[w] != 0u) atomicOr(flags[flag + uint(w)], found[w]);
        return;
    }
    for (int y = y_first; y <= y_last && !hit; ++y) {
        ivec2 row = static_rows[y];
        int x_first = max(x_lo, row.x), x_last = min(x_hi, row.y);
        for (int x = x_first; x <= x_last && !hit; ++x) {
            i64vec2 source = source_column(int64_t(params.static_x0 + x - p.y), int64_t(params.static_y0 + y - p.z),
                                           angle.trig, root_a, root_b);
            int64_t bx = source.x - int64_t(params.moving_x0), by = source.y - int64_t(params.moving_y0);
            if (bx < 0 || by < 0 || bx >= int64_t(params.moving_nx) || by >= int64_t(params.moving_ny)) continue;
            uint s = (uint(y) * uint(params.static_nx) + uint(x)) * column_words;
            uint m = (uint(by) * uint(params.moving_nx) + uint(bx)) * column_words;
            bool unions_meet = false;
            for (int w = params.word_first; w <= params.word_last; ++w)
                if ((static_bits[s + uint(w)] & moving_bits[m + uint(w)]) != 0u) { unions_meet = true; break; }
            if (!unions_meet) continue;
            if (params.frames == 0) { hit = true; break; }
            for (int t = 0; t < params.frames && !hit; ++t) {
                uint bit = 1u << uint(t & 31);
                if ((found[t >> 5] & bit) != 0u) continue;  // this frame's overlap is already known
                uint slot = uint((1 + t) * params.zwords);
                for (int w = params.word_first; w <= params.word_last; ++w) {
                    if ((static_bits[s + slot + uint(w)] & moving_bits[m + slot + uint(w)]) != 0u) {
                        if (params.mode == MODE_ANY) hit = true;
                        else found[t >> 5] |= bit;
                        break;
                    }
                }
            }
        }
    }
    uint flag = uint(params.flag_offset) + pose * uint(params.flag_words);
    if (params.mode == MODE_ANY) {
        if (hit) atomicOr(flags[flag], 1u);
    } else {
        for (int w = 0; w < params.flag_words; ++w)
            if (found[w] != 0u) atomicOr(flags[flag + uint(w)], found[w]);
    }
}
