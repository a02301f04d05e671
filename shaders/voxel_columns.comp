#version 450
// Pass 2 of the solid voxelisation: one invocation per (x, y) column. For every frame of the batch
// it sorts the frame's crossing keys (layer << 1 | upward) and walks them upwards with the frame's
// winding number, flipping the frame's bit in toggles[layer] wherever the voxels switch between
// inside (winding non-zero) and outside. Then an XOR up the column over the flips gives each
// layer's occupancy word, which is ORed into the mask (earlier batches of the same word set other
// bits). Only layers between the column's first and last flip are visited, and every flip word
// read is reset, so the next batch needs no clear. Work scales with the column's crossings and
// span, not with frames x layers.
// Loop work is at most frames + MAX_COLUMN_CROSSINGS * (log2 MAX_COLUMN_CROSSINGS + 2) for the
// sorts and walks plus slab_layers for the XOR; a column with more crossings is skipped and
// flagged, and the host redoes the batch with fewer frames.

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint MAX_COLUMN_CROSSINGS = 1024;
const uint INSERTION_SORT_MAX = 12;  // small buckets (the usual 2 to 8 crossings) sort by insertion

layout(std430, set = 0, binding = 0) buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) readonly buffer Starts { uint bucket_start[]; };
layout(std430, set = 0, binding = 2) readonly buffer Ends { uint bucket_end[]; };  // the fill pass's cursors
// The most crossings a skipped column had (0: none skipped).
layout(std430, set = 0, binding = 3) buffer Overflow { uint most_column_crossings; };
// [y][x][z]: each column's flips lie together, so its walk below reads them in order.
layout(std430, set = 0, binding = 4) buffer Toggles { uint toggles[]; };
layout(std430, set = 0, binding = 5) buffer Mask { uint mask[]; };        // [z][y][x] of the slab

layout(push_constant) uniform Params {
    uint column_base;
    uint column_count;
    uint columns;     // nx * ny
    uint frames;      // buckets per column
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

// Sorts keys[start, start + n) in place: the column's keys are this invocation's alone.
void sort_bucket(uint start, uint n) {
    if (n <= INSERTION_SORT_MAX) {
        for (uint i = 1u; i < n; ++i) {
            uint value = keys[start + i];
            uint j = i;
            for (; j > 0u && keys[start + j - 1u] > value; --j) keys[start + j] = keys[start + j - 1u];
            keys[start + j] = value;
        }
        return;
    }
    for (uint i = n / 2u; i > 0u; --i) sift_down(start, i - 1u, n);
    for (uint last = n - 1u; last > 0u; --last) {
        uint top = keys[start];
        keys[start] = keys[start + last];
        keys[start + last] = top;
        sift_down(start, 0u, last);
    }
}

void main() {
    if (gl_GlobalInvocationID.x >= params.column_count) return;
    uint column = params.column_base + gl_GlobalInvocationID.x;
    uint total = 0u;
    for (uint s = 0u; s < params.frames; ++s) total += bucket_end[column * params.frames + s] - bucket_start[column * params.frames + s];
    if (total == 0u) return;
    if (total > MAX_COLUMN_CROSSINGS) {
        atomicMax(most_column_crossings, total);
        return;
    }

    int first = params.slab_layers, last = -1;
    for (uint s = 0u; s < params.frames; ++s) {
        uint start = bucket_start[column * params.frames + s];
        uint n = bucket_end[column * params.frames + s] - start;
        if (n == 0u) continue;
        sort_bucket(start, n);
        uint bit = 1u << (uint(params.bit_offset) + s);
        int winding = 0;
        bool inside = false;
        for (uint i = 0u; i < n; ++i) {
            uint key = keys[start + i];
            int layer = int(key >> 1);
            winding += (key & 1u) != 0u ? 1 : -1;
            // Decide once every crossing of this layer is in.
            if (i + 1u < n && int(keys[start + i + 1u] >> 1) == layer) continue;
            if ((winding != 0) != inside) {
                inside = !inside;
                toggles[column * uint(params.slab_layers) + uint(layer)] ^= bit;
                first = min(first, layer);
                last = max(last, layer);
            }
        }
        // Still inside after the last crossing (the closing ones lie above the slab): to the top.
        if (inside) last = params.slab_layers - 1;
    }

    uint word = 0u;
    uint flip_base = column * uint(params.slab_layers);
    for (int z = first; z <= last; ++z) {
        uint flips = toggles[flip_base + uint(z)];
        if (flips != 0u) {
            word ^= flips;
            toggles[flip_base + uint(z)] = 0u;
        }
        if (word != 0u) mask[uint(z) * params.columns + column] |= word;
    }
}
