#include "shatter/fracture/adjacency.h"

#include <algorithm>

#include "shatter/mesh/topology.h"

namespace shatter {

NodeTets node_tets(const TetMesh& mesh) {
  NodeTets n;
  n.begin.assign(mesh.positions.size() + 1, 0);
  for (const TetIndices& t : mesh.tets)
    for (Index v : t) ++n.begin[v + 1];
  for (std::size_t i = 1; i < n.begin.size(); ++i) n.begin[i] += n.begin[i - 1];
  n.tets.resize(static_cast<std::size_t>(n.begin.back()));
  std::vector<Index> fill(n.begin.begin(), n.begin.end() - 1);
  for (Index e = 0; e < mesh.num_tets(); ++e)
    for (Index v : mesh.tets[e]) n.tets[fill[v]++] = e;
  return n;
}

Index face_neighbor(const TetMesh& mesh, const NodeTets& incidence, Index e, int k) {
  const TetIndices& t = mesh.tets[e];
  const auto a = incidence.of(t[kTetFaces[k][0]]);
  const auto b = incidence.of(t[kTetFaces[k][1]]);
  const auto c = incidence.of(t[kTetFaces[k][2]]);
  for (Index n : a)
    if (n != e && std::binary_search(b.begin(), b.end(), n) && std::binary_search(c.begin(), c.end(), n)) return n;
  return -1;
}

}  // namespace shatter
