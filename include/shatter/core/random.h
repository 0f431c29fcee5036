// Deterministic random numbers: our own generator (SplitMix64) and our own mapping from bits to
// numbers, so results do not depend on the standard library's distributions.
#pragma once

#include <cstdint>

#include "shatter/core/types.h"

namespace shatter {

/// Deterministic random number generator: the same seed gives the same numbers on every platform.
class Random {
 public:
  /// A generator started at `seed`.
  explicit Random(std::uint64_t seed = 0x5eed) : state_(seed) {}

  /// 64 random bits (SplitMix64, Steele, Lea & Flood 2014).
  std::uint64_t next_u64() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, 1): the top 53 bits scaled by 2^-53.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n) (n > 0), by rejection (unbiased).
  std::uint64_t below(std::uint64_t n) {
    const std::uint64_t limit = ~std::uint64_t(0) - (~std::uint64_t(0) % n);
    std::uint64_t x = next_u64();
    while (x >= limit) x = next_u64();
    return x % n;
  }
  /// Each component uniform in [lo, hi).
  Vec3 uniform_vec3(double lo, double hi) { return {uniform(lo, hi), uniform(lo, hi), uniform(lo, hi)}; }
  /// Uniform on the unit sphere.
  Vec3 unit_vec3();

 private:
  std::uint64_t state_;
};

}  // namespace shatter
