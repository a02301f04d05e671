#pragma once
// How every amhv program handles its memory: freed memory kept at start and given back at named
// points; large blocks on huge pages.
#include <cstddef>
#include <cstdlib>
#include <new>
#include <utility>

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

// A vector allocator over zeroed memory that leaves value-initialised elements as they are (zero):
// a vector sized from empty costs nothing until its pages are written. `Source` gives the memory
// (static allocate(bytes), zeroed, and free(block, bytes)). Only for vectors sized once from
// empty: growing back after a shrink would keep the old values.
template <typename T, typename Source>
struct ZeroFilledAllocator {
    using value_type = T;
    ZeroFilledAllocator() = default;
    template <typename U>
    ZeroFilledAllocator(const ZeroFilledAllocator<U, Source>&) {}
    T* allocate(std::size_t n) {
        if (n > std::size_t(-1) / sizeof(T)) throw std::bad_alloc();
        if (void* p = Source::allocate(n * sizeof(T))) return static_cast<T*>(p);
        throw std::bad_alloc();
    }
    void deallocate(T* p, std::size_t n) { Source::free(p, n * sizeof(T)); }
    template <typename U>
    void construct(U*) {}  // value-initialised: already zero
    template <typename U, typename... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
    template <typename U>
    bool operator==(const ZeroFilledAllocator<U, Source>&) const { return true; }
};

// Zeroed memory on small pages, for large arrays that are mostly zero and written sparsely: a
// column volume holds every frame's slot per column and a frame fills a small part of them; a
// sweep's outcomes are FailsContact (0) for most poses. calloc (no huge-page advice) leaves the
// pages never written on the kernel's zero page instead of clearing them (at 5 mm a segment's
// column volumes were about 1 GB, cleared twice: by the kernel and by the fill).
struct SmallZeroPages {
    static void* allocate(std::size_t bytes) { return std::calloc(bytes, 1); }
    static void free(void* block, std::size_t) { std::free(block); }
};
template <typename T>
using CallocAllocator = ZeroFilledAllocator<T, SmallZeroPages>;

// Blocks from this size on get advise_huge_pages.
inline constexpr std::size_t kHugePageBytes = std::size_t(2) << 20;

}  // namespace amhv
