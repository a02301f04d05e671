#version 450
// Pass 1 of the solid voxelisation. Every invocation takes one (triangle, tile of columns) work
// item and finds the columns whose centre the triangle's xy-projection covers. A bucket is one
// (column, frame slot): index column * frames + slot. Each crossing's key (layer << 1 | upward)
// goes into its bucket's next slot, where layer is the first voxel centre above the crossing,
// relative to the slab (crossings below the slab count from its first layer; those above it
// affect no voxel of the slab and are left out). The host gave every bucket room for one key per
// triangle whose bounding box holds the column, so the slots never run out.
// Work per invocation is at most TILE*TILE columns, well under lavapipe's loop cap.
#extension GL_GOOGLE_include_directive : require
#include "fixed_raster.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const int TILE = 16;

struct Triangle {
    ivec4 a;  // xyz fixed point; a.w = frame slot within the batch
    ivec4 b;
    ivec4 c;
};
layout(std430, set = 0, binding = 0) readonly buffer Triangles { Triangle triangles[]; };
layout(std430, set = 0, binding = 1) readonly buffer WorkItems { uvec2 work_items[]; };  // (triangle, tile x | tile y << 16)
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
    uint frames;     // frames in the batch: buckets per column
} params;

void main() {
    uint item_index = params.work_base + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= params.work_count) return;
    uvec2 item = work_items[item_index];
    Triangle tri = triangles[item.x];
    int tile_x = int(item.y & 0xffffu) * TILE;
    int tile_y = int(item.y >> 16) * TILE;

    ivec3 a = tri.a.xyz;
    ivec3 b = tri.b.xyz;
    ivec3 c = tri.c.xyz;
    uint frame_slot = uint(tri.a.w);
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

    for (int y = y_first; y <= y_last; ++y) {
        int64_t wa = row_wa, wb = row_wb, wc = row_wc, numerator = row_numerator;
        for (int x = x_first; x <= x_last; ++x) {
            if (covers(wa, top_left_a) && covers(wb, top_left_b) && covers(wc, top_left_c)) {
                uint bucket = (uint(y) * uint(params.nx) + uint(x)) * params.frames + frame_slot;
                int64_t layer = floor_div_estimated(numerator, layer_divisor) + 1 - int64_t(params.z_begin);
                // Above this slab: affects no voxel here. Below it: counts from its first layer.
                if (layer < int64_t(params.slab_layers)) {
                    uint slot = atomicAdd(bucket_cursor[bucket], 1u);
                    keys[slot] = (uint(max(layer, int64_t(0))) << 1) | upward;
                }
            }
            wa += step_x_wa;
            wb += step_x_wb;
            wc += step_x_wc;
            numerator += step_x_numerator;
        }
        row_wa += step_y_wa;
        row_wb += step_y_wb;
        row_wc += step_y_wc;
        row_numerator += step_y_numerator;
    }
}
