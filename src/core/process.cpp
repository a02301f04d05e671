#include "src/core/process.hpp"
#include "src/core/sanitizers.hpp"

#include <malloc.h>
#include <sys/mman.h>

#include <cstdint>
#include <cstdlib>
#include <new>

namespace amhv {

void keep_freed_memory() {
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

void release_freed_memory() { malloc_trim(0); }

void advise_huge_pages(void* block, std::size_t bytes) {
    if (!block || bytes < kHugePageBytes) return;
    const std::uintptr_t start = reinterpret_cast<std::uintptr_t>(block);
    const std::uintptr_t first = (start + kHugePageBytes - 1) & ~std::uintptr_t(kHugePageBytes - 1);
    const std::uintptr_t last = (start + bytes) & ~std::uintptr_t(kHugePageBytes - 1);
    // Advice only: where the kernel declines (THP off), the block stays on small pages.
    if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
}

}  // namespace amhv

// The replaceable global operator new (and so every standard container) with large blocks on
// huge pages. It allocates with malloc, as libstdc++'s own does, so the default operator delete
// (free) still matches. Sanitizer builds keep their runtime's allocator, which tracks new/delete
// pairs itself.
#if !defined(AMHV_ASAN) && !defined(__SANITIZE_THREAD__)
void* operator new(std::size_t bytes) {
    void* block = std::malloc(bytes ? bytes : 1);
    if (!block) throw std::bad_alloc();
    if (bytes >= amhv::kHugePageBytes) amhv::advise_huge_pages(block, bytes);
    return block;
}
void* operator new[](std::size_t bytes) { return ::operator new(bytes); }
#endif
