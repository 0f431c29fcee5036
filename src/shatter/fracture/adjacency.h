// Node-to-tet incidence (CSR) and face neighbours found through it: local topology queries that
// cost O(tets) to set up and need no global face sort (used by crack regions and cutting).
#pragma once

#include <span>
#include <vector>

#include "shatter/mesh/tet_mesh.h"

namespace shatter {

struct NodeTets {
  std::vector<Index> begin;  ///< CSR offsets (#nodes + 1)
  std::vector<Index> tets;   ///< incident tets of each node, increasing
  [[nodiscard]] std::span<const Index> of(Index v) const {
    return {tets.data() + begin[v], static_cast<std::size_t>(begin[v + 1] - begin[v])};
  }
};

NodeTets node_tets(const TetMesh& mesh);

/// The tet other than e that has the three nodes of e's local face k (opposite corner k), or -1.
Index face_neighbor(const TetMesh& mesh, const NodeTets& incidence, Index e, int k);

}  // namespace shatter
