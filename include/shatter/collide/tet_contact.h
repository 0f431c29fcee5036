// The paper's narrow phase (docs/method.md §2.8), kept as a mode: the vertices of one body tested
// for containment in the tets of the other, located through a uniform grid over those tets, with
// the depth and normal taken from the other body's boundary (its closest boundary triangle). What
// that test misses, an edge of one body passing through the other with both ends outside, is found
// by testing the boundary edges of each body against the boundary triangles of the other.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "shatter/collide/contact.h"
#include "shatter/core/types.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/mesh/topology.h"

namespace shatter {

/// A body's tets, boundary and the acceleration structures the queries need, in the body frame.
struct TetContactShape {
  TetMesh mesh;                        ///< the body's mesh (body frame)
  TriSurface surface;                  ///< its boundary, outward
  std::vector<Vec3> triangle_normals;  ///< outward unit normal of each boundary triangle (zero if degenerate)
  std::vector<std::array<Index, 2>> boundary_edges;  ///< unique boundary edges (surface vertex pairs, i < j, sorted)
  Aabb bounds;                                       ///< box around the nodes
  // Uniform grid over the tets: cell size half the mean tet edge, cells in row-major order (index
  // x + dims[0] * (y + dims[1] * z), x fastest) from grid_origin = bounds.min. Each tet is listed
  // in every cell its (slightly padded) box overlaps, in increasing tet order (counting sort).
  double cell_size = 0;
  Vec3 grid_origin = Vec3::Zero();
  std::array<std::int32_t, 3> grid_dims{};
  std::vector<Index> cell_start;  ///< first entry of each cell (#cells + 1)
  std::vector<Index> cell_tets;   ///< tets overlapping each cell, concatenated
  /// Barycentric coordinates 1..3 of a point x in a tet: to_barycentric * (x - origin); the
  /// coordinate of corner 0 is one minus their sum.
  struct TetMap {
    Mat3 to_barycentric = Mat3::Zero();  ///< inverse of the edge matrix [x1-x0, x2-x0, x3-x0], 1/m
    Vec3 origin = Vec3::Zero();          ///< corner 0, m
  };
  std::vector<TetMap> tet_maps;  ///< per tet (#tets); degenerate tets are left out of the grid
  // Bounding-volume tree over the boundary triangles for closest-point and segment queries: median
  // split along the longest axis of the triangle centroids, ties broken by triangle index; node 0
  // is the root, leaves hold up to 4 triangles.
  struct BvhNode {
    Aabb box;
    Index left = -1;   ///< child, or -1 for a leaf
    Index right = -1;  ///< child (leaf: one past the last triangle in `bvh_triangles`)
    Index first = 0;   ///< leaf: first triangle in `bvh_triangles`
  };
  std::vector<BvhNode> bvh;
  std::vector<Index> bvh_triangles;
};

/// Build the shape of a body from its body-frame mesh and faces.
TetContactShape make_tet_contact_shape(const TetMesh& mesh, const TetFaces& faces);

/// One contact point with its own normal.
struct PointContact {
  Vec3 point = Vec3::Zero();    ///< world, m: midway between the feature and the closest point of the other boundary
  Vec3 normal = Vec3::UnitY();  ///< world unit normal from A to B
  double separation = 0;        ///< m: < 0 overlapping, > 0 a gap within the speculative distance
  std::uint32_t feature = 0;    ///< stable id of the feature pair (vertex/edge of which body)
};

// Feature ids of PointContact: which body owns the feature (A: 0, B: kTetFeatureBodyB), whether it
// is a boundary vertex (surface vertex index) or a boundary edge (index in boundary_edges), and
// that index in the low 30 bits.
inline constexpr std::uint32_t kTetFeatureBodyB = 1u << 31;
inline constexpr std::uint32_t kTetFeatureEdge = 1u << 30;
inline constexpr std::uint32_t kTetFeatureIndexMask = kTetFeatureEdge - 1;

/// A point is inside a tet when each of its barycentric coordinates is >= -kTetInsideTolerance.
inline constexpr double kTetInsideTolerance = 1e-9;

/// The lowest-indexed tet of `shape` containing the body-frame point `p` (within
/// kTetInsideTolerance), found through the grid; -1 when none does.
Index locate_tet(const TetContactShape& shape, const Vec3& p);

/// A closest point of a shape's boundary.
struct BoundaryPoint {
  Vec3 point = Vec3::Zero();  ///< on the boundary, body frame, m
  double distance = 0;        ///< from the query point, m
  Index triangle = -1;        ///< the boundary triangle it lies on
};

/// The boundary point of `shape` closest to the body-frame point `p`, through the BVH; false when
/// none lies within `max_distance` (inclusive; pass infinity for no limit) or there is no boundary.
bool closest_boundary_point(const TetContactShape& shape, const Vec3& p, double max_distance, BoundaryPoint& out);

/// Contacts between two tet bodies placed at `ta`, `tb`: vertices of each inside the other's tets
/// (or outside within `speculative_distance` of its boundary), and boundary edges crossing the
/// other's boundary triangles. Appends to `out` in a fixed order: A's boundary vertices against B,
/// B's against A, A's boundary edges against B, B's against A, each in index order.
///
/// A vertex inside the other body gets the depth of its closest boundary point there and, for a
/// stable direction, minus that triangle's outward normal (made to point from A to B); a vertex
/// outside gets the direction to its closest point (the true gap direction, also across edges and
/// corners of the other body). An edge with both ends outside that passes through the other body
/// gives one point, at the midpoint between its entry and exit (the deepest such midpoint when it
/// crosses several times), with depth and normal from the closest boundary triangle, as a vertex.
/// Edges give contacts only once they overlap: the speculative ones come from vertices alone.
void collide_tet_shapes(const TetContactShape& a, const Transform& ta, const TetContactShape& b, const Transform& tb,
                        double speculative_distance, std::vector<PointContact>& out);

/// Contacts of a tet body's boundary vertices with a plane (B), same conventions: the vertices within
/// `speculative_distance` of the plane (or below it), in surface vertex order, normal minus the
/// plane normal, point midway between the vertex and the plane.
void collide_tet_shape_plane(const TetContactShape& a, const Transform& ta, const Plane& plane,
                             double speculative_distance, std::vector<PointContact>& out);

}  // namespace shatter
