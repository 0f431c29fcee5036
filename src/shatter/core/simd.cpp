// Choice of the vector kernels' instruction set (see simd.h).
#include "shatter/core/simd.h"

#include <atomic>

namespace shatter {
namespace {

bool cpu_has_avx2() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

// 0 = automatic (AVX2 where the CPU has it), else SimdIsa + 1.
std::atomic<int> g_simd_isa{0};

}  // namespace

void set_simd_isa(SimdIsa isa) {
  g_simd_isa.store(isa == SimdIsa::avx2 && !cpu_has_avx2() ? 1 : static_cast<int>(isa) + 1);
}

SimdIsa simd_isa() {
  static const bool has_avx2 = cpu_has_avx2();
  const int chosen = g_simd_isa.load();
  if (chosen == 0) return has_avx2 ? SimdIsa::avx2 : SimdIsa::baseline;
  return static_cast<SimdIsa>(chosen - 1);
}

}  // namespace shatter
