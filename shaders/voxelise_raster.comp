#version 450
// Pass 1 of the solid voxelisation. Every invocation takes one work item of a triangle: the whole
// triangle when its covered columns come as a mask, or a run of one row's columns of a larger one.
// A bucket is one (column, frame slot): index slot * columns + column, the column counted in the
// window of columns voxelised (nx x ny from window_x0, window_y0 of the grid; the items hold only
// its columns, in grid coordinates). Each crossing's
// key (layer << 1 | upward) goes into its bucket's next slot, where layer is the first voxel
// centre above the crossing, relative to the slab (crossings below the slab count from its first
// layer; those above it affect no voxel of the slab and are left out). The host gave every bucket
// room for one key per triangle that may cover the column (its exact coverage mask, or its
// conservative cross-sections with the rows, which the runs are), so the slots never run out.
// Work per invocation is at most 32 mask bits or RUN_COLUMNS columns: well under lavapipe's loop cap.
#extension GL_GOOGLE_include_directive : require
#include "voxelise_fixed_raster.glsl"

layout(local_size_x_id = 0) in;
const int RUN_COLUMNS = 64;  // voxelise_vulkan.cpp's kRunColumns

// Read-only inputs are read as texels: on lavapipe a texel fetch gathers all lanes at once, a
// storage-buffer load runs lane by lane.
// 2 texels per work item (voxelise_vulkan.cpp's GpuItem): its triangle's vertices a, b, c, xyz
// fixed point in 18 bits each, packed into two words each (x | y << 18, y >> 14 | z << 4 | kind
// << 22 for a), where kind = frame slot | MASKED | mask stride << 6; then two words of data. A
// triangle with MASKED comes whole with its covered columns, as the host found them by the same
// exact test (fixed::coverage_mask): a mask of rows 2^stride bits apart, and the column
// x0 | y0 << 16 of its bit 0. Else the item is one run of it: first column | row << 11 |
// (columns - 1) << 22, then 0.
layout(set = 0, binding = 0) uniform isamplerBuffer work_items;
const uint MASKED = 1u << 5;
// The next free key slot of each bucket.
layout(std430, set = 0, binding = 1) buffer BucketCursors { uint bucket_cursor[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Keys { uint keys[]; };

layout(push_constant) uniform Params {
    uint work_base;
    uint work_count;
    int nx;
    int ny;
    int z_begin;     // first z layer of the slab
    int slab_layers; // z layers in the slab
    int window_x0;   // the window's first column and row in the grid
    int window_y0;
} params;

ivec3 unpack_vertex(uint low, uint high) {
    return ivec3(int(low & 0x3ffffu), int((low >> 18) | ((high & 0xfu) << 14)), int((high >> 4) & 0x3ffffu));
}

// The crossing at numerator / divisor into `bucket`'s next slot: its key is the first layer whose
// centre lies above it, relative to the slab (see above), and `upward`.
void add_crossing(uint bucket, int64_t numerator, int64_t divisor, float reciprocal, uint upward, int64_t z_begin, int64_t slab_layers) {
    int64_t layer = floor_div_estimated(numerator, divisor, reciprocal) + 1 - z_begin;
    // Above this slab: affects no voxel here. Below it: counts from its first layer.
    if (layer < slab_layers) {
        uint slot = atomicAdd(bucket_cursor[bucket], 1u);
        keys[slot] = (uint(max(layer, int64_t(0))) << 1) | upward;
    }
}

void main() {
    uint item_index = params.work_base + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= params.work_count) return;
    // Read once here: on lavapipe a push-constant read inside the slot loop is a load per lane.
    const int64_t z_begin = int64_t(params.z_begin), slab_layers = int64_t(params.slab_layers);
    const uint nx = uint(params.nx), columns = uint(params.nx * params.ny);
    const int window_x0 = params.window_x0, window_y0 = params.window_y0;
    uvec4 vertices = uvec4(texelFetch(work_items, int(2u * item_index)));
    uvec4 rest = uvec4(texelFetch(work_items, int(2u * item_index + 1u)));
    ivec3 a = unpack_vertex(vertices.x, vertices.y), b = unpack_vertex(vertices.z, vertices.w), c = unpack_vertex(rest.x, rest.y);
    uint kind = vertices.y >> 22;
    uint place = rest.z;
    uint frame_slot = kind & 31u;
    int64_t area = edge_function(a.xy, b.xy, c.xy);
    if (area == 0) return;  // seen edge-on from above: the vertical ray never crosses it
    uint upward = area > 0 ? 0u : 1u;  // a downward-facing face below a point adds +1 to its winding
    if (area < 0) { ivec3 t = b; b = c; c = t; area = -area; }
    int64_t half_voxel = SUBVOXEL / 2;
    int64_t layer_divisor = SUBVOXEL * area;
    float layer_reciprocal = 1.0 / float(layer_divisor);

    // The edge functions and the crossing numerator are linear in the sample point, so they are
    // evaluated exactly once at a first column and then stepped by integer additions (the same
    // integers fixed_raster.hpp computes directly). edge_function(u, v, p) grows by -(v.y - u.y)
    // per unit of p.x and by (v.x - u.x) per unit of p.y; coordinates stay below 2^17, so a step
    // is below 2^23 and fits 32 bits.
    int step_x_wa = -(c.y - b.y) * int(SUBVOXEL), step_y_wa = (c.x - b.x) * int(SUBVOXEL);
    int step_x_wb = -(a.y - c.y) * int(SUBVOXEL), step_y_wb = (a.x - c.x) * int(SUBVOXEL);
    int step_x_wc = -(b.y - a.y) * int(SUBVOXEL), step_y_wc = (b.x - a.x) * int(SUBVOXEL);
    // Crossing height z = (wa*za + wb*zb + wc*zc) / area; voxel k's centre is above it when
    // (k*S + S/2) * area > numerator, so the first such k is floor((num - S/2*area)/(S*area)) + 1.
    int64_t step_x_numerator = int64_t(step_x_wa) * a.z + int64_t(step_x_wb) * b.z + int64_t(step_x_wc) * c.z;
    int64_t step_y_numerator = int64_t(step_y_wa) * a.z + int64_t(step_y_wb) * b.z + int64_t(step_y_wc) * c.z;

    if ((kind & MASKED) != 0u) {
        // The covered columns are the mask's bits: bit (dy << stride) + dx is column (x0 + dx, y0 + dy).
        int stride = int(kind >> 6);
        int x0 = int(rest.w & 0xffffu), y0 = int(rest.w >> 16);
        uint pending = rest.z;
        ivec2 corner = ivec2(x0 * int(SUBVOXEL) + int(half_voxel), y0 * int(SUBVOXEL) + int(half_voxel));
        int64_t corner_numerator = edge_function(b.xy, c.xy, corner) * int64_t(a.z) + edge_function(c.xy, a.xy, corner) * int64_t(b.z) +
                                   edge_function(a.xy, b.xy, corner) * int64_t(c.z) - half_voxel * area;
        int column_mask = (1 << stride) - 1;
        // On lavapipe an atomic or a store costs a loop over the lanes however few of them take it;
        // the items are classed so that a subgroup's lanes have as many bits each.
        for (; pending != 0u; pending &= pending - 1u) {
            int bit = findLSB(pending);
            int dx = bit & column_mask, dy = bit >> stride;
            int64_t numerator = corner_numerator + int64_t(dx) * step_x_numerator + int64_t(dy) * step_y_numerator;
            uint bucket = frame_slot * columns + uint(y0 + dy - window_y0) * nx + uint(x0 + dx - window_x0);
            add_crossing(bucket, numerator, layer_divisor, layer_reciprocal, upward, z_begin, slab_layers);
        }
        return;
    }

    // A run: columns x_first .. x_first + run - 1 of row y, from the row's conservative span, so
    // each is tested exactly. The test runs in 32 bits: each edge value at the first column,
    // clamped to +-2^30, keeps its sign over the run (under RUN_COLUMNS steps of below 2^23 each:
    // under 2^29), and the top-left rule is folded in: a column is covered when all three are >= 0.
    int x_first = int(place & 0x7ffu), y = int((place >> 11) & 0x7ffu), run = int(place >> 22) + 1;
    ivec2 p0 = ivec2(x_first * int(SUBVOXEL) + int(half_voxel), y * int(SUBVOXEL) + int(half_voxel));
    int64_t wa = edge_function(b.xy, c.xy, p0), wb = edge_function(c.xy, a.xy, p0), wc = edge_function(a.xy, b.xy, p0);
    int64_t numerator = wa * int64_t(a.z) + wb * int64_t(b.z) + wc * int64_t(c.z) - half_voxel * area;
    int ea = coverage_edge(wa, is_top_left(b.xy, c.xy));
    int eb = coverage_edge(wb, is_top_left(c.xy, a.xy));
    int ec = coverage_edge(wc, is_top_left(a.xy, b.xy));
    uint bucket = frame_slot * columns + uint(y - window_y0) * nx + uint(x_first - window_x0);
    for (int i = 0; i < run; ++i) {
        if ((ea | eb | ec) >= 0) add_crossing(bucket + uint(i), numerator, layer_divisor, layer_reciprocal, upward, z_begin, slab_layers);
        ea += step_x_wa;
        eb += step_x_wb;
        ec += step_x_wc;
        numerator += step_x_numerator;
    }
}
