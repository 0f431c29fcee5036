// Random element shapes, deformations and materials for the FEM tests.
#pragma once

#include <Eigen/Geometry>

#include <cmath>

#include "shatter/core/random.h"
#include "shatter/fem/constitutive.h"
#include "shatter/fem/tet_kernels.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter::test {

/// Random positively oriented tet (3x4, m) of size about `scale`, not too flat.
inline Mat34 random_tet(Random& rng, double scale = 1.0) {
  for (;;) {
    Mat34 m;
    for (int k = 0; k < 4; ++k) m.col(k) = scale * rng.uniform_vec3(-1, 1);
    double v = signed_volume(m.col(0), m.col(1), m.col(2), m.col(3));
    if (v < 0) {
      m.col(1).swap(m.col(2));
      v = -v;
    }
    double longest = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) longest = std::max(longest, (m.col(i) - m.col(j)).norm());
    if (v > 0.02 * longest * longest * longest) return m;
  }
}

/// Random rotation: uniform axis, angle in (-3.1, 3.1).
inline Mat3 random_rotation(Random& rng) {
  const Vec3 axis = rng.unit_vec3();
  const double angle = rng.uniform(-3.1, 3.1);
  return Eigen::AngleAxisd(angle, axis).toRotationMatrix();
}

/// A deformation gradient with stretches in [1 - amount, 1 + amount] and a random rotation.
inline Mat3 random_deformation(Random& rng, double amount) {
  Mat3 G = Mat3::Identity();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) G(i, j) += rng.uniform(-amount, amount) * (i == j ? 1.0 : 0.5);
  return random_rotation(rng) * G;
}

/// Lamé constants of a random material with E = 1 (scale-free) and nu in [0, 0.45].
inline Lame random_lame(Random& rng) {
  const double nu = rng.uniform(0.0, 0.45);
  return {.mu = 1.0 / (2 * (1 + nu)), .lambda = nu / ((1 + nu) * (1 - 2 * nu))};
}

inline constexpr ModelKind kAllModels[] = {ModelKind::stvk, ModelKind::linear, ModelKind::corotated};

}  // namespace shatter::test
