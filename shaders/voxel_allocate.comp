#version 450
// Pass 2 of the solid voxelisation: one invocation per (x, y) column gives the column's buckets
// (one per frame of the batch) consecutive stretches of one key list, taken from a shared bump
// counter: bucket b owns [start[b], start[b] + count[b]), and the fill pass appends through
// cursor[b], which starts at start[b]. Where a column's stretch lies does not matter: its keys are
// sorted per bucket before use, so the result is the same for any order of allocation.
// It also records the column's crossings for the column pass, and flags a column with more than
// the column pass may sort. Counts are reset here, their only reader, so the next batch counts
// from zero without a clear. Loop work is 2 * frames <= 64.

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint MAX_COLUMN_CROSSINGS = 1024;

layout(std430, set = 0, binding = 0) buffer Counts { uint bucket_count[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Starts { uint bucket_start[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Cursors { uint bucket_cursor[]; };
layout(std430, set = 0, binding = 3) writeonly buffer ColumnKeys { uint column_keys[]; };
layout(std430, set = 0, binding = 4) buffer Allocated { uint keys_allocated; };
layout(std430, set = 0, binding = 5) buffer Overflow { uint most_column_crossings; };

layout(push_constant) uniform Params {
    uint column_base;
    uint column_count;
    uint frames;  // buckets per column
} params;

void main() {
    if (gl_GlobalInvocationID.x >= params.column_count) return;
    uint column = params.column_base + gl_GlobalInvocationID.x;
    uint base = column * params.frames;
    uint total = 0u;
    for (uint s = 0u; s < params.frames; ++s) total += bucket_count[base + s];
    column_keys[column] = total;
    if (total == 0u) return;
    if (total > MAX_COLUMN_CROSSINGS) atomicMax(most_column_crossings, total);
    uint start = atomicAdd(keys_allocated, total);
    for (uint s = 0u; s < params.frames; ++s) {
        bucket_start[base + s] = start;
        bucket_cursor[base + s] = start;
        start += bucket_count[base + s];
        bucket_count[base + s] = 0u;
    }
}
