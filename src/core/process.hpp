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

// Zeroed memory on small pages, for large arrays that are mostly zero and written sparsely: a
// column volume holds every frame's slot per column and a frame fills a small part of them; a
// sweep's outcomes are FailsContact (0) for most poses. calloc (no huge-page advice) leaves the
// pages never written on the kernel's zero page instead of clearing them (at 5 mm a segment's
// column volumes were about 1 GB, cleared twice: by the kernel and by the fill). Value-initialised
// elements are left as they are (zero): only for vectors sized once from empty.
template <typename T>
struct CallocAllocator {
    using value_type = T;
    CallocAllocator() = default;
    template <typename U>
    CallocAllocator(const CallocAllocator<U>&) {}
    T* allocate(std::size_t n) {
        if (n > std::size_t(-1) / sizeof(T)) throw std::bad_alloc();
        if (void* p = std::calloc(n, sizeof(T))) return static_cast<T*>(p);
        throw std::bad_alloc();
    }
    void deallocate(T* p, std::size_t) { std::free(p); }
    template <typename U>
    void construct(U*) {}  // value-initialised: already zero
    template <typename U, typename... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
    template <typename U>
    bool operator==(const CallocAllocator<U>&) const { return true; }
};

// Blocks from this size on get advise_huge_pages.
inline constexpr std::size_t kHugePageBytes = std::size_t(2) << 20;

}  // namespace amhv
