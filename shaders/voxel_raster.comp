#version 450
// Pass 1 of the solid voxelisation: every invocation takes one (triangle, tile of columns) work item,
// finds the columns whose centre the triangle's xy-projection covers, and records the signed ray
// crossing in the column's delta list: delta[frame][z][y][x] += winding change at the first voxel
// centre above the crossing. A prefix sum along z (voxel_columns.comp) then gives the winding number.
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
layout(std430, set = 0, binding = 2) buffer Deltas { int deltas[]; };
// Per column of the slab: lowest and highest layer that received a crossing in this batch, so the
// column pass can skip empty columns and stop early.
layout(std430, set = 0, binding = 3) buffer FirstLayer { int first_layer[]; };
layout(std430, set = 0, binding = 4) buffer LastLayer { int last_layer[]; };

layout(push_constant) uniform Params {
    uint work_base;
    uint work_count;
    int nx;
    int ny;
    int z_begin;     // first z layer of the slab
    int slab_layers; // z layers in the slab
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
    int frame_slot = tri.a.w;
    int64_t area = edge_function(a.xy, b.xy, c.xy);
    if (area == 0) return;  // seen edge-on from above: the vertical ray never crosses it
    int winding_change = area > 0 ? -1 : 1;  // a downward-facing face below a point adds +1
    if (area < 0) { ivec3 t = b; b = c; c = t; area = -area; }

    ivec2 range_x = centre_range(min(a.x, min(b.x, c.x)), max(a.x, max(b.x, c.x)));
    ivec2 range_y = centre_range(min(a.y, min(b.y, c.y)), max(a.y, max(b.y, c.y)));
    int x_first = max(max(range_x.x, tile_x), 0);
    int x_last = min(min(range_x.y, tile_x + TILE - 1), params.nx - 1);
    int y_first = max(max(range_y.x, tile_y), 0);
    int y_last = min(min(range_y.y, tile_y + TILE - 1), params.ny - 1);

    int64_t half_voxel = SUBVOXEL / 2;
    for (int y = y_first; y <= y_last; ++y) {
        for (int x = x_first; x <= x_last; ++x) {
            ivec2 p = ivec2(x * int(SUBVOXEL) + int(half_voxel), y * int(SUBVOXEL) + int(half_voxel));
            int64_t wa = edge_function(b.xy, c.xy, p);
            int64_t wb = edge_function(c.xy, a.xy, p);
            int64_t wc = edge_function(a.xy, b.xy, p);
            if (!(covers(wa, b.xy, c.xy) && covers(wb, c.xy, a.xy) && covers(wc, a.xy, b.xy))) continue;
            // Crossing height z = (wa*za + wb*zb + wc*zc) / area; voxel k's centre is above it when
            // (k*S + S/2) * area > numerator, so the first such k is floor((num - S/2*area)/(S*area)) + 1.
            int64_t numerator = wa * int64_t(a.z) + wb * int64_t(b.z) + wc * int64_t(c.z);
            int64_t first_above = floor_div(numerator - half_voxel * area, SUBVOXEL * area) + 1;
            int64_t layer = first_above - int64_t(params.z_begin);
            if (layer >= int64_t(params.slab_layers)) continue;  // above this slab: affects no voxel here
            int slab_z = int(max(layer, int64_t(0)));            // below the slab: counts from its first layer
            uint index = ((uint(frame_slot) * uint(params.slab_layers) + uint(slab_z)) * uint(params.ny) + uint(y))
                         * uint(params.nx) + uint(x);
            atomicAdd(deltas[index], winding_change);
            uint column = uint(y) * uint(params.nx) + uint(x);
            atomicMin(first_layer[column], slab_z);
            atomicMax(last_layer[column], slab_z);
        }
    }
}
