// Allocator settings (see memory.h).
#include "shatter/core/memory.h"

#include <cstdlib>  // defines __GLIBC__ where the C library is glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace shatter {

bool keep_freed_memory() {
#if defined(__GLIBC__)
  // The largest mmap threshold glibc accepts on 64-bit systems (HEAP_MAX_SIZE / 2 = 32 MiB).
  constexpr int kMmapThreshold = 32 << 20;
  constexpr int kTrimThreshold = 1 << 30;
  return mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1 && mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
#else
  return false;
#endif
}

}  // namespace shatter
