#version 450
// Overlap maps of the placement sweep (docs/method.md section 5): for every pose offset (i, j) of the
// range at once, does the fixed volume (A's side) share a voxel with the moving volume (B's side,
// pulled under A's lattice at offset 0 by the host)? Both volumes come as slice runs
// (src/sweep/slice_runs.hpp): a fixed run (y_a, [xa0, xa1]) and a pulled run (y_b, [xb0, xb1]) at
// the same z and slot pair overlap exactly at the offsets j = y_a - y_b, xa0 - xb1 <= i <= xa1 - xb0.
// The map is the union of those intervals, one bit per offset, so its cost is one step per pair
// of runs, whatever the number of poses. Where only some poses are still in play, the host gives
// each pulled run only the rows that can reach one, and drops runs that reach none: the map is
// then exact on those poses, the only ones read.
//
// One invocation handles one work item = (pulled run, chunk of the fixed runs at its key). With
// several heights of B in one sweep run, B's runs come at its lowest height, each with the height
// it is paired at: raised by h more, a run at slice z meets the fixed runs at z + h and sets the
// map of its angle at that height. The host sizes the chunks so that a binary search plus runs *
// (words an interval spans + 4) stays under lavapipe's per-invocation loop cap.
layout(local_size_x_id = 0) in;

// Pulled runs: y relative to fixed_y0 (16 bits, signed) | the height it is paired at << 16,
// x_first | x_last << 16 relative to pulled_x0, key, and the rows j the run is paired on (first |
// last << 16), cut by the host to where poses are still in play.
struct Run {
    uint y_heights;
    uint x;
    int key;
    uint rows;
};
// Packed to halve the loads: (y, x_first | x_last << 16), relative to (fixed_x0, fixed_y0); sorted
// by key, then y.
// Read as texels, one (y, x) per run.
layout(set = 0, binding = 0) uniform usamplerBuffer fixed_runs;
layout(std430, set = 0, binding = 1) readonly buffer FixedKeys { ivec2 fixed_keys[]; };  // per key: first run, count
layout(std430, set = 0, binding = 2) readonly buffer PulledRuns { Run pulled_runs[]; };
// [angle in batch][height][map][row j][word]: bit i of a row is offset range_i0 + i.
layout(std430, set = 0, binding = 3) buffer Maps { uint maps[]; };
// The same maps read through the sampler path, which lavapipe gathers for all lanes at once (a
// storage load runs lane by lane): a stale word only costs an atomic that sets nothing new.
layout(set = 0, binding = 4) uniform usamplerBuffer map_texels;

layout(push_constant) uniform Params {
    uint item_base;
    uint item_count;
    int heights;
    int chunks, runs_per_chunk;
    int zbits, slot_count;
    int range_i0, range_j0, range_ni, range_nj, row_words;
    // 1: one map per slot pair (every-frame tests); 0: one map for all.
    int map_per_slot;
    int fixed_x0, fixed_y0, pulled_x0;
    // Words the texel view covers (the device's texel limit may be below the maps' size).
    uint texel_words;
} params;

// Word w of the maps as far as the texel view shows it; past the view, none of its bits.
uint seen(uint w) { return w < params.texel_words ? texelFetch(map_texels, int(w)).x : 0u; }

void main() {
    uint item = params.item_base + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= params.item_count) return;
    Run b = pulled_runs[item / uint(params.chunks)];
    int chunk = int(item % uint(params.chunks));
    int h = int(b.y_heights >> 16u);
    int z = b.key % params.zbits + h;
    if (z >= params.zbits) return;
    int b_y = int(b.y_heights << 16) >> 16;  // relative to fixed_y0
    int angle_slot = b.key / params.zbits;
    int slot = angle_slot % params.slot_count, angle = angle_slot / params.slot_count;
    ivec2 key = fixed_keys[slot * params.zbits + z];
    int b_x_first = int(b.x & 0xffffu) + params.pulled_x0, b_x_last = int(b.x >> 16u) + params.pulled_x0;
    int y_first = b_y + params.range_j0 + int(b.rows & 0xffffu), y_last = b_y + params.range_j0 + int(b.rows >> 16u);
    // A key's fixed runs are sorted by y: start at the first one on row y_first or later.
    int lo = key.x, hi = key.x + key.y;
    while (lo < hi) {
        int mid = (lo + hi) >> 1;
        if (int(texelFetch(fixed_runs, mid).x) < y_first) lo = mid + 1;
        else hi = mid;
    }
    int first = lo + chunk * params.runs_per_chunk;
    int last = min(key.x + key.y, first + params.runs_per_chunk);
    int view = angle * params.heights + h;
    int map = params.map_per_slot != 0 ? view * params.slot_count + slot : view;
    uint map_base = uint(map) * uint(params.range_nj) * uint(params.row_words);
    for (int r = first; r < last; ++r) {
        uvec2 a = texelFetch(fixed_runs, r).xy;
        int a_y = int(a.x);
        if (a_y > y_last) break;
        int j = a_y - b_y - params.range_j0;
        int a_x_first = int(a.y & 0xffffu) + params.fixed_x0, a_x_last = int(a.y >> 16u) + params.fixed_x0;
        int lo = max(a_x_first - b_x_last - params.range_i0, 0);
        int hi = min(a_x_last - b_x_first - params.range_i0, params.range_ni - 1);
        if (lo > hi) continue;
        uint row = map_base + uint(j) * uint(params.row_words);
        // Most intervals land where other pairs already set the bits: a plain read skips the atomic.
        // Straight-line code for the first and last word (most intervals span one or two).
        uint w_lo = row + uint(lo >> 5), w_hi = row + uint(hi >> 5);
        uint lo_mask = 0xffffffffu << uint(lo & 31), hi_mask = 0xffffffffu >> uint(31 - (hi & 31));
        if (w_lo == w_hi) lo_mask &= hi_mask;
        if ((seen(w_lo) & lo_mask) != lo_mask) atomicOr(maps[w_lo], lo_mask);
        for (uint w = w_lo + 1u; w < w_hi; ++w)
            if (seen(w) != 0xffffffffu) atomicOr(maps[w], 0xffffffffu);
        if (w_hi != w_lo && (seen(w_hi) & hi_mask) != hi_mask) atomicOr(maps[w_hi], hi_mask);
    }
}
