#version 450
// Pass 4 of the solid voxelisation: one invocation per bucket (frame slot, column) sorts the
// bucket's crossing keys (layer << 1 | upward) and walks them upwards with the frame's winding
// number. Wherever the voxels switch between inside (winding non-zero) and outside, it flips the
// frame's bit in toggles[layer][column]; voxel_columns.comp turns the flips into occupancy words
// with a running XOR. The column's first and last flip layers bound that walk.
// Loop work is at most MAX_CROSSINGS * (2 log2 MAX_CROSSINGS + 1) for the heap sort and walk; a
// bucket with more crossings (one frame's surface crossing one column more often than that)
// records its frame slot (the lowest such slot, so the report is deterministic) and stops; the
// host reports it.

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint MAX_CROSSINGS = 1024;

layout(std430, set = 0, binding = 0) buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) readonly buffer Starts { uint bucket_start[]; };
layout(std430, set = 0, binding = 2) readonly buffer Ends { uint bucket_end[]; };  // the fill pass's cursors
layout(std430, set = 0, binding = 3) buffer Toggles { uint toggles[]; };         // [z][y][x] of the slab
layout(std430, set = 0, binding = 4) buffer FirstLayer { int first_layer[]; };   // per column
layout(std430, set = 0, binding = 5) buffer LastLayer { int last_layer[]; };
layout(std430, set = 0, binding = 6) buffer Overflow { uint first_overflowing_slot; };  // ~0u: none

layout(push_constant) uniform Params {
    uint bucket_base;
    uint bucket_count;
    uint columns;     // nx * ny
    int slab_layers;
    int bit_offset;   // bit of the batch's first frame inside the word
} params;

// Restores the max-heap below `root` in keys[start, start + n).
void sift_down(uint start, uint root, uint n) {
    uint value = keys[start + root];
    for (;;) {
        uint child = 2u * root + 1u;
        if (child >= n) break;
        uint child_value = keys[start + child];
        if (child + 1u < n) {
            uint right = keys[start + child + 1u];
            if (right > child_value) { child += 1u; child_value = right; }
        }
        if (value >= child_value) break;
        keys[start + root] = child_value;
        root = child;
    }
    keys[start + root] = value;
}

void main() {
    if (gl_GlobalInvocationID.x >= params.bucket_count) return;
    uint bucket = params.bucket_base + gl_GlobalInvocationID.x;
    uint start = bucket_start[bucket];
    uint n = bucket_end[bucket] - start;
    if (n == 0u) return;
    uint slot = bucket / params.columns;
    if (n > MAX_CROSSINGS) {
        atomicMin(first_overflowing_slot, slot);
        return;
    }
    uint column = bucket - slot * params.columns;
    uint bit = 1u << (uint(params.bit_offset) + slot);

    // Heap sort in place: the keys of one bucket are this invocation's alone.
    for (uint i = n / 2u; i > 0u; --i) sift_down(start, i - 1u, n);
    for (uint last = n - 1u; last > 0u; --last) {
        uint top = keys[start];
        keys[start] = keys[start + last];
        keys[start + last] = top;
        sift_down(start, 0u, last);
    }

    int winding = 0;
    bool inside = false;
    int first_flip = params.slab_layers, last_flip = -1;
    for (uint i = 0u; i < n; ++i) {
        uint key = keys[start + i];
        int layer = int(key >> 1);
        winding += (key & 1u) != 0u ? 1 : -1;
        // Decide once every crossing of this layer is in.
        if (i + 1u < n && int(keys[start + i + 1u] >> 1) == layer) continue;
        if ((winding != 0) != inside) {
            inside = !inside;
            atomicXor(toggles[uint(layer) * params.columns + column], bit);
            first_flip = min(first_flip, layer);
            last_flip = layer;
        }
    }
    if (last_flip < 0) return;  // never inside
    // Still inside after the last crossing (the closing ones lie above the slab): to the top.
    if (inside) last_flip = params.slab_layers - 1;
    atomicMin(first_layer[column], first_flip);
    atomicMax(last_layer[column], last_flip);
}
