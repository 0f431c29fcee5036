// Per-tet stress analysis (see stress.h).
#include "shatter/fracture/stress.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "shatter/core/assert.h"
#include "shatter/core/parallel.h"
#include "shatter/fem/tet_kernels.h"

namespace shatter {

namespace {

// The rest of TetStress from sigma and its principal stresses.
TetStress finish_stress(const Mat3& sigma, const Principal& p) {
  TetStress s;
  s.sigma = sigma;
  s.principal = p.values;
  s.directions = p.vectors;
  // Largest tension is values[0] (if > 0), largest compression values[2] (if < 0).
  const double tension = std::max(0.0, p.values[0]);
  const double compression = std::min(0.0, p.values[2]);
  s.display = tension >= -compression ? tension : compression;
  s.von_mises = von_mises(sigma);
  return s;
}

// Analyses each tensor of sigma into the same place of out, principal stresses four at a time.
void analyze_range(std::span<const Mat3> sigma, std::span<TetStress> out) {
  std::array<Principal, 4> p;
  for (std::size_t i = 0; i < sigma.size(); i += 4) {
    const std::size_t n = std::min<std::size_t>(4, sigma.size() - i);
    principal_stresses(sigma.subspan(i, n), std::span(p.data(), n));
    for (std::size_t k = 0; k < n; ++k) out[i + k] = finish_stress(sigma[i + k], p[k]);
  }
}

// The Cauchy stress of tet t of `model` at the deformed positions, Pa.
Mat3 tet_cauchy_stress(const FemModel& model, const std::vector<Vec3>& deformed, std::size_t t) {
  Mat34 x;
  for (int c = 0; c < 4; ++c) x.col(c) = deformed[static_cast<std::size_t>(model.tets[t][c])];
  return cauchy_stress(model.model, model.lame, deformation_gradient(model.rest[t], x));
}

}  // namespace

TetStress analyze_stress(const Mat3& sigma) { return finish_stress(sigma, principal_stresses(sigma)); }

std::vector<TetStress> compute_stresses(const FemModel& model, const std::vector<Vec3>& deformed) {
  SHATTER_CHECK(static_cast<Index>(deformed.size()) == model.num_nodes);
  std::vector<TetStress> out(model.tets.size());
  constexpr std::int64_t kGroup = 64;  // tets per task: their stresses, then their analyses
  parallel_for(
      0, (model.num_tets() + kGroup - 1) / kGroup,
      [&](std::int64_t g) {
        const auto first = static_cast<std::size_t>(g * kGroup);
        const std::size_t n = std::min<std::size_t>(kGroup, model.tets.size() - first);
        std::array<Mat3, kGroup> sigma;
        for (std::size_t k = 0; k < n; ++k) {
          const std::size_t t = first + k;
          sigma[k] = tet_cauchy_stress(model, deformed, t);
        }
        analyze_range(std::span(sigma.data(), n), std::span(out).subspan(first, n));
      },
      8);
  return out;
}

std::vector<TetStress> compute_stresses(const FemModel& model, const std::vector<Vec3>& deformed,
                                        const std::vector<char>& at_rest) {
  SHATTER_CHECK(static_cast<Index>(deformed.size()) == model.num_nodes && at_rest.size() == model.tets.size());
  std::vector<Index> active;
  active.reserve(model.tets.size());
  for (std::size_t e = 0; e < at_rest.size(); ++e)
    if (!at_rest[e]) active.push_back(static_cast<Index>(e));
  std::vector<TetStress> out(model.tets.size());
  constexpr std::int64_t kGroup = 64;  // deformed tets per task, as in compute_stresses
  parallel_for(
      0, (static_cast<std::int64_t>(active.size()) + kGroup - 1) / kGroup,
      [&](std::int64_t g) {
        const auto first = static_cast<std::size_t>(g * kGroup);
        const std::size_t n = std::min<std::size_t>(kGroup, active.size() - first);
        std::array<Mat3, kGroup> sigma;
        std::array<TetStress, kGroup> analysed;
        for (std::size_t k = 0; k < n; ++k) {
          const auto t = static_cast<std::size_t>(active[first + k]);
          sigma[k] = tet_cauchy_stress(model, deformed, t);
        }
        analyze_range(std::span(sigma.data(), n), std::span(analysed.data(), n));
        for (std::size_t k = 0; k < n; ++k) out[static_cast<std::size_t>(active[first + k])] = analysed[k];
      },
      8);
  return out;
}

std::vector<TetStress> analyze_stresses(const std::vector<Mat3>& sigma) {
  std::vector<TetStress> out(sigma.size());
  constexpr std::int64_t kGroup = 64;
  parallel_for(
      0, (static_cast<std::int64_t>(sigma.size()) + kGroup - 1) / kGroup,
      [&](std::int64_t g) {
        const auto first = static_cast<std::size_t>(g * kGroup);
        const std::size_t n = std::min<std::size_t>(kGroup, sigma.size() - first);
        analyze_range(std::span(sigma).subspan(first, n), std::span(out).subspan(first, n));
      },
      16);
  return out;
}

}  // namespace shatter
