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
  TetMesh mesh;                           ///< the body's mesh (body frame)
  TriSurface surface;                     ///< its boundary, outward
  std::vector<std::array<Index, 2>> boundary_edges;  ///< unique boundary edges (surface vertex pairs)
  Aabb bounds;                            ///< box around the nodes
  // Uniform grid over the tets (cell size from the mean tet size), counting-sorted cell lists.
  double cell_size = 0;
  Vec3 grid_origin = Vec3::Zero();
  std::array<std::int32_t, 3> grid_dims{};
  std::vector<Index> cell_start;          ///< first entry of each cell (#cells + 1)
  std::vector<Index> cell_tets;           ///< tets overlapping each cell, concatenated
  // Bounding-volume tree over the boundary triangles for closest-point queries.
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
  Vec3 point = Vec3::Zero();      ///< world, m
  Vec3 normal = Vec3::UnitY();    ///< world unit normal from A to B
  double separation = 0;          ///< m: < 0 overlapping, > 0 a gap within the speculative distance
  std::uint32_t feature = 0;      ///< stable id of the feature pair (vertex/edge of which body)
};

/// Contacts between two tet bodies placed at `ta`, `tb`: vertices of each inside the other's tets
/// (or outside within `speculative_distance` of its boundary), and boundary edges crossing the
/// other's boundary triangles. Appends to `out` in a fixed order.
void collide_tet_shapes(const TetContactShape& a, const Transform& ta, const TetContactShape& b,
                        const Transform& tb, double speculative_distance, std::vector<PointContact>& out);

/// Contacts of a tet body's boundary vertices with a plane (B), same conventions.
void collide_tet_shape_plane(const TetContactShape& a, const Transform& ta, const Plane& plane,
                             double speculative_distance, std::vector<PointContact>& out);

}  // namespace shatter
