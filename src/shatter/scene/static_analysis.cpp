// The static-analysis pipeline and its files (see static_analysis.h).
#include "shatter/scene/static_analysis.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <system_error>
#include <utility>

#include "shatter/core/clock.h"
#include "shatter/core/file_io.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/scene/static_fracture.h"

namespace shatter {
namespace {

// Mark fragment_<k>.<ext> (and .ele beside .node) for k >= first, left by an earlier run that made
// more fragments, for removal when the batch commits, so the folder then holds exactly this run's
// fragments.
void remove_stale_fragments(OutputBatch& batch, const std::filesystem::path& dir, std::size_t first,
                            const std::string& ext) {
  for (std::size_t k = first;; ++k) {
    const std::filesystem::path p = dir / ("fragment_" + std::to_string(k) + "." + ext);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) break;
    batch.remove_on_commit(p.string());
    if (ext == "node") batch.remove_on_commit((dir / ("fragment_" + std::to_string(k) + ".ele")).string());
  }
}

// Far from the origin (map coordinates: 1e7 m) a double keeps too few digits for displacements of
// micrometres: the solve then runs about the mesh's box centre, and the results are moved back.
// Only then: near the origin the positions are used as given, bit for bit.
Vec3 local_origin(const TetMesh& mesh) {
  Aabb box;
  for (const Vec3& p : mesh.positions) box.extend(p);
  if (mesh.positions.empty()) return Vec3::Zero();
  const Vec3 centre = 0.5 * (box.min + box.max);
  const double size = (box.max - box.min).norm();
  return centre.norm() > 100 * size ? centre : Vec3::Zero();
}

void shift(std::vector<Vec3>& points, const Vec3& by) {
  for (Vec3& p : points) p += by;
}

}  // namespace

Result<StaticAnalysis> run_static_analysis(const StaticCase& c, const TetMesh& world_mesh,
                                           const StaticAnalysisOptions& options) {
  StaticAnalysis a;
  // Anchors and loads are found on the mesh as given; the model and the solve use local positions.
  const auto t_setup = Clock::now();
  SHATTER_TRY(resolved, resolve_static_case(c, world_mesh));
  a.resolved = std::move(*resolved);
  const Vec3 origin = local_origin(world_mesh);
  const bool moved = origin != Vec3::Zero();
  TetMesh local_copy;
  if (moved) {
    local_copy = world_mesh;
    shift(local_copy.positions, -origin);
  }
  const TetMesh& mesh = moved ? local_copy : world_mesh;
  a.model = make_fem_model(mesh, c.material, c.model);
  a.problem = make_static_problem(c, a.resolved);
  if (moved) shift(a.problem.anchor_positions, -origin);  // prescribed positions, as the mesh
  a.solver_options = make_solver_options(c.solver);
  if (a.problem.gravity)
    for (double m : a.model.node_mass) a.gravity_load += m * a.problem.gravity_vector;
  a.setup_ms = ms_since(t_setup);

  // Solve.
  a.deformed = mesh.positions;
  SHATTER_TRY(report, solve_static(a.model, a.problem, a.deformed, a.solver_options));
  a.report = std::move(*report);
  if (!a.report.converged) return a;

  // Results, then fracture and plasticity of the solution from the same stresses.
  std::vector<TetStress> stress = compute_stresses(a.model, a.deformed);
  a.results = compute_static_results(a.model, mesh, a.deformed, stress);
  if (options.fracture) {
    const auto t_frac = Clock::now();
    a.fracture = fracture_with_stress(mesh, a.model, a.deformed, std::move(stress), c.fracture);
    a.fracture_ms = ms_since(t_frac);
  }
  if (moved) {  // back to the mesh's coordinates (displacements and stresses do not move)
    shift(a.deformed, origin);
    if (a.fracture) {
      FractureResult& f = *a.fracture;
      shift(f.mesh.positions, origin);
      shift(f.deformed, origin);
      shift(f.plastic.rest_positions, origin);
      for (Fragment& fr : f.fragments) {
        shift(fr.mesh.positions, origin);
        fr.mass.center += origin;
      }
      for (CrackEvent& e : f.events) e.plan.origin += origin;
    }
  }
  return a;
}

std::vector<std::string> StaticOutputs::all() const {
  std::vector<std::string> out;
  for (const std::string* p : {&displacements, &elements, &result})
    if (!p->empty()) out.push_back(*p);
  out.insert(out.end(), fragments.begin(), fragments.end());
  for (const std::string* p : {&fragments_mesh, &cracks, &rest_shape})
    if (!p->empty()) out.push_back(*p);
  return out;
}

Result<StaticOutputs> write_static_outputs(const std::string& out_dir, const TetMesh& mesh,
                                           const StaticAnalysis& analysis, const std::string& fragment_format) {
  SHATTER_CHECK(analysis.report.converged);
  const std::filesystem::path dir(out_dir);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    return file_error(out_dir, "cannot create the output folder" + (ec ? ": " + ec.message() : std::string()));
  // Every file to a temporary, all renamed at the end: a failure on any output leaves all the
  // earlier results as they were (the batch removes its temporaries when it goes out of scope).
  OutputBatch batch;
  StaticOutputs out;
  out.displacements = (dir / "displacements.csv").string();
  out.elements = (dir / "elements.csv").string();
  out.result = (dir / "result.vtu").string();
  const StaticResults& results = analysis.results;
  for (const auto& written :
       {write_displacements_csv(out.displacements, mesh, results), write_elements_csv(out.elements, mesh, results),
        write_result_mesh(out.result, mesh, results)})
    if (!written) return written.error();
  if (!analysis.fracture) {
    SHATTER_TRY(committed, batch.commit());
    return out;
  }

  const FractureResult& frac = *analysis.fracture;
  for (std::size_t k = 0; k < frac.fragments.size(); ++k) {
    const std::string p = (dir / ("fragment_" + std::to_string(k) + "." + fragment_format)).string();
    auto w = write_mesh(p, fragment_mesh_with_ids(frac, k));
    if (!w) return w.error();
    out.fragments.push_back(p);
  }
  remove_stale_fragments(batch, dir, frac.fragments.size(), fragment_format);
  out.fragments_mesh = (dir / "fragments.vtu").string();
  out.cracks = (dir / "cracks.csv").string();
  for (const auto& written :
       {write_fragments_mesh(out.fragments_mesh, mesh, frac), write_cracks_csv(out.cracks, mesh, frac)})
    if (!written) return written.error();
  if (std::isfinite(analysis.model.material.yield_stress)) {
    out.rest_shape = (dir / "rest_shape.vtu").string();
    auto w = write_rest_shape(out.rest_shape, frac);
    if (!w) return w.error();
  }
  SHATTER_TRY(committed, batch.commit());
  return out;
}

}  // namespace shatter
