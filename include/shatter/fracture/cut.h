// Cutting a tet mesh along a crack (docs/method.md §2.5, Fig. 4): optional splitting of the tets a plane
// crosses, then disconnection of the faces between tets on opposite sides by duplicating nodes.
#pragma once

#include <cstdint>
#include <vector>

#include "shatter/core/types.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// The plane {x : normal . (x - point) = 0}; `normal` is a unit vector, the + side is where it
/// points.
struct CutPlane {
  Vec3 point = Vec3::Zero();    ///< a point on the plane, m
  Vec3 normal = Vec3::UnitX();  ///< unit normal
};

/// Settings of the cut.
struct CutOptions {
  /// Split the crack's tets that the plane crosses along it, so the crack surface is flat
  /// (docs/method.md Fig. 4). Off: the crack follows the mesh's faces.
  bool split_tets = true;
  /// A node closer to the plane than snap_fraction x (its shortest edge in the crack region)
  /// counts as lying on it: no edge point is made near it (no slivers). Nodes are never moved,
  /// so volume and mass are exactly conserved.
  double snap_fraction = 0.1;
  /// A tet is split only if every piece has at least min_volume_fraction x its volume;
  /// otherwise it stays whole (and the tets sharing its crossed edges too, to stay conforming).
  double min_volume_fraction = 1e-3;
};

/// Where a node of a cut mesh comes from: its position is (1 - t) x[a] + t x[b] in the input mesh
/// (a == b, t == 0 for a kept or duplicated node). Interpolate deformed positions or velocities the
/// same way.
struct NodeOrigin {
  Index a = -1;  ///< first input node
  Index b = -1;  ///< second input node (== a for a kept or duplicated node)
  double t = 0;  ///< weight of b, in [0, 1]
};

/// A cut mesh and how it relates to the input.
struct CutResult {
  TetMesh mesh;                         ///< the cut mesh: input nodes and tets keep their indices
                                        ///< (a split tet's first piece keeps its index); new ones
                                        ///< are appended, with fresh ids above the input's maximum
  std::vector<NodeOrigin> node_origin;  ///< per node of `mesh` (#nodes)
  std::vector<Index> tet_parent;        ///< input tet of each tet of `mesh` (#tets)
  std::vector<std::int8_t> tet_side;    ///< +1 / -1: side of the plane in the crack; 0: outside it
  Index tets_split = 0;                 ///< input tets split along the plane
  Index edge_nodes = 0;                 ///< nodes made on crossed edges
  Index nodes_duplicated = 0;           ///< node copies made to open the crack
  Index faces_cut = 0;                  ///< faces between + and - tets that were disconnected
  /// Input tets whose corners changed: split (their first piece) or given a node copy; increasing.
  /// Every other input tet keeps its corners.
  std::vector<Index> changed_tets;
};

/// Split the tets of `region` (indices into mesh.tets) that the plane crosses along it, mark the
/// region's tets (pieces) + / - by side, and return the conforming result (faces still shared).
/// Quad faces are split by the diagonal through their lowest-index node (Dompierre et al. 1999), so
/// both tets sharing a face agree; every piece is positively oriented.
CutResult split_along_plane(const TetMesh& mesh, const CutPlane& plane, const std::vector<Index>& region,
                            const CutOptions& options = {});

/// A mesh with faces disconnected (disconnect_faces).
struct DisconnectResult {
  TetMesh mesh;                     ///< the input's tets and nodes, plus the node copies (appended)
  std::vector<Index> node_parent;   ///< input node of each node of `mesh` (#nodes of mesh)
  Index nodes_duplicated = 0;       ///< node copies made
  Index faces_cut = 0;              ///< faces disconnected
  std::vector<Index> changed_tets;  ///< tets given a node copy, increasing
};
/// Disconnect the faces between tets of side +1 and -1 (#tets, others 0): every node on such a face
/// gets one copy per group of its tets that stay connected through uncut faces around it, so a
/// crack ending inside the body leaves the rest attached. Faces whose disconnection would leave an
/// edge with more than two boundary triangles are kept connected. `node_parent` receives the
/// input node of each output node.
DisconnectResult disconnect_faces(const TetMesh& mesh, const std::vector<std::int8_t>& tet_side);

/// split_along_plane (which marks the sides, and splits only if options.split_tets) then
/// disconnect_faces; node_origin is given relative to the input mesh.
CutResult cut_mesh(const TetMesh& mesh, const CutPlane& plane, const std::vector<Index>& region,
                   const CutOptions& options = {});

}  // namespace shatter
