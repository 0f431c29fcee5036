// TetMesh: the one tetrahedral mesh type every subsystem shares (structure of arrays).
// Node positions and 4-node tets with positive orientation, plus optional attributes carried from
// the file it came from (ids, region tags, named sets) so results can be matched with other tools.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "shatter/core/types.h"

namespace shatter {

/// A tetrahedral mesh: node positions, tets, and optional attributes from its source file.
struct TetMesh {
  std::vector<Vec3> positions;   ///< node positions, m (#nodes)
  std::vector<TetIndices> tets;  ///< node indices per tet, positive orientation (#tets)

  // Optional attributes: each is either empty or has one entry per node / tet.
  std::vector<FileId> node_ids;                         ///< id of each node in its source file (#nodes); empty: i+1
  std::vector<FileId> tet_ids;                          ///< id of each tet in its source file (#tets); empty: e+1
  std::vector<std::int32_t> tet_tags;                   ///< region / physical tag per tet (#tets); empty: none
  std::vector<std::int32_t> node_tags;                  ///< boundary marker per node (#nodes); empty: none
  std::map<std::string, std::vector<Index>> node_sets;  ///< named node sets (node indices, sorted)
  std::map<std::string, std::vector<Index>> tet_sets;   ///< named tet sets (tet indices, sorted)

  /// Number of nodes.
  [[nodiscard]] Index num_nodes() const { return static_cast<Index>(positions.size()); }
  /// Number of tets.
  [[nodiscard]] Index num_tets() const { return static_cast<Index>(tets.size()); }
  /// File id of node i (node_ids[i], or i+1 when the mesh has none).
  [[nodiscard]] FileId node_id(Index i) const { return node_ids.empty() ? FileId(i) + 1 : node_ids[i]; }
  /// File id of tet e (tet_ids[e], or e+1 when the mesh has none).
  [[nodiscard]] FileId tet_id(Index e) const { return tet_ids.empty() ? FileId(e) + 1 : tet_ids[e]; }
  /// Whether node ids are stored (else they are i+1).
  [[nodiscard]] bool has_node_ids() const { return !node_ids.empty(); }
  /// Whether tet ids are stored (else they are e+1).
  [[nodiscard]] bool has_tet_ids() const { return !tet_ids.empty(); }

  /// The 4 corner positions of tet e, m (column k = corner k).
  [[nodiscard]] Mat34 corners(Index e) const {
    Mat34 x;
    for (int k = 0; k < 4; ++k) x.col(k) = positions[tets[e][k]];
    return x;
  }
  /// Bounding box of the nodes, m (empty when there are none).
  [[nodiscard]] Aabb bounds() const {
    Aabb b;
    for (const Vec3& p : positions) b.extend(p);
    return b;
  }

  /// Equal when every array and set is equal.
  friend bool operator==(const TetMesh&, const TetMesh&) = default;
};

/// Signed volume of the tet (a,b,c,d), m^3: det[b-a, c-a, d-a] / 6; positive for positive orientation.
inline double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}
/// Signed volume of tet e of `mesh`, m^3.
inline double signed_volume(const TetMesh& mesh, Index e) {
  const TetIndices& t = mesh.tets[e];
  return signed_volume(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]], mesh.positions[t[3]]);
}
/// Sum of signed tet volumes, m^3.
double total_volume(const TetMesh& mesh);

/// Keep only the listed tets (in the given order) and the nodes they use (in increasing index
/// order); ids, tags and sets follow. Returns the new mesh; `node_map` (if given) receives, for
/// each new node, its index in `mesh`.
TetMesh extract_tets(const TetMesh& mesh, const std::vector<Index>& tets, std::vector<Index>* node_map = nullptr);

}  // namespace shatter
