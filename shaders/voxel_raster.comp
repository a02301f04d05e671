#version 450
// Pass 1 of the solid voxelisation. Every invocation takes one (triangle, tile of columns) work
// item and finds the columns whose centre the triangle's xy-projection covers. A bucket is one
// (column, frame slot): index slot * columns + column. Each crossing's key (layer << 1 | upward)
// goes into its bucket's next slot, where layer is the first voxel centre above the crossing,
// relative to the slab (crossings below the slab count from its first layer; those above it
// affect no voxel of the slab and are left out). The host gave every bucket room for one key per
// triangle whose bounding box holds the column, so the slots never run out.
// Work per invocation is at most TILE*TILE columns, tested 8 x 8 at a time, then as many slot
// takings as columns covered: well under lavapipe's loop cap.
#extension GL_GOOGLE_include_directive : require
#include "fixed_raster.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const int TILE = 16;

// Read-only inputs are read as texels: on lavapipe a texel fetch gathers all lanes at once, a
// storage-buffer load runs lane by lane.
layout(set = 0, binding = 0) uniform isamplerBuffer triangles;  // 3 texels per triangle: a, b, c (xyz fixed point; a.w = frame slot)
layout(set = 0, binding = 1) uniform usamplerBuffer work_items; // 2 texels per item: triangle, tile x | tile y << 16
// The next free key slot of each bucket.
layout(std430, set = 0, binding = 2) buffer BucketCursors { uint bucket_cursor[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Keys { uint keys[]; };

layout(push_constant) uniform Params {
    uint work_base;
    uint work_count;
    int nx;
    int ny;
    int z_begin;     // first z layer of the slab
    int slab_layers; // z layers in the slab
    uint frames;     // frames in the batch
} params;

void main() {
    uint item_index = params.work_base + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= params.work_count) return;
    uint triangle = texelFetch(work_items, int(2u * item_index)).x;
    uint tile = texelFetch(work_items, int(2u * item_index + 1u)).x;
    int tile_x = int(tile & 0xffffu) * TILE;
    int tile_y = int(tile >> 16) * TILE;

    ivec4 a4 = texelFetch(triangles, int(3u * triangle));
    ivec3 a = a4.xyz;
    ivec3 b = texelFetch(triangles, int(3u * triangle + 1u)).xyz;
    ivec3 c = texelFetch(triangles, int(3u * triangle + 2u)).xyz;
    uint frame_slot = uint(a4.w);
    int64_t area = edge_function(a.xy, b.xy, c.xy);
    if (area == 0) return;  // seen edge-on from above: the vertical ray never crosses it
    uint upward = area > 0 ? 0u : 1u;  // a downward-facing face below a point adds +1 to its winding
    if (area < 0) { ivec3 t = b; b = c; c = t; area = -area; }

    ivec2 range_x = centre_range(min(a.x, min(b.x, c.x)), max(a.x, max(b.x, c.x)));
    ivec2 range_y = centre_range(min(a.y, min(b.y, c.y)), max(a.y, max(b.y, c.y)));
    int x_first = max(max(range_x.x, tile_x), 0);
    int x_last = min(min(range_x.y, tile_x + TILE - 1), params.nx - 1);
    int y_first = max(max(range_y.x, tile_y), 0);
    int y_last = min(min(range_y.y, tile_y + TILE - 1), params.ny - 1);

    // The edge functions and the crossing numerator are linear in the sample point, so they are
    // evaluated exactly once at the first column and then stepped by integer additions (the same
    // integers fixed_raster.hpp computes directly).
    int64_t half_voxel = SUBVOXEL / 2;
    ivec2 p0 = ivec2(x_first * int(SUBVOXEL) + int(half_voxel), y_first * int(SUBVOXEL) + int(half_voxel));
    int64_t row_wa = edge_function(b.xy, c.xy, p0);
    int64_t row_wb = edge_function(c.xy, a.xy, p0);
    int64_t row_wc = edge_function(a.xy, b.xy, p0);
    // edge_function(u, v, p) grows by -(v.y - u.y) per unit of p.x and by (v.x - u.x) per unit of p.y.
    int64_t step_x_wa = -int64_t(c.y - b.y) * SUBVOXEL, step_y_wa = int64_t(c.x - b.x) * SUBVOXEL;
    int64_t step_x_wb = -int64_t(a.y - c.y) * SUBVOXEL, step_y_wb = int64_t(a.x - c.x) * SUBVOXEL;
    int64_t step_x_wc = -int64_t(b.y - a.y) * SUBVOXEL, step_y_wc = int64_t(b.x - a.x) * SUBVOXEL;
    // Crossing height z = (wa*za + wb*zb + wc*zc) / area; voxel k's centre is above it when
    // (k*S + S/2) * area > numerator, so the first such k is floor((num - S/2*area)/(S*area)) + 1.
    int64_t row_numerator = row_wa * int64_t(a.z) + row_wb * int64_t(b.z) + row_wc * int64_t(c.z) - half_voxel * area;
    int64_t step_x_numerator = step_x_wa * int64_t(a.z) + step_x_wb * int64_t(b.z) + step_x_wc * int64_t(c.z);
    int64_t step_y_numerator = step_y_wa * int64_t(a.z) + step_y_wb * int64_t(b.z) + step_y_wc * int64_t(c.z);
    int64_t layer_divisor = SUBVOXEL * area;
    bool top_left_a = is_top_left(b.xy, c.xy), top_left_b = is_top_left(c.xy, a.xy), top_left_c = is_top_left(a.xy, b.xy);

    // The box goes in blocks of 8 x 8 columns. First the block's covered columns are found, with
    // arithmetic only, as bits of a 64-bit mask; then each takes its slot. On lavapipe an atomic
    // or a store costs a loop over the lanes however few of them take it, so the slots are taken
    // in a loop as long as this subgroup's most covered columns, not its largest box.
    for (int block_y = y_first; block_y <= y_last; block_y += 8) {
        for (int block_x = x_first; block_x <= x_last; block_x += 8) {
            const int64_t dx0 = int64_t(block_x - x_first), dy0 = int64_t(block_y - y_first);
            int64_t block_wa = row_wa + dx0 * step_x_wa + dy0 * step_y_wa;
            int64_t block_wb = row_wb + dx0 * step_x_wb + dy0 * step_y_wb;
            int64_t block_wc = row_wc + dx0 * step_x_wc + dy0 * step_y_wc;
            int64_t block_numerator = row_numerator + dx0 * step_x_numerator + dy0 * step_y_numerator;
            uint covered_low = 0u, covered_high = 0u;  // bit (y - block_y) * 8 + (x - block_x), rows 0-3 and 4-7
            for (int y = block_y; y <= min(block_y + 7, y_last); ++y) {
                int64_t wa = block_wa, wb = block_wb, wc = block_wc;
                uint row_bits = 0u;
                for (int x = block_x; x <= min(block_x + 7, x_last); ++x) {
                    if (covers(wa, top_left_a) && covers(wb, top_left_b) && covers(wc, top_left_c)) row_bits |= 1u << uint(x - block_x);
                    wa += step_x_wa;
                    wb += step_x_wb;
                    wc += step_x_wc;
                }
                uint shift = uint((y - block_y) & 3) * 8u;
                if (y - block_y < 4) covered_low |= row_bits << shift;
                else covered_high |= row_bits << shift;
                block_wa += step_y_wa;
                block_wb += step_y_wb;
                block_wc += step_y_wc;
            }
            while ((covered_low | covered_high) != 0u) {
                int bit;
                if (covered_low != 0u) {
                    bit = findLSB(covered_low);
                    covered_low &= covered_low - 1u;
                } else {
                    bit = 32 + findLSB(covered_high);
                    covered_high &= covered_high - 1u;
                }
                int x = block_x + (bit & 7), y = block_y + (bit >> 3);
                int64_t numerator = block_numerator + int64_t(bit & 7) * step_x_numerator + int64_t(bit >> 3) * step_y_numerator;
                int64_t layer = floor_div_estimated(numerator, layer_divisor) + 1 - int64_t(params.z_begin);
                // Above this slab: affects no voxel here. Below it: counts from its first layer.
                if (layer < int64_t(params.slab_layers)) {
                    uint bucket = frame_slot * uint(params.nx * params.ny) + uint(y) * uint(params.nx) + uint(x);
                    uint slot = atomicAdd(bucket_cursor[bucket], 1u);
                    keys[slot] = (uint(max(layer, int64_t(0))) << 1) | upward;
                }
            }
        }
    }
}
