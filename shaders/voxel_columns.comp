#version 450
// Pass 2 of the solid voxelisation: one invocation per (x, y) column of the slab walks up the z
// layers from the column's first crossing, keeps the running winding number of every frame of the
// batch, and writes one mask word per voxel with bit (bit_offset + f) set where frame f's winding
// number is non-zero, ORed into the word (the host zeroed it before the word's first batch).
// Columns without crossings are skipped; the walk
// stops once past the last crossing with every winding back at zero. Each delta it reads is reset
// to zero, so the delta volume is clean for the next batch without a full clear.
// Loop work is at most slab_layers * (frames + 1), which the host keeps under lavapipe's loop cap.

layout(local_size_x_id = 0) in;

layout(std430, set = 0, binding = 0) buffer Deltas { int deltas[]; };
layout(std430, set = 0, binding = 1) buffer Mask { uint mask[]; };  // [z][y][x] of the slab, one occupancy word
layout(std430, set = 0, binding = 2) buffer FirstLayer { int first_layer[]; };
layout(std430, set = 0, binding = 3) buffer LastLayer { int last_layer[]; };

layout(push_constant) uniform Params {
    uint column_base;
    uint column_count;
    int nx;
    int ny;
    int slab_layers;
    int frames;       // frames in this batch, at most 32
    int bit_offset;   // bit of the batch's first frame inside the word
    int padding;
} params;

void main() {
    if (gl_GlobalInvocationID.x >= params.column_count) return;
    uint column = params.column_base + gl_GlobalInvocationID.x;
    int last = last_layer[column];
    if (last < 0) return;  // no crossing in this column
    int first = first_layer[column];
    // Reset the range markers for the next batch (this invocation is their only reader).
    first_layer[column] = 0x7fffffff;
    last_layer[column] = -1;

    uint layer_size = uint(params.nx) * uint(params.ny);
    uint frame_stride = layer_size * uint(params.slab_layers);
    int winding[32];
    for (int f = 0; f < params.frames; ++f) winding[f] = 0;
    for (int z = first; z < params.slab_layers; ++z) {
        uint voxel = uint(z) * layer_size + column;
        uint word = 0u;
        for (int f = 0; f < params.frames; ++f) {
            uint index = uint(f) * frame_stride + voxel;
            winding[f] += deltas[index];
            deltas[index] = 0;
            if (winding[f] != 0) word |= 1u << uint(params.bit_offset + f);
        }
        if (word != 0u) mask[voxel] |= word;  // earlier batches of the same word set other bits
        if (z >= last && word == 0u) break;  // past every crossing and all windings are zero again
    }
}
