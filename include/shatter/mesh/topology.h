// Derived topology of a TetMesh: unique faces with the tets on each side, face adjacency,
// the boundary surface as outward-oriented triangles, connected components, and node-to-tet
// incidence for local face queries.
#pragma once

#include <array>
#include <span>
#include <vector>

#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// Local faces of a positively oriented tet (a,b,c,d): face k is opposite corner k and its
/// corners, in this order, give the outward normal by the right-hand rule.
inline constexpr std::array<std::array<int, 3>, 4> kTetFaces = {{{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}};
/// Local edges of a tet: edge q joins corners kTetEdges[q][0] < kTetEdges[q][1].
inline constexpr std::array<std::array<int, 2>, 6> kTetEdges = {{{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};

/// The unique faces of a tet mesh and the tets on each side (compute_faces).
struct TetFaces {
  /// Each unique face: corners as seen from tets[0] (outward for tets[0]) (#faces).
  std::vector<TriIndices> faces;
  /// The tets sharing each face: [0] always valid, [1] = -1 on the boundary (#faces x 2).
  std::vector<std::array<Index, 2>> face_tets;
  /// Face index of each tet's local face k (#tets x 4).
  std::vector<std::array<Index, 4>> tet_faces;
  /// Faces shared by more than two tets (non-manifold); their extra tets are listed here as
  /// (face, tet) pairs and not in face_tets.
  std::vector<std::array<Index, 2>> overshared;

  /// Number of unique faces.
  [[nodiscard]] Index num_faces() const { return static_cast<Index>(faces.size()); }
  /// Whether face f has a tet on one side only.
  [[nodiscard]] bool is_boundary(Index f) const { return face_tets[f][1] < 0; }
  /// The tet across local face k of tet e, or -1 on the boundary.
  [[nodiscard]] Index neighbor(Index e, int k) const {
    const auto& ft = face_tets[tet_faces[e][k]];
    return ft[0] == e ? ft[1] : ft[0];
  }
};

/// Unique faces, deterministic order (sorted by their sorted corner indices).
/// Requires every tet node index in [0, num_nodes) (validate_mesh checks that first).
TetFaces compute_faces(const TetMesh& mesh);

/// The faces of `after` (what compute_faces(after) gives, the same bits) from those of `before`, a
/// mesh it shares most tets with: a tet of `after` whose index is below before's tet count and
/// whose corners are the same node indices as before's tet of that index keeps its faces, and only
/// the faces of the other tets, and of their neighbours across them, are searched again. For a mesh
/// cut (cut_mesh keeps the indices of the input's nodes and tets; changed tets and new ones differ)
/// or dented: O(faces) instead of compute_faces' incidence and per-node sorts. Falls back to
/// compute_faces when `before_faces` has faces of more than two tets or the result would.
TetFaces update_faces(const TetMesh& before, const TetFaces& before_faces, const TetMesh& after);

/// The faces of the parts of a mesh that share no face (its connected components, say), from
/// `faces` = compute_faces(mesh): for each part, what compute_faces gives for
/// extract_tets(mesh, its tets in increasing order). `tet_part` (#tets): each tet's part, -1 for a
/// tet in none; `local_tet` (#tets): its index in its part; `local_node` (#nodes): each node's
/// index in the part of its tets; `part_tets`: the tets of each part. One pass over the faces.
std::vector<TetFaces> split_faces(const TetFaces& faces, std::span<const Index> tet_part,
                                  std::span<const Index> local_tet, std::span<const Index> local_node,
                                  std::span<const Index> part_tets);

/// A triangle surface: positions indexed by triangles.
struct TriSurface {
  std::vector<Vec3> positions;        ///< vertex positions, m (#vertices)
  std::vector<TriIndices> triangles;  ///< outward oriented (#triangles)
  std::vector<Index> vertex_node;     ///< tet-mesh node of each vertex (#vertices)
  std::vector<Index> triangle_tet;    ///< tet each triangle bounds (#triangles)
};

/// The boundary faces of the mesh as outward-oriented triangles, with only the boundary nodes as
/// vertices (in increasing node order).
TriSurface boundary_surface(const TetMesh& mesh, const TetFaces& faces);
/// The same, computing the faces first.
TriSurface boundary_surface(const TetMesh& mesh);

/// A label per tet naming its connected component.
struct Components {
  std::vector<Index> tet_component;  ///< component of each tet, in [0, count) (#tets)
  Index count = 0;                   ///< number of components
};
/// Connected components: tets are connected when they share a node. Labels are numbered in order
/// of each component's lowest tet index.
Components connected_components(const TetMesh& mesh);

/// The tets incident to each node, in CSR form (node_tets).
struct NodeTets {
  std::vector<Index> begin;  ///< CSR offsets (#nodes + 1)
  std::vector<Index> tets;   ///< incident tets of each node, increasing
  /// The tets incident to node v, increasing.
  [[nodiscard]] std::span<const Index> of(Index v) const {
    return {tets.data() + begin[v], static_cast<std::size_t>(begin[v + 1] - begin[v])};
  }
};

/// Incident tets of every node (CSR), O(#tets): local face queries without a global face sort
/// (crack regions, cutting).
NodeTets node_tets(const TetMesh& mesh);

/// The same lists as node_tets for the nodes with wanted[v] != 0 (#nodes), empty lists for the
/// others: one pass over the tets that writes only the wanted entries, for queries about a few
/// nodes of a large mesh (the nodes along a cut).
NodeTets node_tets(const TetMesh& mesh, std::span<const char> wanted);

/// The tet other than e that has the three nodes of e's local face k (opposite corner k), or -1.
Index face_neighbor(const TetMesh& mesh, const NodeTets& incidence, Index e, int k);

}  // namespace shatter
