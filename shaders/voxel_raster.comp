#version 450
// Pass 1 of the solid voxelisation. Every invocation takes one (triangle, tile of columns) work
// item and finds the columns whose centre the triangle's xy-projection covers. A bucket is one
// (column, frame slot): index slot * columns + column. Each crossing's key (layer << 1 | upward)
// goes into its bucket's next slot, where layer is the first voxel centre above the crossing,
// relative to the slab (crossings below the slab count from its first layer; those above it
// affect no voxel of the slab and are left out). The host gave every bucket room for one key per
// triangle that may cover the column (its exact coverage mask, or its conservative cross-sections
// with the rows), so the slots never run out, and the box of those columns bounds the ones tested.
// Work per invocation is at most TILE*TILE columns, tested 8 x 8 at a time, then as many slot
// takings as columns covered: well under lavapipe's loop cap.
#extension GL_GOOGLE_include_directive : require
#include "fixed_raster.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const int TILE = 16;

// Read-only inputs are read as texels: on lavapipe a texel fetch gathers all lanes at once, a
// storage-buffer load runs lane by lane.
// 3 texels per triangle: a, b, c, xyz fixed point; a.w = frame slot | MASKED | mask stride << 8.
// A triangle with MASKED comes with its covered columns, as the host found them by the same exact
// test (fixed::coverage_mask): c.w = a mask of rows 2^stride bits apart from the column
// b.w = x0 | y0 << 16. Without it b.w = x0 | x1 << 16 and c.w = y0 | y1 << 16 are the box of the
// columns it may cover, inside the grid, and the raster finds the covered ones.
layout(set = 0, binding = 0) uniform isamplerBuffer triangles;
layout(set = 0, binding = 1) uniform usamplerBuffer work_items; // 2 texels per item: triangle, tile x | tile y << 16
const uint MASKED = 1u << 16;
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
} params;

void main() {
    uint item_index = params.work_base + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= params.work_count) return;
    // Read once here: on lavapipe a push-constant read inside the slot loop is a load per lane.
    const int64_t z_begin = int64_t(params.z_begin), slab_layers = int64_t(params.slab_layers);
    const uint nx = uint(params.nx), columns = uint(params.nx * params.ny);
    uint triangle = texelFetch(work_items, int(2u * item_index)).x;
    uint tile = texelFetch(work_items, int(2u * item_index + 1u)).x;
    int tile_x = int(tile & 0xffffu) * TILE;
    int tile_y = int(tile >> 16) * TILE;

    ivec4 a4 = texelFetch(triangles, int(3u * triangle));
    ivec3 a = a4.xyz;
    ivec4 b4 = texelFetch(triangles, int(3u * triangle + 1u));
    ivec4 c4 = texelFetch(triangles, int(3u * triangle + 2u));
    ivec3 b = b4.xyz, c = c4.xyz;
    uint frame_slot = uint(a4.w) & 0xffu;
    int64_t area = edge_function(a.xy, b.xy, c.xy);
    if (area == 0) return;  // seen edge-on from above: the vertical ray never crosses it
    uint upward = area > 0 ? 0u : 1u;  // a downward-facing face below a point adds +1 to its winding
    if (area < 0) { ivec3 t = b; b = c; c = t; area = -area; }
    int64_t half_voxel = SUBVOXEL / 2;
    int64_t layer_divisor = SUBVOXEL * area;
    float layer_reciprocal = 1.0 / float(layer_divisor);

    if ((uint(a4.w) & MASKED) != 0u) {
        // The covered columns are the mask's bits in this tile: bit (dy << stride) + dx is column
        // (x0 + dx, y0 + dy). The crossing numerator (below) is stepped from the mask's corner.
        int stride = int(uint(a4.w) >> 8) & 3;
        int x0 = b4.w & 0xffff, y0 = int(uint(b4.w) >> 16);
        int dx_first = max(tile_x - x0, 0), dx_last = min(tile_x + TILE - 1 - x0, (1 << stride) - 1);
        int dy_first = max(tile_y - y0, 0), dy_last = min(tile_y + TILE - 1 - y0, 31);
        uint row_columns = ((2u << dx_last) - 1u) & ~((1u << dx_first) - 1u);
        uint row_starts = stride == 0 ? 0xffffffffu : stride == 1 ? 0x55555555u : stride == 2 ? 0x11111111u : 0x01010101u;
        uint64_t rows = ((uint64_t(1) << min((dy_last + 1) << stride, 63)) - 1ul) & ~((uint64_t(1) << min(dy_first << stride, 63)) - 1ul);
        uint pending = uint(c4.w) & uint(rows) & (row_starts * row_columns);
        ivec2 corner = ivec2(x0 * int(SUBVOXEL) + int(half_voxel), y0 * int(SUBVOXEL) + int(half_voxel));
        int64_t corner_numerator = edge_function(b.xy, c.xy, corner) * int64_t(a.z) + edge_function(c.xy, a.xy, corner) * int64_t(b.z) +
                                   edge_function(a.xy, b.xy, corner) * int64_t(c.z) - half_voxel * area;
        // As below: per unit of x, -(v.y - u.y) * S of each edge function; per unit of y, (v.x - u.x) * S.
        int64_t column_step = int64_t(-(c.y - b.y) * int(SUBVOXEL)) * a.z + int64_t(-(a.y - c.y) * int(SUBVOXEL)) * b.z +
                              int64_t(-(b.y - a.y) * int(SUBVOXEL)) * c.z;
        int64_t row_step = int64_t((c.x - b.x) * int(SUBVOXEL)) * a.z + int64_t((a.x - c.x) * int(SUBVOXEL)) * b.z +
                           int64_t((b.x - a.x) * int(SUBVOXEL)) * c.z;
        uint column_mask = (1u << uint(stride)) - 1u;
        for (; pending != 0u; pending &= pending - 1u) {
            int bit = findLSB(pending);
            int dx = bit & int(column_mask), dy = bit >> stride;
            int64_t numerator = corner_numerator + int64_t(dx) * column_step + int64_t(dy) * row_step;
            int64_t layer = floor_div_estimated(numerator, layer_divisor, layer_reciprocal) + 1 - z_begin;
            // Above this slab: affects no voxel here. Below it: counts from its first layer.
            if (layer < slab_layers) {
                uint bucket = frame_slot * columns + uint(y0 + dy) * nx + uint(x0 + dx);
                uint slot = atomicAdd(bucket_cursor[bucket], 1u);
                keys[slot] = (uint(max(layer, int64_t(0))) << 1) | upward;
            }
        }
        return;
    }

    int x_first = max(b4.w & 0xffff, tile_x);
    int x_last = min(int(uint(b4.w) >> 16), tile_x + TILE - 1);
    int y_first = max(c4.w & 0xffff, tile_y);
    int y_last = min(int(uint(c4.w) >> 16), tile_y + TILE - 1);

    // The edge functions and the crossing numerator are linear in the sample point, so they are
    // evaluated exactly once at the first column and then stepped by integer additions (the same
    // integers fixed_raster.hpp computes directly).
    ivec2 p0 = ivec2(x_first * int(SUBVOXEL) + int(half_voxel), y_first * int(SUBVOXEL) + int(half_voxel));
    int64_t row_wa = edge_function(b.xy, c.xy, p0);
    int64_t row_wb = edge_function(c.xy, a.xy, p0);
    int64_t row_wc = edge_function(a.xy, b.xy, p0);
    // edge_function(u, v, p) grows by -(v.y - u.y) per unit of p.x and by (v.x - u.x) per unit of p.y.
    // Coordinates stay below 2^17, so a step is below 2^23 and fits 32 bits.
    int step_x_wa = -(c.y - b.y) * int(SUBVOXEL), step_y_wa = (c.x - b.x) * int(SUBVOXEL);
    int step_x_wb = -(a.y - c.y) * int(SUBVOXEL), step_y_wb = (a.x - c.x) * int(SUBVOXEL);
    int step_x_wc = -(b.y - a.y) * int(SUBVOXEL), step_y_wc = (b.x - a.x) * int(SUBVOXEL);
    // Crossing height z = (wa*za + wb*zb + wc*zc) / area; voxel k's centre is above it when
    // (k*S + S/2) * area > numerator, so the first such k is floor((num - S/2*area)/(S*area)) + 1.
    int64_t row_numerator = row_wa * int64_t(a.z) + row_wb * int64_t(b.z) + row_wc * int64_t(c.z) - half_voxel * area;
    int64_t step_x_numerator = int64_t(step_x_wa) * a.z + int64_t(step_x_wb) * b.z + int64_t(step_x_wc) * c.z;
    int64_t step_y_numerator = int64_t(step_y_wa) * a.z + int64_t(step_y_wb) * b.z + int64_t(step_y_wc) * c.z;
    // The coverage test runs in 32 bits: each edge value at the first column, clamped to +-2^30,
    // keeps its sign over the tile (at most 2 (TILE - 1) steps of below 2^23 each: under 2^28 for
    // TILE <= 16), and the top-left rule is folded in: a column is covered when all three are >= 0.
    int row_ea = coverage_edge(row_wa, is_top_left(b.xy, c.xy));
    int row_eb = coverage_edge(row_wb, is_top_left(c.xy, a.xy));
    int row_ec = coverage_edge(row_wc, is_top_left(a.xy, b.xy));

    // The box goes in blocks of 8 x 8 columns. First the block's covered columns are found, with
    // arithmetic only, as bits of a 64-bit mask; then each takes its slot. On lavapipe an atomic
    // or a store costs a loop over the lanes however few of them take it, so the slots are taken
    // in a loop as long as this subgroup's most covered columns, not its largest box.
    for (int block_y = y_first; block_y <= y_last; block_y += 8) {
        for (int block_x = x_first; block_x <= x_last; block_x += 8) {
            const int dx0 = block_x - x_first, dy0 = block_y - y_first;
            int block_ea = row_ea + dx0 * step_x_wa + dy0 * step_y_wa;
            int block_eb = row_eb + dx0 * step_x_wb + dy0 * step_y_wb;
            int block_ec = row_ec + dx0 * step_x_wc + dy0 * step_y_wc;
            int64_t block_numerator = row_numerator + int64_t(dx0) * step_x_numerator + int64_t(dy0) * step_y_numerator;
            uint covered_low = 0u, covered_high = 0u;  // bit (y - block_y) * 8 + (x - block_x), rows 0-3 and 4-7
            for (int y = block_y; y <= min(block_y + 7, y_last); ++y) {
                int ea = block_ea, eb = block_eb, ec = block_ec;
                uint row_bits = 0u;
                for (int x = block_x; x <= min(block_x + 7, x_last); ++x) {
                    if ((ea | eb | ec) >= 0) row_bits |= 1u << uint(x - block_x);
                    ea += step_x_wa;
                    eb += step_x_wb;
                    ec += step_x_wc;
                }
                uint shift = uint((y - block_y) & 3) * 8u;
                if (y - block_y < 4) covered_low |= row_bits << shift;
                else covered_high |= row_bits << shift;
                block_ea += step_y_wa;
                block_eb += step_y_wb;
                block_ec += step_y_wc;
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
                int64_t layer = floor_div_estimated(numerator, layer_divisor, layer_reciprocal) + 1 - z_begin;
                // Above this slab: affects no voxel here. Below it: counts from its first layer.
                if (layer < slab_layers) {
                    uint bucket = frame_slot * columns + uint(y) * nx + uint(x);
                    uint slot = atomicAdd(bucket_cursor[bucket], 1u);
                    keys[slot] = (uint(max(layer, int64_t(0))) << 1) | upward;
                }
            }
        }
    }
}
