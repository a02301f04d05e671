#version 450
// Pass 5 of the solid voxelisation: one invocation per (x, y) column runs an XOR along the column
// over the inside/outside flips of every frame (voxel_windings.comp), which gives the occupancy
// word of each layer, and ORs it into the mask (earlier batches of the same word set other bits).
// Only the layers between the column's first and last flip are visited; each flip word and the
// column's range markers are reset after reading, so the next batch needs no clear.
// Loop work is at most slab_layers, which the host keeps under lavapipe's loop cap.

layout(local_size_x_id = 0) in;

layout(std430, set = 0, binding = 0) buffer Toggles { uint toggles[]; };  // [z][y][x] of the slab
layout(std430, set = 0, binding = 1) buffer Mask { uint mask[]; };        // [z][y][x] of the slab
layout(std430, set = 0, binding = 2) buffer FirstLayer { int first_layer[]; };
layout(std430, set = 0, binding = 3) buffer LastLayer { int last_layer[]; };

layout(push_constant) uniform Params {
    uint column_base;
    uint column_count;
    uint columns;  // nx * ny
} params;

void main() {
    if (gl_GlobalInvocationID.x >= params.column_count) return;
    uint column = params.column_base + gl_GlobalInvocationID.x;
    int last = last_layer[column];
    if (last < 0) return;  // no frame is inside anywhere in this column
    int first = first_layer[column];
    first_layer[column] = 0x7fffffff;
    last_layer[column] = -1;

    uint word = 0u;
    for (int z = first; z <= last; ++z) {
        uint voxel = uint(z) * params.columns + column;
        uint flips = toggles[voxel];
        if (flips != 0u) {
            word ^= flips;
            toggles[voxel] = 0u;
        }
        if (word != 0u) mask[voxel] |= word;
    }
}
