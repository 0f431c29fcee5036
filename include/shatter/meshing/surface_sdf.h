// Inside test and distance for closed triangle surfaces, robust to small holes and
// self-intersections: inside where the generalized winding number exceeds 1/2 (Jacobson, Kavan &
// Sorkine-Hornung 2013, "Robust Inside-Outside Segmentation using Generalized Winding Numbers"),
// distance = unsigned distance to the nearest triangle. Both use one bounding-volume hierarchy:
// distance by branch and bound, the winding number by the far-field dipole approximation of
// clusters far from the query (Barill et al. 2018, "Fast Winding Numbers for Soups and Clouds",
// first order: cluster contribution = N . (c - p) / (4 pi |c - p|^3) with N the summed area
// vectors and c the area-weighted centroid) and the exact per-triangle sum near it.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/mesh/topology.h"

namespace shatter {

/// Inside test and distance queries on one closed triangle surface (see the top of this file).
class SurfaceDistance {
 public:
  /// Checks the surface: not empty, finite coordinates, valid indices, some non-degenerate
  /// triangle, and closed enough that the winding number reaches ~1 inside. Triangles of zero
  /// area are dropped. Either orientation is accepted (inside-out surfaces are flipped).
  /// `name` (a file name) is used in error messages.
  static Result<std::shared_ptr<const SurfaceDistance>> create(const TriSurface& surface, const std::string& name);

  /// Generalized winding number at p (1 inside a closed outward surface, 0 outside).
  [[nodiscard]] double winding_number(const Vec3& p) const;
  /// Distance from p to the nearest triangle, m.
  [[nodiscard]] double unsigned_distance(const Vec3& p) const;
  /// -distance inside (winding number > 1/2), +distance outside.
  [[nodiscard]] double signed_distance(const Vec3& p) const;
  /// Bounding box of the surface, m.
  [[nodiscard]] const Aabb& bounds() const { return bounds_; }
  /// Triangles kept (zero-area ones are dropped).
  [[nodiscard]] std::size_t num_triangles() const { return tris_.size(); }

 private:
  struct Tri {
    Vec3 a, b, c;
  };
  struct BvhNode {
    Aabb box;
    std::int32_t first = 0, count = 0;  ///< leaf: range in tris_; inner: count = 0
    std::int32_t left = -1, right = -1;
    Vec3 area_vector = Vec3::Zero();  ///< sum of triangle area vectors, m^2
    Vec3 center = Vec3::Zero();       ///< area-weighted centroid, m
    double radius = 0;                ///< max distance from center to the box corners, m
  };
  /// Clusters farther than this many radii from the query use the dipole approximation.
  static constexpr double kFarField = 3.0;
  std::int32_t build(std::int32_t first, std::int32_t count);
  std::vector<Tri> tris_;       ///< (#triangles)
  std::vector<BvhNode> nodes_;  ///< root is nodes_[0]
  Aabb bounds_;
  double orientation_ = 1.0;  ///< -1 when the input was inside-out
};

/// Distance from p to triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);
/// Signed solid angle of triangle (a, b, c) seen from p, divided by 4 pi (Van Oosterom &
/// Strackee 1983).
double triangle_winding(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace shatter
