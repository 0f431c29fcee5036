#include "shatter/mesh/tet_mesh.h"

#include <algorithm>

namespace shatter {

double total_volume(const TetMesh& mesh) {
  double v = 0.0;
  for (Index e = 0; e < mesh.num_tets(); ++e) v += signed_volume(mesh, e);
  return v;
}

TetMesh extract_tets(const TetMesh& mesh, const std::vector<Index>& tets, std::vector<Index>* node_map) {
  std::vector<Index> new_index(mesh.positions.size(), -1);
  for (Index e : tets)
    for (Index v : mesh.tets[e]) new_index[v] = 0;
  std::vector<Index> old_of_new;
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    if (new_index[i] == 0) {
      new_index[i] = static_cast<Index>(old_of_new.size());
      old_of_new.push_back(i);
    }
  TetMesh out;
  out.positions.reserve(old_of_new.size());
  for (Index i : old_of_new) out.positions.push_back(mesh.positions[i]);
  if (!mesh.node_ids.empty())
    for (Index i : old_of_new) out.node_ids.push_back(mesh.node_ids[i]);
  if (!mesh.node_tags.empty())
    for (Index i : old_of_new) out.node_tags.push_back(mesh.node_tags[i]);
  std::vector<Index> new_tet(mesh.tets.size(), -1);
  for (Index e : tets) {
    new_tet[e] = static_cast<Index>(out.tets.size());
    TetIndices t = mesh.tets[e];
    for (Index& v : t) v = new_index[v];
    out.tets.push_back(t);
    if (!mesh.tet_ids.empty()) out.tet_ids.push_back(mesh.tet_ids[e]);
    if (!mesh.tet_tags.empty()) out.tet_tags.push_back(mesh.tet_tags[e]);
  }
  for (const auto& [name, set] : mesh.node_sets) {
    std::vector<Index> s;
    for (Index i : set)
      if (new_index[i] >= 0) s.push_back(new_index[i]);
    std::sort(s.begin(), s.end());
    if (!s.empty()) out.node_sets[name] = std::move(s);
  }
  for (const auto& [name, set] : mesh.tet_sets) {
    std::vector<Index> s;
    for (Index e : set)
      if (new_tet[e] >= 0) s.push_back(new_tet[e]);
    std::sort(s.begin(), s.end());
    if (!s.empty()) out.tet_sets[name] = std::move(s);
  }
  if (node_map) *node_map = std::move(old_of_new);
  return out;
}

}  // namespace shatter
