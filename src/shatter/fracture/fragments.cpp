#include "shatter/fracture/fragments.h"

#include "shatter/mesh/topology.h"

namespace shatter {

std::vector<Fragment> extract_fragments(const TetMesh& mesh, double density) {
  const Components comp = connected_components(mesh);
  std::vector<std::vector<Index>> tets(static_cast<std::size_t>(comp.count));
  for (Index e = 0; e < mesh.num_tets(); ++e) tets[comp.tet_component[e]].push_back(e);
  std::vector<Fragment> out(tets.size());
  for (std::size_t c = 0; c < tets.size(); ++c) {
    Fragment& f = out[c];
    f.mesh = extract_tets(mesh, tets[c], &f.node_map);
    f.tet_map = std::move(tets[c]);
    f.mass = mass_properties(f.mesh, density);
  }
  return out;
}

}  // namespace shatter
