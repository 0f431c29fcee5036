// Narrow phase between convex hulls and planes: the separating-axis test over face normals and
// Gauss-map-pruned edge pairs (Gregorius, "The Separating Axis Test between Convex Polyhedra",
// GDC 2013), then a manifold of up to 4 points from clipping the incident face against the side
// planes of the reference face (Sutherland-Hodgman), or one point between the two closest edges.
// Pairs closer than a speculative distance give contacts with a positive separation, so the
// solver can stop a fast body before it passes through (docs/method.md §2.8).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "shatter/collide/convex_hull.h"
#include "shatter/core/types.h"

namespace shatter {

/// A rigid placement: world = rotation * local + translation.
struct Transform {
  Mat3 rotation = Mat3::Identity();  ///< proper rotation
  Vec3 translation = Vec3::Zero();   ///< m
  /// Map a point from the local frame to the world.
  [[nodiscard]] Vec3 apply(const Vec3& p) const { return rotation * p + translation; }
  /// Map a world point into the local frame.
  [[nodiscard]] Vec3 apply_inverse(const Vec3& p) const { return rotation.transpose() * (p - translation); }
};

/// A plane normal . x = offset in the world (the ground), solid on the side opposite the normal.
struct Plane {
  Vec3 normal = Vec3::UnitY();  ///< unit, pointing out of the solid
  double offset = 0;            ///< m
};

/// One contact point of a manifold.
struct ManifoldPoint {
  Vec3 point = Vec3::Zero();  ///< world, m: midway between the two surfaces
  double separation = 0;      ///< along the manifold normal, m: < 0 overlapping, > 0 a gap
  /// Names the pair of features that made the point (stable while the contact persists), so the
  /// solver can carry impulses from one step to the next (warm start).
  std::uint32_t feature = 0;
};

/// Contact between two shapes A and B: one normal, up to 4 points.
struct ContactManifold {
  Vec3 normal = Vec3::UnitY();            ///< world unit normal, pointing from A to B
  std::array<ManifoldPoint, 4> points{};  ///< the first `count` are valid
  int count = 0;                          ///< 0: no contact within the speculative distance
};

/// What the separating-axis test found last time for a pair; passing it back lets the next query
/// test that axis first and usually stop there (a cache, not state that changes results).
struct SatCache {
  /// 0 none, 1 face of A, 2 face of B, 3 edge pair.
  std::uint8_t kind = 0;
  Index index_a = -1;  ///< face or half-edge of A
  Index index_b = -1;  ///< face or half-edge of B
};

/// Contact between two hulls placed at `ta`, `tb`. Points with separation > `speculative_distance`
/// are left out; an empty manifold (count 0) means farther apart than that. `cache` may be null.
ContactManifold collide_hulls(const ConvexHull& a, const Transform& ta, const ConvexHull& b, const Transform& tb,
                              double speculative_distance, SatCache* cache = nullptr);

/// Contact between a hull (A) and a plane (B): the hull's vertices within `speculative_distance`
/// of the plane, reduced to at most 4 (the deepest and the three that span the largest area). The
/// normal is minus the plane normal (from the hull into the plane's solid).
ContactManifold collide_hull_plane(const ConvexHull& a, const Transform& ta, const Plane& plane,
                                   double speculative_distance);

/// Reduce candidate points (all on one manifold normal) to at most 4: the deepest, then the point
/// farthest from it, then the two that add the most area on each side (Box2D/Jolt style). Keeps
/// the input when it has 4 or fewer. `normal` is the manifold normal.
int reduce_manifold_points(const Vec3& normal, std::span<const ManifoldPoint> candidates,
                           std::array<ManifoldPoint, 4>& out);

}  // namespace shatter
