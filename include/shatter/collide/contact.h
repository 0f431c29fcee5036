// Narrow phase between convex hulls and planes: the separating-axis test over face normals and
// Gauss-map-pruned edge pairs (Gregorius, "The Separating Axis Test between Convex Polyhedra",
// GDC 2013), then a manifold of up to 4 points from clipping the incident face against the side
// planes of the reference face (Sutherland-Hodgman), or one point between the two closest edges.
// Pairs closer than a speculative distance give contacts with a positive separation, so the
// solver can stop a fast body before it passes through (docs/method.md §2.8).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
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
  /// solver can carry impulses from one step to the next (warm start). Bits 31-30 the kind:
  /// - 0, 1 (face contact, reference face on A, on B): bits 29-22 the reference face, 21-14 the
  ///   incident face (indices mod 256), 13-7 and 6-0 the two lines the point lies on, smaller code
  ///   first. A line code is an incident-face edge (0..63: its place in the face loop from
  ///   HullFace::edge, mod 64) or 64 + a reference-face side (same numbering). An incident vertex
  ///   lies on its two incident edges, a clipped point on an incident edge and a side, a corner of
  ///   the reference face on two sides; (127, 127) marks the single deepest-vertex point used when
  ///   clipping leaves nothing. An overlapping vertex i off the incident face has (127, i mod 127),
  ///   in that order, and i / 127 (mod 256) in place of the incident face.
  /// - 2 (edge contact): bits 29-15 A's edge, 14-0 B's edge (half-edge / 2, mod 2^15).
  /// - 3 (hull and plane): bits 29-0 the hull vertex.
  /// Unique within a manifold while faces have at most 64 edges and hulls fewer than 127 x 256
  /// vertices.
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
///
/// Axis choice, with r = the smaller hull radius: a face of B replaces the face of A as reference
/// only when s_B > s_A + 0.02 |s_A| + 0.002 r, and the edge pair replaces the faces only when
/// s_edge > s_face + 0.1 |s_face| + 0.002 r (s: separation along the axis, s_face the larger of
/// the two), so resting boxes always get a face manifold and the choice does not flicker. Incident
/// vertices up to 0.001 r outside a side plane of the reference face are kept as they are (equal
/// stacked boxes keep their 4 corners and ids under round-off). The incident hull's other vertices
/// that overlap, within the same side planes, are candidates too (a hull sunk past its incident
/// face). When that leaves no point (deep, sideways overlaps) the edge pair gives one point, else
/// the deepest incident vertex. The
/// cache is only tested first: if its axis still separates beyond the speculative distance the
/// result is empty at once; otherwise the full test runs, so results never depend on it.
ContactManifold collide_hulls(const ConvexHull& a, const Transform& ta, const ConvexHull& b, const Transform& tb,
                              double speculative_distance, SatCache* cache = nullptr);

/// The separating-axis test of collide_hulls on its own: the largest separation of the two hulls
/// along the face normals of both and the edge-pair axes that pass the Gauss-map test, m. < 0: the
/// hulls overlap and this is minus the penetration depth; >= 0: they are at least this far apart.
/// `axis` (may be null) receives the feature of that axis, in SatCache's form.
double hull_separation(const ConvexHull& a, const Transform& ta, const ConvexHull& b, const Transform& tb,
                       SatCache* axis = nullptr);

/// Contact between a hull (A) and a plane (B), as a face contact: the incident face is, of the
/// faces around the hull's deepest vertex, the one most anti-parallel to the plane normal; its
/// corners within `speculative_distance` of the plane, and every other vertex that overlaps the
/// plane, are the candidates, reduced to at most 4 (the deepest and the three that span the
/// largest area, chosen among those that touch when at least three do: reduce_manifold_points).
/// The normal is minus the plane normal (from the hull into the plane's solid).
///
/// With `motion`, the hull's velocity over the coming step: the vertex that this motion, held for
/// `motion->dt`, takes deepest through the plane (deeper than `motion->depth`) joins the manifold
/// when it is not in it, in place of its point with the widest gap when it is full. A shard turning
/// fast about the edge it lands on brings its other side down within the step; those vertices are
/// off the incident face and do not overlap yet. With the body's inverse mass and inertia, the
/// motion the landing itself gives counts too: the lowest vertex stopped along the normal (no
/// bounce), the body then turning about it; the vertex that motion takes deepest joins too, never
/// in place of the first one. A shard falling fast onto one end is swung down onto its other end
/// within the step, at several times its falling speed.
struct HullMotion {
  Vec3 linear_velocity = Vec3::Zero();   ///< of the point at ta's origin, world, m/s
  Vec3 angular_velocity = Vec3::Zero();  ///< world, rad/s
  double dt = 0;                         ///< s
  double depth = 0.001;                  ///< m
  double inverse_mass = 0;               ///< 1/kg (0: the landing's turn is not predicted)
  Mat3 inverse_inertia = Mat3::Zero();   ///< in the hull's frame, about ta's origin, 1/(kg m^2)
};
ContactManifold collide_hull_plane(const ConvexHull& a, const Transform& ta, const Plane& plane,
                                   double speculative_distance, const HullMotion* motion = nullptr);

/// Reduce candidate points (all on one manifold normal) to at most 4: the deepest, then the point
/// farthest from it, then the two that add the most area on each side (Box2D/Jolt style). Keeps
/// the input when it has 4 or fewer. `normal` is the manifold normal. With a finite `touch_band`
/// (m), the choice is made among the points that touch, those that overlap or lie within that band
/// of the deepest, when at least three do (the collide functions pass 2 % of the smaller hull
/// radius).
int reduce_manifold_points(const Vec3& normal, std::span<const ManifoldPoint> candidates,
                           std::array<ManifoldPoint, 4>& out,
                           double touch_band = std::numeric_limits<double>::infinity());

}  // namespace shatter
