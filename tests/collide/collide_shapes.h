// Point sets and meshes shared by the collision tests and benchmarks.
#pragma once

#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "shatter/core/random.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter::shapes {

/// `n` points uniform in a ball of radius `radius` about the origin (by rejection).
inline std::vector<Vec3> random_ball(Random& rng, int n, double radius) {
  std::vector<Vec3> p;
  while (static_cast<int>(p.size()) < n) {
    const Vec3 q = rng.uniform_vec3(-radius, radius);
    if (q.norm() <= radius) p.push_back(q);
  }
  return p;
}

/// A box mesh bent into an arc of `angle` radians: x -> angle, y -> radius 1 + y, z -> height;
/// tets turned positive again.
inline TetMesh arc_mesh(std::array<Index, 3> cells, double angle, double thickness) {
  TetMesh mesh = make_box_mesh({.min = Vec3(0, 0, 0), .max = Vec3(1, thickness, 0.2), .cells = cells});
  for (Vec3& p : mesh.positions) {
    const double a = angle * p.x(), r = 1 + p.y();
    p = Vec3(r * std::cos(a), p.z(), r * std::sin(a));
  }
  for (TetIndices& t : mesh.tets)
    if (signed_volume(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]], mesh.positions[t[3]]) < 0)
      std::swap(t[2], t[3]);
  return mesh;
}

}  // namespace shatter::shapes
