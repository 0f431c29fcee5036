#include "shatter/core/parallel.h"

#include <algorithm>
#include <thread>

namespace shatter {
namespace {
int g_threads = 0;  // 0 = not set: hardware concurrency
}

void set_num_threads(int n) { g_threads = std::clamp(n, 1, kMaxThreads); }

int num_threads() {
  if (g_threads > 0) return g_threads;
#ifdef SHATTER_HAS_OPENMP
  return std::max(1, omp_get_max_threads());
#else
  return 1;
#endif
}

}  // namespace shatter
