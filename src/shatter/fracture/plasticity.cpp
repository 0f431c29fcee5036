// Plastic rest-shape update (see plasticity.h).
#include "shatter/fracture/plasticity.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "shatter/core/assert.h"
#include "shatter/fem/constitutive.h"

namespace shatter {

PlasticResult apply_plasticity(const FemModel& model, const std::vector<Vec3>& rest_positions,
                               const std::vector<Vec3>& deformed, const std::vector<TetStress>& stress,
                               const std::vector<double>& plastic_strain, const PlasticityOptions& options) {
  const Index nn = model.num_nodes;
  const Index nt = model.num_tets();
  const Material& material = model.material;
  const std::vector<TetIndices>& tets = model.tets;
  SHATTER_CHECK(static_cast<Index>(rest_positions.size()) == nn && deformed.size() == rest_positions.size());
  SHATTER_CHECK(static_cast<Index>(stress.size()) == nt);
  SHATTER_CHECK(plastic_strain.empty() || static_cast<Index>(plastic_strain.size()) == nt);
  PlasticResult r;
  r.rest_positions = rest_positions;
  r.plastic_strain = plastic_strain.empty() ? std::vector<double>(nt, 0.0) : plastic_strain;
  const double yield = material.yield_stress;
  if (!options.enabled || !std::isfinite(yield) || options.creep <= 0) return r;

  // (1) Yield per tet.
  std::vector<double> w_tet(nt, 0.0);
  for (Index e = 0; e < nt; ++e) {
    const double vm = stress[e].von_mises;
    if (!(vm > yield)) continue;
    w_tet[e] = std::min(1.0, options.creep) * (1.0 - yield / vm);
    r.plastic_strain[e] += w_tet[e] * vm / material.youngs_modulus;
    r.yielded.push_back(e);
  }
  for (Index e = 0; e < nt; ++e)
    if (r.plastic_strain[e] > options.max_plastic_strain) r.failed.push_back(e);
  if (r.yielded.empty()) return r;

  // (2) Best-fit rigid motion x ~ R m + t , weighted by the volume of the tets that stayed
  // elastic (an anchored part stays put), or of all tets if every tet yielded.
  std::vector<double> vol(nt), node_vol(nn, 0.0), fit_vol(nn, 0.0);
  const bool all_yielded = r.yielded.size() == tets.size();
  for (Index e = 0; e < nt; ++e) {
    const TetIndices& t = tets[e];
    vol[e] = signed_volume(rest_positions[t[0]], rest_positions[t[1]], rest_positions[t[2]], rest_positions[t[3]]);
    for (Index v : t) {
      node_vol[v] += vol[e];
      if (all_yielded || w_tet[e] == 0) fit_vol[v] += vol[e];
    }
  }
  double wsum = 0;
  Vec3 cm = Vec3::Zero(), cx = Vec3::Zero();
  for (Index i = 0; i < nn; ++i) {
    wsum += fit_vol[i];
    cm += fit_vol[i] * rest_positions[i];
    cx += fit_vol[i] * deformed[i];
  }
  cm /= wsum;
  cx /= wsum;
  // Rotation of the best-fit affine map A = Apq Aqq^-1 (shape matching, Müller et al. 2005): for an
  // affine deformation A = F exactly, so a pure stretch has R = I.
  Mat3 apq = Mat3::Zero(), aqq = Mat3::Zero();
  for (Index i = 0; i < nn; ++i) {
    const Vec3 q = rest_positions[i] - cm;
    apq += fit_vol[i] * (deformed[i] - cx) * q.transpose();
    aqq += fit_vol[i] * q * q.transpose();
  }
  const Mat3 A = apq * aqq.inverse();
  r.rotation = A.allFinite() ? polar_decomposition(A).R : Mat3::Identity();
  auto unrotated = [&](Index i) -> Vec3 { return r.rotation.transpose() * (deformed[i] - cx) + cm; };

  // (3) Node weights.
  std::vector<double> w(nn, 0.0);
  for (Index e = 0; e < nt; ++e)
    if (w_tet[e] > 0)
      for (Index v : tets[e]) w[v] += vol[e] * w_tet[e];
  for (Index i = 0; i < nn; ++i) w[i] = node_vol[i] > 0 ? w[i] / node_vol[i] : 0.0;

  // (4)+(5) Move, keeping every rest tet above min_volume_fraction of its volume.
  for (int round = 0;; ++round) {
    for (Index i = 0; i < nn; ++i)
      r.rest_positions[i] =
          w[i] > 0 ? Vec3(rest_positions[i] + w[i] * (unrotated(i) - rest_positions[i])) : rest_positions[i];
    bool bad = false;
    for (Index e = 0; e < nt; ++e) {
      const TetIndices& t = tets[e];
      const double v =
          signed_volume(r.rest_positions[t[0]], r.rest_positions[t[1]], r.rest_positions[t[2]], r.rest_positions[t[3]]);
      if (v >= options.min_volume_fraction * vol[e]) continue;
      bad = true;
      for (Index i : t) w[i] = round >= 30 ? 0.0 : 0.5 * w[i];
    }
    if (!bad) break;
  }
  for (Index i = 0; i < nn; ++i)
    if (w[i] > 0) r.moved_nodes.push_back(i);
  return r;
}

}  // namespace shatter
