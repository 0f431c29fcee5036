// Selecting mesh nodes for anchors and loads: by file node id, by an axis-aligned box, by a plane
// (with a distance tolerance) or by a named node set of the mesh file.
#pragma once

#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

struct NodeSelector {
  enum class Kind { ids, box, plane, set } kind = Kind::ids;
  std::vector<FileId> ids;   ///< kind ids: node ids as in the mesh file
  Aabb box;                  ///< kind box: nodes with min - tol <= p <= max + tol (m)
  Vec3 point = Vec3::Zero(); ///< kind plane: a point on the plane (m)
  Vec3 normal = Vec3::UnitY();  ///< kind plane: normal (any length > 0)
  /// box and plane: distance tolerance, m. < 0: 1e-6 times the mesh's bounding-box diagonal.
  double tolerance = -1.0;
  std::string set;           ///< kind set: name of a node set of the mesh
};

/// The selected node indices, sorted, without repeats. Errors (no field set; the caller adds it):
/// an id not in the mesh, an unknown set, a selection with no node.
Result<std::vector<Index>> select_nodes(const TetMesh& mesh, const NodeSelector& selector);

/// Human-readable one-line description ("box [0 0 0]..[1 1 1]", "3 node ids").
std::string describe(const NodeSelector& selector);

}  // namespace shatter
