// Exact and lumped mass properties of a tet mesh (see mass_properties.h).
#include "shatter/mesh/mass_properties.h"

#include <array>
#include <vector>

namespace shatter {

MassProperties mass_properties(const TetMesh& mesh, double density) {
  MassProperties m;
  if (mesh.tets.empty()) return m;
  // Moments about a reference point near the body (its first node) to limit cancellation.
  const Vec3 ref = mesh.positions[mesh.tets[0][0]];
  // The symmetric second moment has six distinct entries (xx yy zz xy xz yz), kept as scalars and
  // summed per tet in the order of s s^T + r0 r0^T + ... + r3 r3^T, then scaled by v / 20.
  double volume = 0;
  Vec3 first = Vec3::Zero();       // integral of r dV
  std::array<double, 6> second{};  // integral of r r^T dV: xx yy zz xy xz yz
  const Vec3* pos = mesh.positions.data();
  for (const TetIndices& t : mesh.tets) {
    const Vec3 r0 = pos[t[0]] - ref, r1 = pos[t[1]] - ref, r2 = pos[t[2]] - ref, r3 = pos[t[3]] - ref;
    const double v = signed_volume(r0, r1, r2, r3);
    const Vec3 s = r0 + r1 + r2 + r3;
    volume += v;
    first += v / 4.0 * s;
    const double w20 = v / 20.0;
    // Entry (a, b) of s s^T + r0 r0^T + r1 r1^T + r2 r2^T + r3 r3^T, summed in that order.
    const auto entry = [&](int a, int b) {
      double c = s[a] * s[b];
      c += r0[a] * r0[b];
      c += r1[a] * r1[b];
      c += r2[a] * r2[b];
      c += r3[a] * r3[b];
      return c;
    };
    second[0] += w20 * entry(0, 0);
    second[1] += w20 * entry(1, 1);
    second[2] += w20 * entry(2, 2);
    second[3] += w20 * entry(0, 1);
    second[4] += w20 * entry(0, 2);
    second[5] += w20 * entry(1, 2);
  }
  Mat3 second_moment;
  second_moment << second[0], second[3], second[4], second[3], second[1], second[5], second[4], second[5], second[2];
  m.volume = volume;
  m.mass = density * volume;
  const Vec3 c = first / volume;
  m.center = ref + c;
  const Mat3 central = density * (second_moment - volume * c * c.transpose());
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
