// Helpers shared by the solver tests: box models, face loads, anchors.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "shatter/fem/assembly.h"
#include "shatter/fem/fem_model.h"
#include "shatter/mesh/generate.h"
#include "shatter/solve/static_solver.h"

namespace shatter::test {

inline Material test_material(double youngs = 70e9, double poisson = 0.3) {
  return Material{.name = "test",
                  .youngs_modulus = youngs,
                  .poisson_ratio = poisson,
                  .density = 2500,
                  .tensile_strength = kInfinity,
                  .yield_stress = kInfinity};
}

inline TetMesh box(const Vec3& max, std::array<Index, 3> cells, double jitter = 0.0) {
  return make_box_mesh(BoxMeshDef{.min = Vec3::Zero(), .max = max, .cells = cells, .jitter = jitter});
}

/// Consistent nodal forces of a uniform traction t (Pa) on the boundary triangles whose nodes all
/// satisfy on_face (each triangle gives area * t / 3 to each corner), N (#nodes).
template <class OnFace>
std::vector<Vec3> face_load(const TetMesh& mesh, OnFace&& on_face, const Vec3& traction) {
  std::vector<Vec3> f(mesh.positions.size(), Vec3::Zero());
  static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  for (const TetIndices& t : mesh.tets)
    for (const auto& face : kFaces) {
      const Vec3& a = mesh.positions[t[face[0]]];
      const Vec3& b = mesh.positions[t[face[1]]];
      const Vec3& c = mesh.positions[t[face[2]]];
      if (!on_face(a) || !on_face(b) || !on_face(c)) continue;
      const double area = 0.5 * (b - a).cross(c - a).norm();
      for (int k = 0; k < 3; ++k) f[t[face[k]]] += traction * (area / 3.0);
    }
  return f;
}

/// The relative residuals of a Newton history, " 1.00e+00 2.53e-03 ..." (for messages and logs).
inline std::string residual_trace(const std::vector<NewtonIteration>& history) {
  std::string trace;
  for (const NewtonIteration& it : history) {
    char buf[32];
    std::snprintf(buf, sizeof buf, " %.2e", it.relative_residual);
    trace += buf;
  }
  return trace;
}

}  // namespace shatter::test
