// Per-tet stress analysis (see stress.h).
#include "shatter/fracture/stress.h"

#include <cmath>

#include "shatter/core/assert.h"
#include "shatter/core/parallel.h"
#include "shatter/fem/tet_kernels.h"

namespace shatter {

TetStress analyze_stress(const Mat3& sigma) {
  TetStress s;
  s.sigma = sigma;
  const Principal p = principal_stresses(sigma);
  s.principal = p.values;
  s.directions = p.vectors;
  // Largest tension is values[0] (if > 0), largest compression values[2] (if < 0).
  const double tension = std::max(0.0, p.values[0]);
  const double compression = std::min(0.0, p.values[2]);
  s.display = tension >= -compression ? tension : compression;
  s.von_mises = von_mises(sigma);
  return s;
}

std::vector<TetStress> compute_stresses(const FemModel& model, const std::vector<Vec3>& deformed) {
  SHATTER_CHECK(static_cast<Index>(deformed.size()) == model.num_nodes);
  std::vector<TetStress> out(model.tets.size());
  parallel_for(
      0, model.num_tets(),
      [&](std::int64_t e) {
        const auto t = static_cast<std::size_t>(e);
        Mat34 x;
        for (int k = 0; k < 4; ++k) x.col(k) = deformed[static_cast<std::size_t>(model.tets[t][k])];
        out[t] = analyze_stress(cauchy_stress(model.model, model.lame, deformation_gradient(model.rest[t], x)));
      },
      512);
  return out;
}

std::vector<TetStress> analyze_stresses(const std::vector<Mat3>& sigma) {
  std::vector<TetStress> out(sigma.size());
  parallel_for(
      0, static_cast<std::int64_t>(sigma.size()), [&](std::int64_t e) { out[e] = analyze_stress(sigma[e]); }, 1024);
  return out;
}

}  // namespace shatter
