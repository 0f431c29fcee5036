// Fragments: the connected components of a cut mesh as separate meshes with exact rigid-body mass
// properties (constant density), and maps back to the parent's nodes and tets.
#pragma once

#include <vector>

#include "shatter/core/types.h"
#include "shatter/mesh/mass_properties.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// One connected piece of a mesh as a mesh of its own.
struct Fragment {
  TetMesh mesh;                 ///< the component's tets and nodes
  std::vector<Index> node_map;  ///< node of the source mesh of each fragment node (#nodes)
  std::vector<Index> tet_map;   ///< tet of the source mesh of each fragment tet (#tets)
  MassProperties mass;          ///< exact, at the given density
};

/// One fragment per connected component (tets sharing a node), in order of each component's
/// lowest tet; tets keep their relative order. `density`: kg/m^3.
std::vector<Fragment> extract_fragments(const TetMesh& mesh, double density);

}  // namespace shatter
