// Selecting mesh nodes for anchors and loads: by file node id, by an axis-aligned box, by a plane
// (with a distance tolerance) or by a named node set of the mesh file; the boundary area lumped at
// selected nodes (to spread a load) and whether held node components stop every rigid motion.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// Which nodes an anchor or a load applies to.
struct NodeSelector {
  /// How nodes are chosen: by file id, inside a box, near a plane, or a named node set.
  enum class Kind { ids, box, plane, set } kind = Kind::ids;
  std::vector<FileId> ids;      ///< kind ids: node ids as in the mesh file
  Aabb box;                     ///< kind box: nodes with min - tol <= p <= max + tol (m)
  Vec3 point = Vec3::Zero();    ///< kind plane: a point on the plane (m)
  Vec3 normal = Vec3::UnitY();  ///< kind plane: normal (any length > 0)
  /// box and plane: distance tolerance, m. < 0: 1e-6 times the mesh's bounding-box diagonal.
  double tolerance = -1.0;
  std::string set;  ///< kind set: name of a node set of the mesh
};

/// The selected node indices, sorted, without repeats. Errors (no field set; the caller adds it):
/// an id not in the mesh, an unknown set, a selection with no node.
Result<std::vector<Index>> select_nodes(const TetMesh& mesh, const NodeSelector& selector);

/// Human-readable one-line description ("box [0, 0, 0]..[1, 1, 1]", "3 node id(s)").
std::string describe(const NodeSelector& selector);

/// Lumped boundary area of each of `nodes` (m^2, same order): each boundary triangle whose three
/// corners are all among `nodes` gives a third of its area to each corner.
std::vector<double> lumped_boundary_area(const TetMesh& mesh, const std::vector<Index>& nodes);

/// Whether the held components `held` (#nodes; bit c = component c held, as AnchorMask) stop every
/// rigid motion of the nodes `piece_nodes` (one connected piece): the rows of the held components
/// of the rigid-motion basis (3 translations, 3 small rotations about the piece's centre, lengths
/// scaled by its size) must have rank 6.
bool holds_rigid_motion(const TetMesh& mesh, const std::vector<Index>& piece_nodes,
                        const std::vector<std::uint8_t>& held);

}  // namespace shatter
