#include "src/core/process.hpp"

#include <malloc.h>

namespace amhv {

void keep_freed_memory() {
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

void release_freed_memory() { malloc_trim(0); }

}  // namespace amhv
