#pragma once
// How every amhv program handles its memory: freed memory kept at start and given back at named
// points; large blocks on huge pages.
#include <cstddef>

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

// Asks the kernel to back the 2 MiB-aligned part of [block, block + bytes) with transparent huge
// pages (madvise; the kernel's setting on these machines is "madvise"). Each first touch of a
// 4 KiB page is a page fault, and on these VMs a fault costs microseconds: a 10 mm sweep of the
// paper scene took 850,000 of them, a fifth of its CPU time. A huge page is one fault per 2 MiB.
// Every block of 2 MiB or more from operator new (replaced in process.cpp) and from the volumes'
// zeroed allocator gets this advice.
void advise_huge_pages(void* block, std::size_t bytes);

// Blocks from this size on get advise_huge_pages.
inline constexpr std::size_t kHugePageBytes = std::size_t(2) << 20;

}  // namespace amhv
