#version 450
// Pass 2 of the solid voxelisation: every non-empty bucket (frame slot, column) takes a contiguous
// stretch of the key list, [start, start + count), from one shared bump counter, and the fill pass
// appends through cursor (which starts at start). Where a stretch lies does not matter: each
// bucket's keys are sorted before use, so the result is the same for any order of allocation.
// The count is reset here, its only reader, so the next batch counts from zero without a clear.

layout(local_size_x_id = 0) in;

layout(std430, set = 0, binding = 0) buffer Counts { uint bucket_count[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Starts { uint bucket_start[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Cursors { uint bucket_cursor[]; };
layout(std430, set = 0, binding = 3) buffer Allocated { uint keys_allocated; };

layout(push_constant) uniform Params {
    uint bucket_base;
    uint bucket_count_total;
} params;

void main() {
    if (gl_GlobalInvocationID.x >= params.bucket_count_total) return;
    uint bucket = params.bucket_base + gl_GlobalInvocationID.x;
    uint count = bucket_count[bucket];
    uint start = 0u;
    if (count != 0u) {
        start = atomicAdd(keys_allocated, count);
        bucket_count[bucket] = 0u;
    }
    bucket_start[bucket] = start;
    bucket_cursor[bucket] = start;
}
