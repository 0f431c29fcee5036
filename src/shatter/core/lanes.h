// Four doubles side by side for the vector kernels (the contact batches, the rigid drift, the
// stresses' Jacobi sweeps). Private to the library.
//
// GCC vector extensions: each kernel is written once over these types and compiled twice, for the
// build's baseline (SSE on x86-64) and for AVX2 (core/simd.h picks one at run time). With
// -ffp-contract=off every lane is computed exactly as the scalar formula would be, so both give the
// bits of one value at a time.
#pragma once

#include <immintrin.h>

// A 32-byte vector returned by an always-inlined helper makes GCC report -Wpsabi (the call ABI of
// such vectors differs between SSE and AVX code) after the end of the including file, though none
// crosses a real call; it stays off for every file that includes this one.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace shatter {

/// Four doubles, one per lane. Aligned to 32 bytes everywhere: without AVX the baseline ABI would
/// give such vectors 16, while the AVX2 code loads them with aligned 32-byte moves.
typedef double Lanes __attribute__((vector_size(4 * sizeof(double)), aligned(32)));
/// A mask per lane: all bits set for true, as the comparisons of two Lanes give.
typedef long long LaneMask __attribute__((vector_size(4 * sizeof(long long)), aligned(32)));

/// Four doubles without the alignment attribute, for template arguments (GCC drops attributes there)
/// in code that keeps its vectors in locals only.
typedef double PlainLanes __attribute__((vector_size(4 * sizeof(double))));
/// The mask of two PlainLanes compared.
typedef long long PlainLaneMask __attribute__((vector_size(4 * sizeof(long long))));

namespace lanes_detail {
// Not always_inline: GCC inlines it only into AVX2 code (a kernel under gnu::target("avx2")).
// Returns through a pointer: a 32-byte vector returned by value from AVX code to baseline code would
// change the ABI.
template <class V>
[[gnu::target("avx2")]] inline void sqrt_avx2(const V& x, V* out) {
  *out = reinterpret_cast<V>(_mm256_sqrt_pd(reinterpret_cast<__m256d>(x)));
}
template <class V>
[[gnu::always_inline]] inline void sqrt_baseline(const V& x, V* out) {
  const __m128d lo = _mm_sqrt_pd(_mm_set_pd(x[1], x[0]));
  const __m128d hi = _mm_sqrt_pd(_mm_set_pd(x[3], x[2]));
  *out = V{lo[0], lo[1], hi[0], hi[1]};
}
}  // namespace lanes_detail

/// Correctly rounded square roots lane by lane, as std::sqrt gives them (the same bits on every
/// path), in one or two vector instructions. V is Lanes or PlainLanes; kAvx2 must match the
/// kernel's instruction set.
template <bool kAvx2, class V>
[[gnu::always_inline]] inline V lane_sqrt(const V& x) {
  V out;
  if constexpr (kAvx2) {
    lanes_detail::sqrt_avx2(x, &out);
  } else {
    lanes_detail::sqrt_baseline(x, &out);
  }
  return out;
}

}  // namespace shatter
