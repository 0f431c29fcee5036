// Small math and index types shared by every layer. FEM state is double precision: moduli of
// 1e9..1e11 Pa with strains of 1e-4 need it (docs/architecture.md).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <limits>

namespace shatter {

using Real = double;                          ///< scalar of all FEM state
using Vec2 = Eigen::Vector2d;                 ///< 2D point or vector (profiles, polygons)
using Vec3 = Eigen::Vector3d;                 ///< 3D point or vector
using Vec4 = Eigen::Vector4d;                 ///< 4-vector
using Mat3 = Eigen::Matrix3d;                 ///< 3x3 matrix (deformation gradients, stresses, rotations)
using Mat4 = Eigen::Matrix4d;                 ///< 4x4 matrix
using Mat34 = Eigen::Matrix<double, 3, 4>;    ///< 3x4: one column per tet corner
using Mat43 = Eigen::Matrix<double, 4, 3>;    ///< 4x3: one row per tet corner (shape gradients)
using Quat = Eigen::Quaterniond;              ///< unit quaternion for orientations
using Mat12 = Eigen::Matrix<double, 12, 12>;  ///< tet element matrix, ordering [x0; x1; x2; x3]
using Vec12 = Eigen::Matrix<double, 12, 1>;   ///< tet element vector, same ordering

/// Index of a node, tet, face... inside one mesh. 32 bits: meshes up to 2^31-1 entities.
using Index = std::int32_t;
/// An id as written in a file (Gmsh node tags, Abaqus element numbers...): may be sparse, 64-bit.
using FileId = std::int64_t;

/// The 4 node indices of a tetrahedron. Positive orientation: det[x1-x0, x2-x0, x3-x0] > 0.
using TetIndices = std::array<Index, 4>;
/// The 3 node indices of a triangle; outward normal by the right-hand rule when on a boundary.
using TriIndices = std::array<Index, 3>;

/// Axis-aligned box.
struct Aabb {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());   ///< lowest corner, m (+inf when empty)
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());  ///< highest corner, m (-inf when empty)
  /// Grow to contain p.
  void extend(const Vec3& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  /// True when it contains no point (min > max on some axis).
  [[nodiscard]] bool empty() const { return (min.array() > max.array()).any(); }
  /// Size along each axis, m (zero when empty).
  [[nodiscard]] Vec3 extent() const { return empty() ? Vec3::Zero() : Vec3(max - min); }
  /// Whether p lies inside or on the box.
  [[nodiscard]] bool contains(const Vec3& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
};

}  // namespace shatter
