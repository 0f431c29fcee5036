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

std::vector<TetStress> compute_stresses(const TetMesh& rest, const std::vector<Vec3>& deformed,
                                        const Material& material, ModelKind model) {
  SHATTER_CHECK(deformed.size() == rest.positions.size());
  const Lame lame = lame_parameters(material);
  std::vector<TetStress> out(rest.tets.size());
  parallel_for(0, rest.num_tets(), [&](std::int64_t e) {
    const Index t = static_cast<Index>(e);
    Mat34 x;
    for (int k = 0; k < 4; ++k) x.col(k) = deformed[rest.tets[t][k]];
    const TetRest r = tet_rest(rest.corners(t));
    out[t] = analyze_stress(cauchy_stress(model, lame, deformation_gradient(r, x)));
  }, 512);
  return out;
}

std::vector<TetStress> analyze_stresses(const std::vector<Mat3>& sigma) {
  std::vector<TetStress> out(sigma.size());
  parallel_for(0, static_cast<std::int64_t>(sigma.size()),
               [&](std::int64_t e) { out[e] = analyze_stress(sigma[e]); }, 1024);
  return out;
}

}  // namespace shatter
