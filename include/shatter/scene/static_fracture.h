// Outputs of fracture and plasticity after a static solve (`shatter static --fracture`,
// docs/static_case.md): one mesh per fragment, the whole cut mesh with fragment and stress fields,
// the crack events as CSV and the plastic rest shape.
#pragma once

#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fracture/fracture.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// Fragment index of each tet of r.mesh (#tets).
std::vector<Index> fragment_of_tets(const FractureResult& r);

/// Fragment k's mesh with the file ids of the cut mesh written out explicitly: input nodes and tets
/// keep their input ids, nodes and tets made by cutting keep the fresh ids the cut gave them.
TetMesh fragment_mesh_with_ids(const FractureResult& r, std::size_t k);

/// Largest plastic strain over the tets of r.mesh (0 if none).
double max_plastic_strain(const FractureResult& r);

/// The whole cut mesh (rest positions) with point data displacement (deformed - rest, m) and
/// node_id, cell data fragment_id (the k of fragment_<k>), display_stress (Pa, signed: the larger in
/// magnitude of the largest tension and the largest compression, of the tet's input tet),
/// max_principal (Pa), von_mises (Pa), plastic_strain, parent_tet_id (the input tet's id) and
/// tet_id. Format by extension (VTU / VTK hold the fields).
Result<void> write_fragments_mesh(const std::string& path, const TetMesh& input, const FractureResult& r);

/// cracks.csv: "crack,origin_element_id,x,y,z,nx,ny,nz,radius,stress,ductile,tets_marked,tets_split,
/// edge_nodes,nodes_duplicated,faces_cut", one row per crack in the order cut (%.17g; m, Pa; the
/// origin element id is the input mesh's; ductile 1 when the origin tore from plastic strain).
Result<void> write_cracks_csv(const std::string& path, const TetMesh& input, const FractureResult& r);

/// The rest shape after plasticity (and cuts): r.mesh with cell data plastic_strain and tet_id.
Result<void> write_rest_shape(const std::string& path, const FractureResult& r);

}  // namespace shatter
