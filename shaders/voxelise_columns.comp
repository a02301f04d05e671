#version 450
// Pass 2 of the solid voxelisation: one invocation per (x, y) column. For every frame of the batch
// it sorts the frame's crossing keys (layer << 1 | upward) and walks them upwards with the frame's
// winding number, flipping the frame's bit in toggles[layer] wherever the voxels switch between
// inside (winding non-zero) and outside. Then an XOR up the column over the flips gives each
// layer's occupancy word, which goes into the mask. Only layers between the column's first and
// last flip are visited. Work scales with the column's crossings and span, not frames x layers.
//
// The kernel is built five times, by the specialisation constant STAGE, and dispatched in order:
//   FLIP_SMALL, one invocation per column: the buckets of at most REGISTER_KEYS keys (most of
//     them), sorted in registers by a sorting network; each column's span of flips.
//     It lists the larger buckets, and counts the workgroups of the next three stages' dispatches.
//   FLIP_MEDIUM, one invocation per listed bucket of up to MEDIUM_KEYS keys, sorted in registers by
//     a bitonic network. Frames of one column share flip words and spans, so these go in by atomics.
//   FLIP_LARGE, the same for the buckets of up to LARGE_KEYS keys.
//   FLIP_HUGE, the same for the buckets of more than LARGE_KEYS keys (rare), sorted in the key list.
//   WRITE, one invocation per column: the XOR up the column's span.
// A column with more crossings than MAX_COLUMN_CROSSINGS is skipped and flagged (FLIP_SMALL marks
// its span, WRITE leaves it), and the host redoes the batch with fewer frames. On lavapipe a sorting
// network or loop costs every invocation that passes it, taken or not, so each size of bucket has a
// kernel of its own.
// Loop work per invocation is at most frames, plus MAX_COLUMN_CROSSINGS * (log2 MAX_COLUMN_CROSSINGS
// + 2) for a large bucket's sort and walk, or slab_layers for the XOR.

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint MAX_COLUMN_CROSSINGS = 1024;
layout(constant_id = 2) const uint STAGE = 0;
const uint FLIP_SMALL = 0, FLIP_LARGE = 1, FLIP_HUGE = 2, WRITE = 3, FLIP_MEDIUM = 4;
const uint INSERTION_SORT_MAX = 12;  // huge buckets up to this size sort by insertion, larger ones by heap sort
const uint REGISTER_KEYS = 8;         // FLIP_SMALL's largest bucket
const uint MEDIUM_KEYS = 16;          // FLIP_MEDIUM's largest bucket
const uint LARGE_KEYS = 32;           // FLIP_LARGE's largest bucket
const uint MAX_GROUPS = 65535;        // an indirect dispatch's workgroups at most (the least limit Vulkan allows)
const uint NO_KEY = 0xffffffffu;       // above every key: pads a small bucket to REGISTER_KEYS
// A skipped column's span starts here, below every layer: the larger buckets' atomicMin keeps it, so
// they need not check the column themselves (their flips there are cleared before the next batch).
const int SKIPPED = -1;

layout(std430, set = 0, binding = 0) buffer Keys { uint keys[]; };
// Read-only data is read as texels: on lavapipe a texel fetch gathers all lanes at once, a
// storage-buffer load runs lane by lane.
// Bucket starts, and one more: the end of the last bucket.
layout(set = 0, binding = 1) uniform usamplerBuffer bucket_start;
layout(set = 0, binding = 2) uniform usamplerBuffer bucket_end;  // the raster's cursors
// The most crossings a skipped column had (0: none skipped).
layout(std430, set = 0, binding = 3) buffer Overflow { uint most_column_crossings; };
// [column][z]: each column's flips lie together, so its walk below reads them in order. They are
// clear before every batch: a device fill, or (in host memory) the host clearing the columns the
// batch before had room in.
layout(std430, set = 0, binding = 4) buffer Toggles { uint toggles[]; };
layout(std430, set = 0, binding = 5) buffer Mask { uint mask[]; };  // [z][y][x] of the slab
layout(set = 0, binding = 6) uniform isamplerBuffer key_quads;      // `keys` again, four a texel, for reading
layout(set = 0, binding = 7) uniform usamplerBuffer column_frames;  // per column: bit s = frame s has room
// Per column: the first and last layer with a flip (first > last: none; first == SKIPPED: skipped).
layout(std430, set = 0, binding = 8) buffer Spans { ivec2 spans[]; };
layout(std430, set = 0, binding = 9) buffer LargeBuckets { uint large_buckets[]; };  // FLIP_LARGE's
layout(std430, set = 0, binding = 10) buffer HugeBuckets { uint huge_buckets[]; };   // FLIP_HUGE's
// The host sets {0, 1, 1, 0} for each list before every batch: its indirect dispatch (x, y, z),
// then its length. x counts workgroups up to the group count limit; the stage loops past it.
struct List {
    uint groups_x, groups_y, groups_z, count;
};
const uint LARGE_LIST = 0, HUGE_LIST = 1, MEDIUM_LIST = 2;  // at byte offsets 0, 16 and 32
layout(std430, set = 0, binding = 11) buffer Lists { List lists[3]; };
layout(std430, set = 0, binding = 12) buffer MediumBuckets { uint medium_buckets[]; };  // FLIP_MEDIUM's

layout(push_constant) uniform Params {
    uint item_base;   // first column
    uint item_count;
    uint columns;     // nx * ny
    int slab_layers;
    int bit_offset;   // bit of the batch's first frame inside the word
    uint whole_word;  // 1: the batch holds every frame of the word
    uint mask_base;   // the slab's first word in `mask`
} params;

// The push constants this batch's stages use, copied once at the top of main: on lavapipe a
// push-constant read inside a branch or loop is a load per lane.
uint columns;
int slab_layers;
int bit_offset;
bool whole_word;
uint mask_base;

// Buckets lie frame by frame: bucket (column, slot) is slot * columns + column, so the raster's
// slots and keys for one frame stay together in the caches.
uint bucket_of(uint column, uint slot) { return slot * columns + column; }
uint column_of(uint bucket) { return bucket % columns; }
uint slot_of(uint bucket) { return bucket / columns; }

uint start_of(uint bucket) { return texelFetch(bucket_start, int(bucket)).x; }
uint end_of(uint bucket) { return texelFetch(bucket_end, int(bucket)).x; }

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

// The bucket's first 8 keys k0..k7 (NO_KEY past its n keys), from three texels of four keys: on
// lavapipe a texel fetch costs a loop over the lanes whatever it fetches (small buckets 4.6 -> 4.2 ms
// at 10 mm against a fetch per key). Shifted into place by the start's offset in its texel, two
// bits at a time. The key list ends in LARGE_KEYS spare slots, so a fetch past the bucket stays in
// the buffer (and is always made: on lavapipe a fetch in a branch costs as much as one outside it);
// what it reads is replaced.
#define LOAD8(start, n)                                              \
    uint k0, k1, k2, k3, k4, k5, k6, k7;                             \
    {                                                                \
        uint quad = (start) >> 2;                                    \
        uvec4 q0 = uvec4(texelFetch(key_quads, int(quad + 0u)));     \
        uvec4 q1 = uvec4(texelFetch(key_quads, int(quad + 1u)));     \
        uvec4 q2 = uvec4(texelFetch(key_quads, int(quad + 2u)));     \
        bool by2 = ((start) & 2u) != 0u, by1 = ((start) & 1u) != 0u; \
        uint a0 = by2 ? q0.z : q0.x;                                 \
        uint a1 = by2 ? q0.w : q0.y;                                 \
        uint a2 = by2 ? q1.x : q0.z;                                 \
        uint a3 = by2 ? q1.y : q0.w;                                 \
        uint a4 = by2 ? q1.z : q1.x;                                 \
        uint a5 = by2 ? q1.w : q1.y;                                 \
        uint a6 = by2 ? q2.x : q1.z;                                 \
        uint a7 = by2 ? q2.y : q1.w;                                 \
        uint a8 = by2 ? q2.z : q2.x;                                 \
        k0 = (n) > 0u ? (by1 ? a1 : a0) : NO_KEY;                    \
        k1 = (n) > 1u ? (by1 ? a2 : a1) : NO_KEY;                    \
        k2 = (n) > 2u ? (by1 ? a3 : a2) : NO_KEY;                    \
        k3 = (n) > 3u ? (by1 ? a4 : a3) : NO_KEY;                    \
        k4 = (n) > 4u ? (by1 ? a5 : a4) : NO_KEY;                    \
        k5 = (n) > 5u ? (by1 ? a6 : a5) : NO_KEY;                    \
        k6 = (n) > 6u ? (by1 ? a7 : a6) : NO_KEY;                    \
        k7 = (n) > 7u ? (by1 ? a8 : a7) : NO_KEY;                    \
    }
// The same for 16 and 32 keys (FLIP_MEDIUM and FLIP_LARGE).
#define LOAD16(start, n)                                                       \
    uint k0, k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15; \
    {                                                                          \
        uint quad = (start) >> 2;                                              \
        uvec4 q0 = uvec4(texelFetch(key_quads, int(quad + 0u)));               \
        uvec4 q1 = uvec4(texelFetch(key_quads, int(quad + 1u)));               \
        uvec4 q2 = uvec4(texelFetch(key_quads, int(quad + 2u)));               \
        uvec4 q3 = uvec4(texelFetch(key_quads, int(quad + 3u)));               \
        uvec4 q4 = uvec4(texelFetch(key_quads, int(quad + 4u)));               \
        bool by2 = ((start) & 2u) != 0u, by1 = ((start) & 1u) != 0u;           \
        uint a0 = by2 ? q0.z : q0.x;                                           \
        uint a1 = by2 ? q0.w : q0.y;                                           \
        uint a2 = by2 ? q1.x : q0.z;                                           \
        uint a3 = by2 ? q1.y : q0.w;                                           \
        uint a4 = by2 ? q1.z : q1.x;                                           \
        uint a5 = by2 ? q1.w : q1.y;                                           \
        uint a6 = by2 ? q2.x : q1.z;                                           \
        uint a7 = by2 ? q2.y : q1.w;                                           \
        uint a8 = by2 ? q2.z : q2.x;                                           \
        uint a9 = by2 ? q2.w : q2.y;                                           \
        uint a10 = by2 ? q3.x : q2.z;                                          \
        uint a11 = by2 ? q3.y : q2.w;                                          \
        uint a12 = by2 ? q3.z : q3.x;                                          \
        uint a13 = by2 ? q3.w : q3.y;                                          \
        uint a14 = by2 ? q4.x : q3.z;                                          \
        uint a15 = by2 ? q4.y : q3.w;                                          \
        uint a16 = by2 ? q4.z : q4.x;                                          \
        k0 = (n) > 0u ? (by1 ? a1 : a0) : NO_KEY;                              \
        k1 = (n) > 1u ? (by1 ? a2 : a1) : NO_KEY;                              \
        k2 = (n) > 2u ? (by1 ? a3 : a2) : NO_KEY;                              \
        k3 = (n) > 3u ? (by1 ? a4 : a3) : NO_KEY;                              \
        k4 = (n) > 4u ? (by1 ? a5 : a4) : NO_KEY;                              \
        k5 = (n) > 5u ? (by1 ? a6 : a5) : NO_KEY;                              \
        k6 = (n) > 6u ? (by1 ? a7 : a6) : NO_KEY;                              \
        k7 = (n) > 7u ? (by1 ? a8 : a7) : NO_KEY;                              \
        k8 = (n) > 8u ? (by1 ? a9 : a8) : NO_KEY;                              \
        k9 = (n) > 9u ? (by1 ? a10 : a9) : NO_KEY;                             \
        k10 = (n) > 10u ? (by1 ? a11 : a10) : NO_KEY;                          \
        k11 = (n) > 11u ? (by1 ? a12 : a11) : NO_KEY;                          \
        k12 = (n) > 12u ? (by1 ? a13 : a12) : NO_KEY;                          \
        k13 = (n) > 13u ? (by1 ? a14 : a13) : NO_KEY;                          \
        k14 = (n) > 14u ? (by1 ? a15 : a14) : NO_KEY;                          \
        k15 = (n) > 15u ? (by1 ? a16 : a15) : NO_KEY;                          \
    }
#define LOAD32(start, n)                                                                                                                                       \
    uint k0, k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, k16, k17, k18, k19, k20, k21, k22, k23, k24, k25, k26, k27, k28, k29, k30, k31; \
    {                                                                                                                                                          \
        uint quad = (start) >> 2;                                                                                                                              \
        uvec4 q0 = uvec4(texelFetch(key_quads, int(quad + 0u)));                                                                                               \
        uvec4 q1 = uvec4(texelFetch(key_quads, int(quad + 1u)));                                                                                               \
        uvec4 q2 = uvec4(texelFetch(key_quads, int(quad + 2u)));                                                                                               \
        uvec4 q3 = uvec4(texelFetch(key_quads, int(quad + 3u)));                                                                                               \
        uvec4 q4 = uvec4(texelFetch(key_quads, int(quad + 4u)));                                                                                               \
        uvec4 q5 = uvec4(texelFetch(key_quads, int(quad + 5u)));                                                                                               \
        uvec4 q6 = uvec4(texelFetch(key_quads, int(quad + 6u)));                                                                                               \
        uvec4 q7 = uvec4(texelFetch(key_quads, int(quad + 7u)));                                                                                               \
        uvec4 q8 = uvec4(texelFetch(key_quads, int(quad + 8u)));                                                                                               \
        bool by2 = ((start) & 2u) != 0u, by1 = ((start) & 1u) != 0u;                                                                                           \
        uint a0 = by2 ? q0.z : q0.x;                                                                                                                           \
        uint a1 = by2 ? q0.w : q0.y;                                                                                                                           \
        uint a2 = by2 ? q1.x : q0.z;                                                                                                                           \
        uint a3 = by2 ? q1.y : q0.w;                                                                                                                           \
        uint a4 = by2 ? q1.z : q1.x;                                                                                                                           \
        uint a5 = by2 ? q1.w : q1.y;                                                                                                                           \
        uint a6 = by2 ? q2.x : q1.z;                                                                                                                           \
        uint a7 = by2 ? q2.y : q1.w;                                                                                                                           \
        uint a8 = by2 ? q2.z : q2.x;                                                                                                                           \
        uint a9 = by2 ? q2.w : q2.y;                                                                                                                           \
        uint a10 = by2 ? q3.x : q2.z;                                                                                                                          \
        uint a11 = by2 ? q3.y : q2.w;                                                                                                                          \
        uint a12 = by2 ? q3.z : q3.x;                                                                                                                          \
        uint a13 = by2 ? q3.w : q3.y;                                                                                                                          \
        uint a14 = by2 ? q4.x : q3.z;                                                                                                                          \
        uint a15 = by2 ? q4.y : q3.w;                                                                                                                          \
        uint a16 = by2 ? q4.z : q4.x;                                                                                                                          \
        uint a17 = by2 ? q4.w : q4.y;                                                                                                                          \
        uint a18 = by2 ? q5.x : q4.z;                                                                                                                          \
        uint a19 = by2 ? q5.y : q4.w;                                                                                                                          \
        uint a20 = by2 ? q5.z : q5.x;                                                                                                                          \
        uint a21 = by2 ? q5.w : q5.y;                                                                                                                          \
        uint a22 = by2 ? q6.x : q5.z;                                                                                                                          \
        uint a23 = by2 ? q6.y : q5.w;                                                                                                                          \
        uint a24 = by2 ? q6.z : q6.x;                                                                                                                          \
        uint a25 = by2 ? q6.w : q6.y;                                                                                                                          \
        uint a26 = by2 ? q7.x : q6.z;                                                                                                                          \
        uint a27 = by2 ? q7.y : q6.w;                                                                                                                          \
        uint a28 = by2 ? q7.z : q7.x;                                                                                                                          \
        uint a29 = by2 ? q7.w : q7.y;                                                                                                                          \
        uint a30 = by2 ? q8.x : q7.z;                                                                                                                          \
        uint a31 = by2 ? q8.y : q7.w;                                                                                                                          \
        uint a32 = by2 ? q8.z : q8.x;                                                                                                                          \
        k0 = (n) > 0u ? (by1 ? a1 : a0) : NO_KEY;                                                                                                              \
        k1 = (n) > 1u ? (by1 ? a2 : a1) : NO_KEY;                                                                                                              \
        k2 = (n) > 2u ? (by1 ? a3 : a2) : NO_KEY;                                                                                                              \
        k3 = (n) > 3u ? (by1 ? a4 : a3) : NO_KEY;                                                                                                              \
        k4 = (n) > 4u ? (by1 ? a5 : a4) : NO_KEY;                                                                                                              \
        k5 = (n) > 5u ? (by1 ? a6 : a5) : NO_KEY;                                                                                                              \
        k6 = (n) > 6u ? (by1 ? a7 : a6) : NO_KEY;                                                                                                              \
        k7 = (n) > 7u ? (by1 ? a8 : a7) : NO_KEY;                                                                                                              \
        k8 = (n) > 8u ? (by1 ? a9 : a8) : NO_KEY;                                                                                                              \
        k9 = (n) > 9u ? (by1 ? a10 : a9) : NO_KEY;                                                                                                             \
        k10 = (n) > 10u ? (by1 ? a11 : a10) : NO_KEY;                                                                                                          \
        k11 = (n) > 11u ? (by1 ? a12 : a11) : NO_KEY;                                                                                                          \
        k12 = (n) > 12u ? (by1 ? a13 : a12) : NO_KEY;                                                                                                          \
        k13 = (n) > 13u ? (by1 ? a14 : a13) : NO_KEY;                                                                                                          \
        k14 = (n) > 14u ? (by1 ? a15 : a14) : NO_KEY;                                                                                                          \
        k15 = (n) > 15u ? (by1 ? a16 : a15) : NO_KEY;                                                                                                          \
        k16 = (n) > 16u ? (by1 ? a17 : a16) : NO_KEY;                                                                                                          \
        k17 = (n) > 17u ? (by1 ? a18 : a17) : NO_KEY;                                                                                                          \
        k18 = (n) > 18u ? (by1 ? a19 : a18) : NO_KEY;                                                                                                          \
        k19 = (n) > 19u ? (by1 ? a20 : a19) : NO_KEY;                                                                                                          \
        k20 = (n) > 20u ? (by1 ? a21 : a20) : NO_KEY;                                                                                                          \
        k21 = (n) > 21u ? (by1 ? a22 : a21) : NO_KEY;                                                                                                          \
        k22 = (n) > 22u ? (by1 ? a23 : a22) : NO_KEY;                                                                                                          \
        k23 = (n) > 23u ? (by1 ? a24 : a23) : NO_KEY;                                                                                                          \
        k24 = (n) > 24u ? (by1 ? a25 : a24) : NO_KEY;                                                                                                          \
        k25 = (n) > 25u ? (by1 ? a26 : a25) : NO_KEY;                                                                                                          \
        k26 = (n) > 26u ? (by1 ? a27 : a26) : NO_KEY;                                                                                                          \
        k27 = (n) > 27u ? (by1 ? a28 : a27) : NO_KEY;                                                                                                          \
        k28 = (n) > 28u ? (by1 ? a29 : a28) : NO_KEY;                                                                                                          \
        k29 = (n) > 29u ? (by1 ? a30 : a29) : NO_KEY;                                                                                                          \
        k30 = (n) > 30u ? (by1 ? a31 : a30) : NO_KEY;                                                                                                          \
        k31 = (n) > 31u ? (by1 ? a32 : a31) : NO_KEY;                                                                                                          \
    }

// One step of a register bucket walk: `key` is the bucket's i-th key in order, `next` the one
// after it (NO_KEY past the end); keys from the n-th on are not. The winding number changes by
// each key; once every key of a layer is in, the voxels above are inside when it is non-zero, and
// an inside/outside switch is a flip of the frame's bit at that layer, recorded as bit i of
// flip_bits. The flips are written after the walk, in a loop only as long as the subgroup's most
// flips: on lavapipe a buffer access in a branch costs a loop over the lanes whether or not a lane
// takes it.
#define WALK_BIT(key, next, i)                                                      \
    {                                                                               \
        bool valid = (i) < n;                                                       \
        int layer = int((key) >> 1);                                                \
        winding += valid ? (((key) & 1u) != 0u ? 1 : -1) : 0;                      \
        bool flip = valid && int((next) >> 1) != layer && (winding != 0) != inside; \
        inside = inside != flip;                                                    \
        flip_bits |= flip ? 1u << (i) : 0u;                                         \
    }
// Key i of k0..k7, by a tree of selects: registers cannot be indexed.
#define PICK8(i) (((i) & 4u) != 0u ? (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k7 : k6) : (((i) & 1u) != 0u ? k5 : k4)) \
                                   : (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k3 : k2) : (((i) & 1u) != 0u ? k1 : k0)))
// XORs the frame's `bit` into the flip word of every layer in flip_bits, at `flip_base`. By atomics
// also where the column's flips are the invocation's alone (FLIP_SMALL): on lavapipe an atomic XOR
// is one loop over the lanes where `^=` is two, a load's and a store's (that stage 0.6 ms faster at
// 10 mm). PICK is the select tree of the bucket's registers.
#define XOR_FLIPS(PICK)                                                        \
    for (uint pending = flip_bits; pending != 0u; pending &= pending - 1u) {   \
        uint i = uint(findLSB(pending));                                       \
        atomicXor(toggles[flip_base + (PICK(i) >> 1)], bit);                   \
    }
#define ORDER(a, b)              \
    {                            \
        uint lower = min(a, b);  \
        b = max(a, b);           \
        a = lower;               \
    }

// The XOR up the column over its flips, from layer `first` to `last`. A batch that holds a whole
// occupancy word writes the mask outright; smaller batches OR their frames' bits into it.
void write_column(uint column, int first, int last) {
    uint flip_base = column * uint(slab_layers);
    uint word = 0u;
    if (whole_word) {
        for (int z = first; z <= last; ++z) {
            word ^= toggles[flip_base + uint(z)];
            mask[mask_base + uint(z) * columns + column] = word;
        }
    } else {
        for (int z = first; z <= last; ++z) {
            word ^= toggles[flip_base + uint(z)];
            // An atomic OR: one loop over the lanes on lavapipe, where `|=` is two.
            if (word != 0u) atomicOr(mask[mask_base + uint(z) * columns + column], word);
        }
    }
}

// Lists a column's buckets of frames `frames` in list `list`: it takes their places at once, and the
// workgroups of the list's indirect dispatch that those places begin (up to MAX_GROUPS) are counted.
void list_buckets(uint column, uint frames, uint list) {
    uint count = uint(bitCount(frames));
    uint index = atomicAdd(lists[list].count, count);
    uint groups_before = min((index + gl_WorkGroupSize.x - 1u) / gl_WorkGroupSize.x, MAX_GROUPS);
    uint groups_after = min((index + count + gl_WorkGroupSize.x - 1u) / gl_WorkGroupSize.x, MAX_GROUPS);
    if (groups_after != groups_before) atomicAdd(lists[list].groups_x, groups_after - groups_before);
    for (uint pending = frames; pending != 0u; pending &= pending - 1u) {
        uint bucket = bucket_of(column, uint(findLSB(pending)));
        if (list == MEDIUM_LIST) medium_buckets[index] = bucket;
        else if (list == LARGE_LIST) large_buckets[index] = bucket;
        else huge_buckets[index] = bucket;
        ++index;
    }
}

void flip_small(uint column) {
    uint with_room = texelFetch(column_frames, int(column)).x;
    int first = slab_layers, last = -1;
    uint total = 0u;
    uint flip_base = column * uint(slab_layers);
    // The frames whose buckets the next stages take, listed after the loop: on lavapipe a list's
    // atomics and store in the loop would cost every frame of every column.
    uint medium_frames = 0u, large_frames = 0u, huge_frames = 0u;
    // Only the frames with room in this column: most columns see the surface in few of them.
    for (uint pending = with_room; pending != 0u; pending &= pending - 1u) {
        uint s = uint(findLSB(pending));
        uint start = start_of(bucket_of(column, s));
        uint n = end_of(bucket_of(column, s)) - start;
        total += n;
        if (n > REGISTER_KEYS) {  // the next stages'
            uint frame_bit = 1u << s;
            if (n <= MEDIUM_KEYS) medium_frames |= frame_bit;
            else if (n <= LARGE_KEYS) large_frames |= frame_bit;
            else huge_frames |= frame_bit;
            continue;
        }
        LOAD8(start, n)
        // An optimal sorting network for 8 keys (19 comparators).
        ORDER(k0, k2) ORDER(k1, k3) ORDER(k4, k6) ORDER(k5, k7)
        ORDER(k0, k4) ORDER(k1, k5) ORDER(k2, k6) ORDER(k3, k7)
        ORDER(k0, k1) ORDER(k2, k3) ORDER(k4, k5) ORDER(k6, k7)
        ORDER(k2, k4) ORDER(k3, k5)
        ORDER(k1, k4) ORDER(k3, k6)
        ORDER(k1, k2) ORDER(k3, k4) ORDER(k5, k6)
        int winding = 0;
        bool inside = false;
        uint flip_bits = 0u;
        WALK_BIT(k0, k1, 0u) WALK_BIT(k1, k2, 1u) WALK_BIT(k2, k3, 2u) WALK_BIT(k3, k4, 3u)
        WALK_BIT(k4, k5, 4u) WALK_BIT(k5, k6, 5u) WALK_BIT(k6, k7, 6u) WALK_BIT(k7, NO_KEY, 7u)
        uint bit = 1u << (uint(bit_offset) + s);
        XOR_FLIPS(PICK8)
        if (flip_bits != 0u) {
            uint i = uint(findLSB(flip_bits));
            first = min(first, int(PICK8(i) >> 1));
            i = uint(findMSB(flip_bits));
            last = max(last, int(PICK8(i) >> 1));
        }
        // Still inside after the last crossing (the closing ones lie above the slab): to the top.
        if (inside) last = slab_layers - 1;
    }
    if (medium_frames != 0u) list_buckets(column, medium_frames, MEDIUM_LIST);
    if (large_frames != 0u) list_buckets(column, large_frames, LARGE_LIST);
    if (huge_frames != 0u) list_buckets(column, huge_frames, HUGE_LIST);
    if (total > MAX_COLUMN_CROSSINGS) {
        // Skipped: its flips are left for the next batch's clear, and nothing is written.
        atomicMax(most_column_crossings, total);
        first = SKIPPED;
        last = -1;
    }
    spans[column] = ivec2(first, last);
}

// The end of a larger bucket's walk: its flips and its column's span go in by atomics (frames of
// one column share them). PICK is the select tree of the bucket's registers.
#define ADD_FLIPS(PICK)                                                                          \
    if (flip_bits == 0u) return;                                                                 \
    uint bit = 1u << (uint(bit_offset) + slot_of(bucket));                                       \
    uint flip_base = column * uint(slab_layers);                                                 \
    XOR_FLIPS(PICK)                                                                              \
    uint i = uint(findLSB(flip_bits));                                                           \
    int first = int(PICK(i) >> 1);                                                               \
    i = uint(findMSB(flip_bits));                                                                \
    /* Still inside after the last crossing (the closing ones lie above the slab): to the top. */ \
    int last = inside ? slab_layers - 1 : int(PICK(i) >> 1);                                     \
    atomicMin(spans[column].x, first);                                                           \
    atomicMax(spans[column].y, last);

// Key i of k0..k31, by a tree of selects: registers cannot be indexed.
#define PICK32(i) (((i) & 16u) != 0u ? (((i) & 8u) != 0u ? (((i) & 4u) != 0u ? (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k31 : k30) : (((i) & 1u) != 0u ? k29 : k28)) : (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k27 : k26) : (((i) & 1u) != 0u ? k25 : k24))) : (((i) & 4u) != 0u ? (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k23 : k22) : (((i) & 1u) != 0u ? k21 : k20)) : (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k19 : k18) : (((i) & 1u) != 0u ? k17 : k16)))) : (((i) & 8u) != 0u ? (((i) & 4u) != 0u ? (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k15 : k14) : (((i) & 1u) != 0u ? k13 : k12)) : (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k11 : k10) : (((i) & 1u) != 0u ? k9 : k8))) : (((i) & 4u) != 0u ? (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k7 : k6) : (((i) & 1u) != 0u ? k5 : k4)) : (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k3 : k2) : (((i) & 1u) != 0u ? k1 : k0)))))

void flip_large(uint bucket) {
    uint start = start_of(bucket);
    uint n = end_of(bucket) - start;
    uint column = column_of(bucket);
    LOAD32(start, n)
    // Batcher's bitonic sorting network for 32 keys (240 comparators), merge by merge.
    /* merge 2, stride 1 */
    ORDER(k0, k1) ORDER(k3, k2) ORDER(k4, k5) ORDER(k7, k6) ORDER(k8, k9) ORDER(k11, k10) ORDER(k12, k13) ORDER(k15, k14)
    ORDER(k16, k17) ORDER(k19, k18) ORDER(k20, k21) ORDER(k23, k22) ORDER(k24, k25) ORDER(k27, k26) ORDER(k28, k29) ORDER(k31, k30)
    /* merge 4, stride 2 */
    ORDER(k0, k2) ORDER(k1, k3) ORDER(k6, k4) ORDER(k7, k5) ORDER(k8, k10) ORDER(k9, k11) ORDER(k14, k12) ORDER(k15, k13)
    ORDER(k16, k18) ORDER(k17, k19) ORDER(k22, k20) ORDER(k23, k21) ORDER(k24, k26) ORDER(k25, k27) ORDER(k30, k28) ORDER(k31, k29)
    /* merge 4, stride 1 */
    ORDER(k0, k1) ORDER(k2, k3) ORDER(k5, k4) ORDER(k7, k6) ORDER(k8, k9) ORDER(k10, k11) ORDER(k13, k12) ORDER(k15, k14)
    ORDER(k16, k17) ORDER(k18, k19) ORDER(k21, k20) ORDER(k23, k22) ORDER(k24, k25) ORDER(k26, k27) ORDER(k29, k28) ORDER(k31, k30)
    /* merge 8, stride 4 */
    ORDER(k0, k4) ORDER(k1, k5) ORDER(k2, k6) ORDER(k3, k7) ORDER(k12, k8) ORDER(k13, k9) ORDER(k14, k10) ORDER(k15, k11)
    ORDER(k16, k20) ORDER(k17, k21) ORDER(k18, k22) ORDER(k19, k23) ORDER(k28, k24) ORDER(k29, k25) ORDER(k30, k26) ORDER(k31, k27)
    /* merge 8, stride 2 */
    ORDER(k0, k2) ORDER(k1, k3) ORDER(k4, k6) ORDER(k5, k7) ORDER(k10, k8) ORDER(k11, k9) ORDER(k14, k12) ORDER(k15, k13)
    ORDER(k16, k18) ORDER(k17, k19) ORDER(k20, k22) ORDER(k21, k23) ORDER(k26, k24) ORDER(k27, k25) ORDER(k30, k28) ORDER(k31, k29)
    /* merge 8, stride 1 */
    ORDER(k0, k1) ORDER(k2, k3) ORDER(k4, k5) ORDER(k6, k7) ORDER(k9, k8) ORDER(k11, k10) ORDER(k13, k12) ORDER(k15, k14)
    ORDER(k16, k17) ORDER(k18, k19) ORDER(k20, k21) ORDER(k22, k23) ORDER(k25, k24) ORDER(k27, k26) ORDER(k29, k28) ORDER(k31, k30)
    /* merge 16, stride 8 */
    ORDER(k0, k8) ORDER(k1, k9) ORDER(k2, k10) ORDER(k3, k11) ORDER(k4, k12) ORDER(k5, k13) ORDER(k6, k14) ORDER(k7, k15)
    ORDER(k24, k16) ORDER(k25, k17) ORDER(k26, k18) ORDER(k27, k19) ORDER(k28, k20) ORDER(k29, k21) ORDER(k30, k22) ORDER(k31, k23)
    /* merge 16, stride 4 */
    ORDER(k0, k4) ORDER(k1, k5) ORDER(k2, k6) ORDER(k3, k7) ORDER(k8, k12) ORDER(k9, k13) ORDER(k10, k14) ORDER(k11, k15)
    ORDER(k20, k16) ORDER(k21, k17) ORDER(k22, k18) ORDER(k23, k19) ORDER(k28, k24) ORDER(k29, k25) ORDER(k30, k26) ORDER(k31, k27)
    /* merge 16, stride 2 */
    ORDER(k0, k2) ORDER(k1, k3) ORDER(k4, k6) ORDER(k5, k7) ORDER(k8, k10) ORDER(k9, k11) ORDER(k12, k14) ORDER(k13, k15)
    ORDER(k18, k16) ORDER(k19, k17) ORDER(k22, k20) ORDER(k23, k21) ORDER(k26, k24) ORDER(k27, k25) ORDER(k30, k28) ORDER(k31, k29)
    /* merge 16, stride 1 */
    ORDER(k0, k1) ORDER(k2, k3) ORDER(k4, k5) ORDER(k6, k7) ORDER(k8, k9) ORDER(k10, k11) ORDER(k12, k13) ORDER(k14, k15)
    ORDER(k17, k16) ORDER(k19, k18) ORDER(k21, k20) ORDER(k23, k22) ORDER(k25, k24) ORDER(k27, k26) ORDER(k29, k28) ORDER(k31, k30)
    /* merge 32, stride 16 */
    ORDER(k0, k16) ORDER(k1, k17) ORDER(k2, k18) ORDER(k3, k19) ORDER(k4, k20) ORDER(k5, k21) ORDER(k6, k22) ORDER(k7, k23)
    ORDER(k8, k24) ORDER(k9, k25) ORDER(k10, k26) ORDER(k11, k27) ORDER(k12, k28) ORDER(k13, k29) ORDER(k14, k30) ORDER(k15, k31)
    /* merge 32, stride 8 */
    ORDER(k0, k8) ORDER(k1, k9) ORDER(k2, k10) ORDER(k3, k11) ORDER(k4, k12) ORDER(k5, k13) ORDER(k6, k14) ORDER(k7, k15)
    ORDER(k16, k24) ORDER(k17, k25) ORDER(k18, k26) ORDER(k19, k27) ORDER(k20, k28) ORDER(k21, k29) ORDER(k22, k30) ORDER(k23, k31)
    /* merge 32, stride 4 */
    ORDER(k0, k4) ORDER(k1, k5) ORDER(k2, k6) ORDER(k3, k7) ORDER(k8, k12) ORDER(k9, k13) ORDER(k10, k14) ORDER(k11, k15)
    ORDER(k16, k20) ORDER(k17, k21) ORDER(k18, k22) ORDER(k19, k23) ORDER(k24, k28) ORDER(k25, k29) ORDER(k26, k30) ORDER(k27, k31)
    /* merge 32, stride 2 */
    ORDER(k0, k2) ORDER(k1, k3) ORDER(k4, k6) ORDER(k5, k7) ORDER(k8, k10) ORDER(k9, k11) ORDER(k12, k14) ORDER(k13, k15)
    ORDER(k16, k18) ORDER(k17, k19) ORDER(k20, k22) ORDER(k21, k23) ORDER(k24, k26) ORDER(k25, k27) ORDER(k28, k30) ORDER(k29, k31)
    /* merge 32, stride 1 */
    ORDER(k0, k1) ORDER(k2, k3) ORDER(k4, k5) ORDER(k6, k7) ORDER(k8, k9) ORDER(k10, k11) ORDER(k12, k13) ORDER(k14, k15)
    ORDER(k16, k17) ORDER(k18, k19) ORDER(k20, k21) ORDER(k22, k23) ORDER(k24, k25) ORDER(k26, k27) ORDER(k28, k29) ORDER(k30, k31)
    int winding = 0;
    bool inside = false;
    uint flip_bits = 0u;
    WALK_BIT(k0, k1, 0u) WALK_BIT(k1, k2, 1u) WALK_BIT(k2, k3, 2u) WALK_BIT(k3, k4, 3u)
    WALK_BIT(k4, k5, 4u) WALK_BIT(k5, k6, 5u) WALK_BIT(k6, k7, 6u) WALK_BIT(k7, k8, 7u)
    WALK_BIT(k8, k9, 8u) WALK_BIT(k9, k10, 9u) WALK_BIT(k10, k11, 10u) WALK_BIT(k11, k12, 11u)
    WALK_BIT(k12, k13, 12u) WALK_BIT(k13, k14, 13u) WALK_BIT(k14, k15, 14u) WALK_BIT(k15, k16, 15u)
    WALK_BIT(k16, k17, 16u) WALK_BIT(k17, k18, 17u) WALK_BIT(k18, k19, 18u) WALK_BIT(k19, k20, 19u)
    WALK_BIT(k20, k21, 20u) WALK_BIT(k21, k22, 21u) WALK_BIT(k22, k23, 22u) WALK_BIT(k23, k24, 23u)
    WALK_BIT(k24, k25, 24u) WALK_BIT(k25, k26, 25u) WALK_BIT(k26, k27, 26u) WALK_BIT(k27, k28, 27u)
    WALK_BIT(k28, k29, 28u) WALK_BIT(k29, k30, 29u) WALK_BIT(k30, k31, 30u) WALK_BIT(k31, NO_KEY, 31u)
    ADD_FLIPS(PICK32)
}

// Key i of k0..k15, by a tree of selects.
#define PICK16(i) (((i) & 8u) != 0u ? (((i) & 4u) != 0u ? (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k15 : k14) : (((i) & 1u) != 0u ? k13 : k12)) : (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k11 : k10) : (((i) & 1u) != 0u ? k9 : k8))) : (((i) & 4u) != 0u ? (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k7 : k6) : (((i) & 1u) != 0u ? k5 : k4)) : (((i) & 2u) != 0u ? (((i) & 1u) != 0u ? k3 : k2) : (((i) & 1u) != 0u ? k1 : k0))))

void flip_medium(uint bucket) {
    uint start = start_of(bucket);
    uint n = end_of(bucket) - start;
    uint column = column_of(bucket);
    LOAD16(start, n)
    // Batcher's bitonic sorting network for 16 keys (80 comparators): FLIP_LARGE's first four merges,
    // on k0..k15 alone.
    /* merge 2, stride 1 */
    ORDER(k0, k1) ORDER(k3, k2) ORDER(k4, k5) ORDER(k7, k6) ORDER(k8, k9) ORDER(k11, k10) ORDER(k12, k13) ORDER(k15, k14)
    /* merge 4, stride 2 */
    ORDER(k0, k2) ORDER(k1, k3) ORDER(k6, k4) ORDER(k7, k5) ORDER(k8, k10) ORDER(k9, k11) ORDER(k14, k12) ORDER(k15, k13)
    /* merge 4, stride 1 */
    ORDER(k0, k1) ORDER(k2, k3) ORDER(k5, k4) ORDER(k7, k6) ORDER(k8, k9) ORDER(k10, k11) ORDER(k13, k12) ORDER(k15, k14)
    /* merge 8, stride 4 */
    ORDER(k0, k4) ORDER(k1, k5) ORDER(k2, k6) ORDER(k3, k7) ORDER(k12, k8) ORDER(k13, k9) ORDER(k14, k10) ORDER(k15, k11)
    /* merge 8, stride 2 */
    ORDER(k0, k2) ORDER(k1, k3) ORDER(k4, k6) ORDER(k5, k7) ORDER(k10, k8) ORDER(k11, k9) ORDER(k14, k12) ORDER(k15, k13)
    /* merge 8, stride 1 */
    ORDER(k0, k1) ORDER(k2, k3) ORDER(k4, k5) ORDER(k6, k7) ORDER(k9, k8) ORDER(k11, k10) ORDER(k13, k12) ORDER(k15, k14)
    /* merge 16, stride 8 */
    ORDER(k0, k8) ORDER(k1, k9) ORDER(k2, k10) ORDER(k3, k11) ORDER(k4, k12) ORDER(k5, k13) ORDER(k6, k14) ORDER(k7, k15)
    /* merge 16, stride 4 */
    ORDER(k0, k4) ORDER(k1, k5) ORDER(k2, k6) ORDER(k3, k7) ORDER(k8, k12) ORDER(k9, k13) ORDER(k10, k14) ORDER(k11, k15)
    /* merge 16, stride 2 */
    ORDER(k0, k2) ORDER(k1, k3) ORDER(k4, k6) ORDER(k5, k7) ORDER(k8, k10) ORDER(k9, k11) ORDER(k12, k14) ORDER(k13, k15)
    /* merge 16, stride 1 */
    ORDER(k0, k1) ORDER(k2, k3) ORDER(k4, k5) ORDER(k6, k7) ORDER(k8, k9) ORDER(k10, k11) ORDER(k12, k13) ORDER(k14, k15)
    int winding = 0;
    bool inside = false;
    uint flip_bits = 0u;
    WALK_BIT(k0, k1, 0u) WALK_BIT(k1, k2, 1u) WALK_BIT(k2, k3, 2u) WALK_BIT(k3, k4, 3u)
    WALK_BIT(k4, k5, 4u) WALK_BIT(k5, k6, 5u) WALK_BIT(k6, k7, 6u) WALK_BIT(k7, k8, 7u)
    WALK_BIT(k8, k9, 8u) WALK_BIT(k9, k10, 9u) WALK_BIT(k10, k11, 10u) WALK_BIT(k11, k12, 11u)
    WALK_BIT(k12, k13, 12u) WALK_BIT(k13, k14, 13u) WALK_BIT(k14, k15, 14u) WALK_BIT(k15, NO_KEY, 15u)
    ADD_FLIPS(PICK16)
}

void flip_huge(uint bucket) {
    uint start = start_of(bucket);
    uint n = end_of(bucket) - start;
    uint column = column_of(bucket);
    // A bucket this large lies in a skipped column: no sort, whose work would be unbounded.
    if (n > MAX_COLUMN_CROSSINGS) return;
    sort_bucket(start, n);
    uint bit = 1u << (uint(bit_offset) + slot_of(bucket));
    uint flip_base = column * uint(slab_layers);
    int first = slab_layers, last = -1;
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
            atomicXor(toggles[flip_base + uint(layer)], bit);
            first = min(first, layer);
            last = max(last, layer);
        }
    }
    if (inside) last = slab_layers - 1;
    if (first <= last) {
        atomicMin(spans[column].x, first);
        atomicMax(spans[column].y, last);
    }
}

// The per-column stages take their columns through spread_group, a permutation of the dispatch's
// workgroups that deals consecutive ones to SPREAD_STRIPES stripes of the grid. lavapipe gives each
// of its threads one contiguous share of a dispatch's workgroups: with the columns in order, one
// thread got the rows the body stands in and the other mostly empty ones (1.4x on two threads
// instead of 2x). The raster keeps its order: its shares are different frames, already even.
const uint SPREAD_STRIPES = 16;
uint spread_group(uint group, uint groups) {
    uint rows = (groups + SPREAD_STRIPES - 1) / SPREAD_STRIPES;  // of the stripes-wide matrix the groups fill row by row
    uint full_stripes = groups - (rows - 1) * SPREAD_STRIPES;  // stripes with `rows` groups; the others have one less
    uint stripe = group % SPREAD_STRIPES, row = group / SPREAD_STRIPES;
    return stripe * (rows - 1) + min(stripe, full_stripes) + row;
}

void main() {
    columns = params.columns;
    slab_layers = params.slab_layers;
    bit_offset = params.bit_offset;
    whole_word = params.whole_word != 0u;
    mask_base = params.mask_base;
    // The listed stages run as many workgroups as FLIP_SMALL counted, up to MAX_GROUPS, and step
    // over the rest of their list.
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    if (STAGE == FLIP_LARGE) {
        for (uint i = gl_GlobalInvocationID.x; i < lists[LARGE_LIST].count; i += stride) flip_large(large_buckets[i]);
        return;
    }
    if (STAGE == FLIP_MEDIUM) {
        for (uint i = gl_GlobalInvocationID.x; i < lists[MEDIUM_LIST].count; i += stride) flip_medium(medium_buckets[i]);
        return;
    }
    if (STAGE == FLIP_HUGE) {
        for (uint i = gl_GlobalInvocationID.x; i < lists[HUGE_LIST].count; i += stride) flip_huge(huge_buckets[i]);
        return;
    }
    uint index = spread_group(gl_WorkGroupID.x, gl_NumWorkGroups.x) * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
    if (index >= params.item_count) return;
    uint item = params.item_base + index;
    if (STAGE == FLIP_SMALL) flip_small(item);
    else {
        ivec2 span = spans[item];
        if (span.x != SKIPPED) write_column(item, span.x, span.y);
    }
}
