#pragma once
// How every amhv program handles its freed memory: kept at start, given back at named points.

namespace amhv {

// The sweep allocates and frees buffers of megabytes batch after batch. By default glibc raises
// its mmap threshold only as large blocks come and go, and gives freed heap tops back to the
// kernel, so batches paid for fresh zeroed pages again and again (with the other page faults, a
// sixth of a sweep's time). Blocks up to 32 MiB (glibc's largest threshold) now come from the heap
// from the start, and freed memory stays in the process for the next batch.
void keep_freed_memory();

// Gives the memory kept that way back to the kernel: between key segments, whose sizes differ, and
// before the stages after the sweep, so that it does not add to their peak.
void release_freed_memory();

}  // namespace amhv
