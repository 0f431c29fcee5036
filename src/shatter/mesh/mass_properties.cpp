// Exact and lumped mass properties of a tet mesh (see mass_properties.h).
#include "shatter/mesh/mass_properties.h"

#include <vector>

namespace shatter {

MassProperties mass_properties(const TetMesh& mesh, double density) {
  MassProperties m;
  if (mesh.tets.empty()) return m;
  // Moments about a reference point near the body (its first node) to limit cancellation.
  const Vec3 ref = mesh.positions[mesh.tets[0][0]];
  double volume = 0;
  Vec3 first = Vec3::Zero();   // integral of r dV
  Mat3 second = Mat3::Zero();  // integral of r r^T dV
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    Vec3 r[4];
    for (int k = 0; k < 4; ++k) r[k] = mesh.positions[mesh.tets[e][k]] - ref;
    const double v = signed_volume(r[0], r[1], r[2], r[3]);
    const Vec3 s = r[0] + r[1] + r[2] + r[3];
    volume += v;
    first += v / 4.0 * s;
    Mat3 c = s * s.transpose();
    for (const Vec3& rk : r) c += rk * rk.transpose();
    second += v / 20.0 * c;
  }
  m.volume = volume;
  m.mass = density * volume;
  const Vec3 c = first / volume;
  m.center = ref + c;
  const Mat3 central = density * (second - volume * c * c.transpose());
  m.inertia = central.trace() * Mat3::Identity() - central;
  return m;
}

MassProperties lumped_mass_properties(const TetMesh& mesh, double density) {
  MassProperties m;
  std::vector<double> node_mass(mesh.positions.size(), 0.0);
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    const double v = signed_volume(mesh, e);
    m.volume += v;
    for (Index i : mesh.tets[e]) node_mass[i] += density * v / 4.0;
  }
  const double volume = m.volume;
  m = point_mass_properties(node_mass, mesh.positions);
  m.volume = volume;
  return m;
}

MassProperties point_mass_properties(std::span<const double> masses, std::span<const Vec3> positions) {
  MassProperties m;
  Vec3 c = Vec3::Zero();
  for (std::size_t i = 0; i < masses.size(); ++i) {
    m.mass += masses[i];
    c += masses[i] * positions[i];
  }
  if (m.mass <= 0) return m;
  m.center = c / m.mass;
  for (std::size_t i = 0; i < masses.size(); ++i) {
    const Vec3 r = positions[i] - m.center;
    m.inertia += masses[i] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  return m;
}

}  // namespace shatter
