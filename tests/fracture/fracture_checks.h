// Checks shared by the fracture tests: mesh validity after cuts (orientation, volume threshold,
// face sharing, closed and consistently oriented boundary) and state hashing.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <string>

#include "shatter/core/hash.h"
#include "shatter/fracture/fragments.h"
#include "shatter/mesh/topology.h"
#include "shatter/mesh/validate.h"

namespace shatter::test {

/// Every tet has volume >= min_volume (> 0), no face is shared by more than two tets, no node is
/// unused, and every directed boundary edge appears once and its reverse once.
inline ::testing::AssertionResult mesh_is_valid(const TetMesh& m, double min_volume = 0.0) {
  for (Index e = 0; e < m.num_tets(); ++e) {
    const double v = signed_volume(m, e);
    if (!(v > 0) || v < min_volume)
      return ::testing::AssertionFailure() << "tet " << e << " volume " << v << " (min " << min_volume << ")";
  }
  const ValidationReport report = validate_mesh(m);
  for (const MeshProblem& p : report.problems) return ::testing::AssertionFailure() << "validate_mesh: " << p.message;
  const TetFaces faces = compute_faces(m);
  if (!faces.overshared.empty()) return ::testing::AssertionFailure() << "overshared face";
  const TriSurface s = boundary_surface(m, faces);
  std::map<std::pair<Index, Index>, int> edges;
  for (const TriIndices& t : s.triangles)
    for (int k = 0; k < 3; ++k) ++edges[{t[k], t[(k + 1) % 3]}];
  for (const auto& [e, n] : edges) {
    if (n != 1) return ::testing::AssertionFailure() << "directed boundary edge used " << n << " times";
    if (!edges.count({e.second, e.first}))
      return ::testing::AssertionFailure() << "boundary edge without its reverse (open surface)";
  }
  // Boundary encloses the volume (divergence theorem) with outward orientation.
  double v = 0;
  for (const TriIndices& t : s.triangles) v += s.positions[t[0]].dot(s.positions[t[1]].cross(s.positions[t[2]])) / 6.0;
  const double total = total_volume(m);
  if (std::abs(v - total) > 1e-9 * std::abs(total))
    return ::testing::AssertionFailure() << "boundary encloses " << v << ", tets sum to " << total;
  return ::testing::AssertionSuccess();
}

inline std::uint64_t mesh_hash(const TetMesh& m) {
  Hasher h;
  h.add_bytes(m.positions.data(), m.positions.size() * sizeof(Vec3));
  h.add(std::span<const TetIndices>(m.tets));
  h.add(std::span<const FileId>(m.node_ids));
  h.add(std::span<const FileId>(m.tet_ids));
  h.add(std::span<const std::int32_t>(m.tet_tags));
  return h.digest();
}

inline std::uint64_t fragments_hash(const std::vector<Fragment>& fragments) {
  Hasher h;
  for (const Fragment& f : fragments) {
    h.add(mesh_hash(f.mesh));
    h.add(std::span<const Index>(f.node_map));
    h.add(std::span<const Index>(f.tet_map));
    h.add(f.mass.mass);
    h.add_bytes(f.mass.center.data(), sizeof(double) * 3);
    h.add_bytes(f.mass.inertia.data(), sizeof(double) * 9);
  }
  return h.digest();
}

}  // namespace shatter::test
