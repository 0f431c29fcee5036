// Convex hulls of point sets (quickhull), kept as a half-edge mesh with planar polygon faces: the
// shape the contact generation clips against (docs/method.md §2.8). Coplanar triangles are merged
// into one face, so a box has 6 faces and 12 edges however its surface was triangulated; that is
// what gives a box resting on a box one normal and a four-point manifold.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"

namespace shatter {

/// One directed edge of a hull. Edge 2k and 2k+1 are twins (the same edge, both directions).
struct HullHalfEdge {
  Index origin = -1;  ///< vertex it starts at
  Index next = -1;    ///< next half-edge around its face (counter-clockwise seen from outside)
  Index face = -1;    ///< face on its left (seen from outside)
};

/// One planar convex face: the plane normal . x = offset, normal outward and unit.
struct HullFace {
  Vec3 normal = Vec3::UnitX();  ///< outward unit normal
  double offset = 0;            ///< plane offset, m (normal . x for any x on the face)
  Index edge = -1;              ///< one of its half-edges (walk `next` around the face)
};

/// A closed convex polyhedron in its own frame (for a body piece: the body frame).
struct ConvexHull {
  std::vector<Vec3> vertices;       ///< hull vertices, m (only extreme points)
  std::vector<HullHalfEdge> edges;  ///< half-edges, twins adjacent (2k, 2k+1)
  std::vector<HullFace> faces;      ///< planar faces
  Vec3 centroid = Vec3::Zero();     ///< centre of the solid, m
  double volume = 0;                ///< m^3
  double radius = 0;                ///< largest distance from the centroid to a vertex, m
  Aabb bounds;                      ///< box around the vertices, m
  double tolerance = 0;             ///< the tolerance it was built with, m (HullOptions::tolerance resolved)

  /// Twin of half-edge e.
  [[nodiscard]] static Index twin(Index e) { return e ^ 1; }
  /// The vertex farthest along direction d (support mapping; ties broken by the lowest index).
  [[nodiscard]] Index support(const Vec3& d) const;
};

/// Settings of the hull builder.
struct HullOptions {
  /// Points within this distance of a face plane count as on it (half of it above a triangle
  /// while building), and adjacent faces whose vertices fit in a slab this wide are merged. 0: from the point set, 1e-9 of its extent plus a few round-off units.
  double tolerance = 0;
};

/// Hull of a point set (quickhull). Interior and duplicate points are dropped; nearly coplanar
/// triangles are merged into convex polygons. Vertices are input points, in input order; every
/// input point lies on or behind every face plane within the tolerance (up to about 1.2x the
/// tolerance where noise of the tolerance's own size made faces merge). Visibility is decided
/// with exact predicates, so the structure is valid for any input.
/// Errors: fewer than 4 points, non-finite points, or points that span no volume (all on a plane
/// or line, within the tolerance).
Result<ConvexHull> build_convex_hull(std::span<const Vec3> points, const HullOptions& options = {});

/// The hull moved by `shift`, m: vertices v + shift (bitwise what the shifted input points are,
/// as IEEE addition), the same faces and edges, face offsets and the centroid, volume, radius and
/// bounds of the moved vertices; the tolerance is kept. For a hull whose points were all moved by
/// the same amount, at a small fraction of the cost of build_convex_hull on the moved points.
[[nodiscard]] ConvexHull translated_hull(ConvexHull hull, const Vec3& shift);

/// Volume of the hull of `points`, m^3, from the triangle stage of build_convex_hull alone (no
/// faces merged, no structure kept): for callers that only compare volumes, at about half the
/// cost. Agrees with build_convex_hull's volume to the faces it merges within the tolerance (at
/// most the tolerance times the surface area). Errors: as build_convex_hull.
Result<double> convex_hull_volume(std::span<const Vec3> points, const HullOptions& options = {});

/// Checks a hull's structure and convexity (for tests and debug builds): twins and face loops
/// consistent, Euler V - E + F = 2, every vertex on or behind every face plane within
/// `tolerance`, each face's own vertices within 2 x `tolerance` of its plane, adjacent faces not coplanar (coplanar: the vertices of both fit in a slab of width
/// `tolerance` across either face's normal; the builder merges such faces). Returns an empty
/// string when valid, else what failed.
std::string check_convex_hull(const ConvexHull& hull, double tolerance);

}  // namespace shatter
