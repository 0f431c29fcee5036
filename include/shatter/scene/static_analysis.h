// A whole static analysis of one mesh under a load case (`shatter static`, docs/static_case.md):
// resolve the case on the mesh, build the FEM model, solve, derive displacements and stresses,
// and optionally crack and yield the solved body; then write the results as one set of files.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fracture/fracture.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/scene/static_case.h"
#include "shatter/scene/static_results.h"
#include "shatter/solve/static_solver.h"

namespace shatter {

/// Options of run_static_analysis.
struct StaticAnalysisOptions {
  /// Crack and yield the solved body with the case's "fracture" settings (fracture.h).
  bool fracture = false;
};

/// Everything a static analysis computed. When the solver did not converge, `report` says why
/// (report.converged false) and `results` and `fracture` are empty: nothing should be written.
struct StaticAnalysis {
  ResolvedStaticCase resolved;             ///< anchors and loads per node
  FemModel model;                          ///< of the input mesh
  StaticProblem problem;                   ///< what the solver was given
  StaticSolverOptions solver_options;      ///< solver settings, from the case
  StaticReport report;                     ///< how the solve ended
  std::vector<Vec3> deformed;              ///< equilibrium positions, m (#nodes)
  StaticResults results;                   ///< displacements and stresses
  std::optional<FractureResult> fracture;  ///< with options.fracture
  Vec3 gravity_load = Vec3::Zero();        ///< total gravity load, N (zero without gravity)
  double setup_ms = 0;                     ///< case resolution and model, ms
  double fracture_ms = 0;                  ///< fracture and plasticity, ms
};

/// Run the analysis. Errors: the case does not fit the mesh (resolve_static_case), or the solver
/// got inconsistent sizes. A solve that does not converge is not an error: see StaticAnalysis.
Result<StaticAnalysis> run_static_analysis(const StaticCase& c, const TetMesh& mesh,
                                           const StaticAnalysisOptions& options = {});

/// Paths of the files one analysis wrote, in the order written.
struct StaticOutputs {
  std::string displacements;           ///< displacements.csv
  std::string elements;                ///< elements.csv
  std::string result;                  ///< result.vtu
  std::vector<std::string> fragments;  ///< fragment_<k>.<format>, with fracture
  std::string fragments_mesh;          ///< fragments.vtu, with fracture
  std::string cracks;                  ///< cracks.csv, with fracture
  std::string rest_shape;              ///< rest_shape.vtu, with fracture of a plastic material
  /// Every path above that was written, in order.
  [[nodiscard]] std::vector<std::string> all() const;
};

/// Write the results of a converged analysis into `out_dir` (created if missing): displacements,
/// element stresses and a VTU; with fracture also one mesh per fragment in `fragment_format`
/// (a mesh extension: vtu, vtk, msh, mesh, inp, node), the whole cut mesh, the cracks and the
/// plastic rest shape. fragment_<k> files left by an earlier run with more fragments are removed.
/// The files are replaced all together or not at all: if any cannot be written, every file of an
/// earlier run in `out_dir` is left as it was.
Result<StaticOutputs> write_static_outputs(const std::string& out_dir, const TetMesh& mesh,
                                           const StaticAnalysis& analysis, const std::string& fragment_format = "vtu");

}  // namespace shatter
