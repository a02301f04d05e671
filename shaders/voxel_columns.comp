#version 450
// Pass 2 of the solid voxelisation: one invocation per (x, y) column of the slab walks up the z
// layers, keeps the running winding number of every frame of the batch, and writes one mask word
// per voxel with bit (bit_offset + f) set where frame f's winding number is non-zero.
// Loop work is slab_layers * (frames + 1), which the host keeps under lavapipe's loop cap.

layout(local_size_x_id = 0) in;

layout(std430, set = 0, binding = 0) readonly buffer Deltas { int deltas[]; };
layout(std430, set = 0, binding = 1) buffer Mask { uint mask[]; };  // [z][y][x] of the slab, one occupancy word

layout(push_constant) uniform Params {
    uint column_base;
    uint column_count;
    int nx;
    int ny;
    int slab_layers;
    int frames;       // frames in this batch, at most 32
    int bit_offset;   // bit of the batch's first frame inside the word
    int accumulate;   // 1: OR into the word (a later batch of the same word), 0: overwrite
} params;

void main() {
    if (gl_GlobalInvocationID.x >= params.column_count) return;
    uint column = params.column_base + gl_GlobalInvocationID.x;
    uint layer_size = uint(params.nx) * uint(params.ny);
    uint frame_stride = layer_size * uint(params.slab_layers);
    int winding[32];
    for (int f = 0; f < params.frames; ++f) winding[f] = 0;
    for (int z = 0; z < params.slab_layers; ++z) {
        uint voxel = uint(z) * layer_size + column;
        uint word = 0u;
        for (int f = 0; f < params.frames; ++f) {
            winding[f] += deltas[uint(f) * frame_stride + voxel];
            if (winding[f] != 0) word |= 1u << uint(params.bit_offset + f);
        }
        mask[voxel] = params.accumulate != 0 ? (mask[voxel] | word) : word;
    }
}
