// Results of a static analysis derived from the equilibrium positions: nodal displacements,
// per-tet Cauchy stress, principal and von Mises stresses, and their CSV / VTU outputs.
#pragma once

#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fracture/stress.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// Displacements and per-tet stresses of one equilibrium.
struct StaticResults {
  std::vector<Vec3> displacement;     ///< x - rest position, m (#nodes)
  std::vector<Mat3> stress;           ///< Cauchy stress, Pa (#tets)
  std::vector<double> max_principal;  ///< largest principal stress, Pa (#tets)
  std::vector<Vec3> max_direction;    ///< its unit direction (#tets)
  std::vector<double> von_mises;      ///< Pa (#tets)

  Index max_displacement_node = -1;  ///< node of largest |u| (lowest index on ties)
  double max_displacement = 0;       ///< m
  Index max_principal_tet = -1;      ///< tet of largest principal stress (lowest index on ties)
  double max_principal_stress = 0;   ///< Pa
  Index max_von_mises_tet = -1;      ///< tet of largest von Mises stress (lowest index on ties)
  double max_von_mises = 0;          ///< Pa
};

/// Displacements and stresses (by compute_stresses, fracture/stress.h) at the deformed positions x
/// (m, #nodes).
StaticResults compute_static_results(const FemModel& model, const TetMesh& rest_mesh, const std::vector<Vec3>& x);
/// The same from the stresses compute_stresses(model, x) already gave (#tets).
StaticResults compute_static_results(const FemModel& model, const TetMesh& rest_mesh, const std::vector<Vec3>& x,
                                     const std::vector<TetStress>& stress);

/// displacements.csv: "node_id,ux,uy,uz" then one row per node (file ids, %.17g).
Result<void> write_displacements_csv(const std::string& path, const TetMesh& mesh, const StaticResults& r);
/// elements.csv: "element_id,sxx,syy,szz,sxy,syz,szx,max_principal,dir_x,dir_y,dir_z,von_mises"
/// then one row per tet (file ids, Pa, %.17g).
Result<void> write_elements_csv(const std::string& path, const TetMesh& mesh, const StaticResults& r);
/// result.vtu (or any mesh format holding fields): point data displacement and node_id, cell data
/// stress (6: xx yy zz xy yz zx), max_principal, max_principal_direction, von_mises, tet_id.
Result<void> write_result_mesh(const std::string& path, const TetMesh& mesh, const StaticResults& r);

}  // namespace shatter
