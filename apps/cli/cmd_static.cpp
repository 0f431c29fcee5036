// `shatter static MESH --case CASE.json [--out DIR] [--json] [--fracture]`: static analysis of a mesh
// under the anchors and loads of a case file; writes displacements, element stresses and a VTU, and
// with --fracture the fragments, cracks and plastic rest shape of the solution; prints a summary
// (docs/static_case.md).
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "command.h"
#include "shatter/fem/fem_model.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/fracture/fracture.h"
#include "shatter/scene/static_case.h"
#include "shatter/scene/static_fracture.h"
#include "shatter/scene/static_results.h"
#include "shatter/solve/static_solver.h"

namespace shatter::cli {
namespace {

struct StaticArgs {
  std::string mesh_path;
  std::string case_path;
  std::string out_dir;
  bool json = false;
  bool fracture = false;
  std::string fragment_format = "vtu";
};

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

std::string vec_text(const Vec3& v) { return fmt::format("[{:.6g}, {:.6g}, {:.6g}]", v.x(), v.y(), v.z()); }

// Remove fragment_<k>.<ext> (and .ele beside .node) for k >= first, left by an earlier run that made
// more fragments, so the folder holds exactly this run's fragments.
void remove_stale_fragments(const std::filesystem::path& dir, std::size_t first, const std::string& ext) {
  for (std::size_t k = first;; ++k) {
    const std::filesystem::path p = dir / fmt::format("fragment_{}.{}", k, ext);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) break;
    std::filesystem::remove(p, ec);
    if (ext == "node") std::filesystem::remove(dir / fmt::format("fragment_{}.ele", k), ec);
  }
}

int run_static(const StaticArgs& args) {
  // Read the inputs.
  const auto t_read = Clock::now();
  auto scase = read_static_case(args.case_path);
  if (!scase) return report_error(scase.error().to_string(), kExitBadInput);
  auto read = read_mesh(args.mesh_path);
  if (!read) return report_error(read.error().to_string(), kExitBadInput);
  const TetMesh& mesh = read->mesh;
  if (mesh.num_tets() == 0) return report_error(args.mesh_path + ": the mesh has no tetrahedra", kExitBadInput);
  const double read_ms = ms_since(t_read);

  // Anchors, loads, model.
  const auto t_setup = Clock::now();
  auto resolved = resolve_static_case(*scase, mesh);
  if (!resolved) return report_error(resolved.error().to_string(), kExitBadInput);
  const FemModel model = make_fem_model(mesh, scase->material, scase->model);
  const StaticProblem problem = make_static_problem(*scase, *resolved);
  const StaticSolverOptions options = make_solver_options(scase->solver);
  const double setup_ms = ms_since(t_setup);

  // Solve.
  std::vector<Vec3> x = mesh.positions;
  auto report = solve_static(model, problem, x, options);
  if (!report) return report_error(report.error().to_string(), kExitBadInput);
  if (!report->converged)
    return report_error(fmt::format("the static solver did not converge: {} (Newton iterations {}, relative "
                                    "residual {:.3g}, load fraction {:.3g}); no output written",
                                    report->message, report->newton_iterations, report->relative_residual,
                                    report->load_fraction),
                        kExitFailure);

  // Results and files.
  const auto t_write = Clock::now();
  const StaticResults results = compute_static_results(model, mesh, x);
  const std::filesystem::path out_dir =
      args.out_dir.empty() ? std::filesystem::path(scase->name + "_out") : std::filesystem::path(args.out_dir);
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec || !std::filesystem::is_directory(out_dir))
    return report_error(out_dir.string() + ": cannot create the output folder" + (ec ? ": " + ec.message() : ""),
                        kExitOutput);
  const std::string disp_path = (out_dir / "displacements.csv").string();
  const std::string elem_path = (out_dir / "elements.csv").string();
  const std::string vtu_path = (out_dir / "result.vtu").string();
  for (const auto& written : {write_displacements_csv(disp_path, mesh, results),
                              write_elements_csv(elem_path, mesh, results),
                              write_result_mesh(vtu_path, mesh, results)})
    if (!written) return report_error(written.error().to_string(), kExitOutput);
  std::vector<std::string> outputs = {disp_path, elem_path, vtu_path};

  // Fracture and plasticity of the solution.
  FractureResult frac;
  double fracture_ms = 0;
  std::vector<std::string> fragment_paths;
  std::string fragments_path, cracks_path, rest_path;
  const bool plastic = std::isfinite(scase->material.yield_stress);
  if (args.fracture) {
    const auto t_frac = Clock::now();
    frac = fracture(mesh, x, scase->material, scase->model, scase->fracture);
    fracture_ms = ms_since(t_frac);
    for (std::size_t k = 0; k < frac.fragments.size(); ++k) {
      const std::string p = (out_dir / fmt::format("fragment_{}.{}", k, args.fragment_format)).string();
      auto w = write_mesh(p, fragment_mesh_with_ids(frac, k));
      if (!w) return report_error(w.error().to_string(), kExitOutput);
      fragment_paths.push_back(p);
    }
    remove_stale_fragments(out_dir, frac.fragments.size(), args.fragment_format);
    fragments_path = (out_dir / "fragments.vtu").string();
    cracks_path = (out_dir / "cracks.csv").string();
    for (const auto& written : {write_fragments_mesh(fragments_path, mesh, frac), write_cracks_csv(cracks_path, mesh, frac)})
      if (!written) return report_error(written.error().to_string(), kExitOutput);
    if (plastic) {
      rest_path = (out_dir / "rest_shape.vtu").string();
      auto w = write_rest_shape(rest_path, frac);
      if (!w) return report_error(w.error().to_string(), kExitOutput);
    }
    outputs.insert(outputs.end(), fragment_paths.begin(), fragment_paths.end());
    outputs.push_back(fragments_path);
    outputs.push_back(cracks_path);
    if (!rest_path.empty()) outputs.push_back(rest_path);
  }
  const double write_ms = ms_since(t_write) - fracture_ms;

  const Material& mat = scase->material;
  const Index maxu = results.max_displacement_node;
  const Index maxs = results.max_principal_tet;
  const Index maxvm = results.max_von_mises_tet;
  const double strength_ratio = results.max_principal_stress / mat.tensile_strength;
  Vec3 gravity_load = Vec3::Zero();
  if (problem.gravity)
    for (double m : model.node_mass) gravity_load += m * problem.gravity_vector;

  if (args.json) {
    nlohmann::ordered_json j;
    j["case"] = args.case_path;
    j["name"] = scase->name;
    j["mesh"] = {{"file", args.mesh_path}, {"format", read->format}, {"nodes", mesh.num_nodes()},
                 {"tets", mesh.num_tets()}};
    j["material"] = {{"name", mat.name},
                     {"youngs_modulus", mat.youngs_modulus},
                     {"poisson_ratio", mat.poisson_ratio},
                     {"density", mat.density},
                     {"tensile_strength", std::isfinite(mat.tensile_strength) ? nlohmann::ordered_json(mat.tensile_strength)
                                                                              : nlohmann::ordered_json(nullptr)}};
    j["model"] = to_string(scase->model);
    j["held_nodes"] = resolved->num_held_nodes;
    j["total_load"] = {resolved->total_load.x(), resolved->total_load.y(), resolved->total_load.z()};
    j["gravity_load"] = {gravity_load.x(), gravity_load.y(), gravity_load.z()};
    j["solver"] = {{"converged", report->converged},
                   {"newton_iterations", report->newton_iterations},
                   {"load_steps", report->load_steps},
                   {"relative_residual", report->relative_residual},
                   {"linear_solver", to_string(options.linear.kind)},
                   {"linear_iterations", report->linear_iterations_total}};
    const Vec3& u = results.displacement[maxu];
    j["max_displacement"] = {{"value", results.max_displacement}, {"node_id", mesh.node_id(maxu)},
                             {"vector", {u.x(), u.y(), u.z()}}};
    const Vec3& d = results.max_direction[maxs];
    j["max_principal_stress"] = {{"value", results.max_principal_stress}, {"element_id", mesh.tet_id(maxs)},
                                 {"direction", {d.x(), d.y(), d.z()}}};
    j["max_von_mises"] = {{"value", results.max_von_mises}, {"element_id", mesh.tet_id(maxvm)}};
    j["would_crack"] = results.max_principal_stress > mat.tensile_strength;
    j["time_ms"] = {{"read", read_ms},          {"setup", setup_ms},
                    {"solve", report->total_ms}, {"assembly", report->assembly_ms},
                    {"linear_solve", report->linear_solve_ms}, {"forces", report->force_ms},
                    {"fracture", fracture_ms}, {"write", write_ms}};
    if (args.fracture) {
      nlohmann::ordered_json jf;
      jf["broken"] = frac.fragments.size() > 1;
      nlohmann::ordered_json frags = nlohmann::ordered_json::array();
      for (std::size_t k = 0; k < frac.fragments.size(); ++k) {
        const Fragment& f = frac.fragments[k];
        frags.push_back({{"index", k},
                         {"tets", f.mesh.num_tets()},
                         {"nodes", f.mesh.num_nodes()},
                         {"volume", f.mass.volume},
                         {"mass", f.mass.mass},
                         {"center_of_mass", {f.mass.center.x(), f.mass.center.y(), f.mass.center.z()}},
                         {"file", fragment_paths[k]}});
      }
      jf["fragments"] = std::move(frags);
      nlohmann::ordered_json cracks = nlohmann::ordered_json::array();
      for (const CrackEvent& ev : frac.events) {
        const CrackPlan& p = ev.plan;
        cracks.push_back({{"origin_element_id", mesh.tet_id(p.origin_tet)},
                          {"point", {p.origin.x(), p.origin.y(), p.origin.z()}},
                          {"normal", {p.normal.x(), p.normal.y(), p.normal.z()}},
                          {"radius", p.radius},
                          {"stress", p.stress},
                          {"ductile", p.ductile},
                          {"tets_marked", ev.tets_marked},
                          {"tets_split", ev.tets_split},
                          {"nodes_duplicated", ev.nodes_duplicated},
                          {"faces_cut", ev.faces_cut}});
      }
      jf["cracks"] = std::move(cracks);
      if (plastic)
        jf["plasticity"] = {{"yield_stress", mat.yield_stress},
                            {"yielded_tets", frac.plastic.yielded.size()},
                            {"max_plastic_strain", max_plastic_strain(frac)},
                            {"rest_shape", rest_path}};
      j["fracture"] = std::move(jf);
    }
    j["outputs"] = outputs;
    std::printf("%s\n", j.dump(2).c_str());
    return kExitOk;
  }

  std::string s;
  s += fmt::format("case        {} ({})\n", scase->name, args.case_path);
  s += fmt::format("mesh        {} ({}): {} nodes, {} tets\n", args.mesh_path, read->format, mesh.num_nodes(),
                   mesh.num_tets());
  s += fmt::format("material    {}: E = {:.4g} Pa, nu = {:.4g}, density = {:.4g} kg/m^3, tensile strength = {:.4g} Pa\n",
                   mat.name, mat.youngs_modulus, mat.poisson_ratio, mat.density, mat.tensile_strength);
  s += fmt::format("model       {}\n", to_string(scase->model));
  s += fmt::format("anchors     {} nodes held\n", resolved->num_held_nodes);
  s += fmt::format("loads       {} N nodal", vec_text(resolved->total_load));
  if (problem.gravity) s += fmt::format(", {} N gravity", vec_text(gravity_load));
  s += "\n";
  s += fmt::format("solver      converged: {} Newton iteration(s), {} load step(s), relative residual {:.3g} ({})\n",
                   report->newton_iterations, report->load_steps, report->relative_residual,
                   to_string(options.linear.kind));
  s += fmt::format("max |u|     {:.6g} m at node {} (u = {} m)\n", results.max_displacement, mesh.node_id(maxu),
                   vec_text(results.displacement[maxu]));
  s += fmt::format("max sigma1  {:.6g} Pa in element {} (direction {})\n", results.max_principal_stress,
                   mesh.tet_id(maxs), vec_text(results.max_direction[maxs]));
  if (std::isfinite(mat.tensile_strength))
    s += fmt::format("            {:.3g} x the tensile strength: {}\n", strength_ratio,
                     strength_ratio > 1 ? "it would crack there" : "no crack");
  s += fmt::format("max vM      {:.6g} Pa in element {}\n", results.max_von_mises, mesh.tet_id(maxvm));
  if (args.fracture) {
    if (frac.events.empty())
      s += "fracture    nothing breaks: no crack, 1 fragment\n";
    else
      s += fmt::format("fracture    {} crack(s), {} fragment(s)\n", frac.events.size(), frac.fragments.size());
    for (std::size_t k = 0; k < frac.events.size(); ++k) {
      const CrackEvent& ev = frac.events[k];
      const CrackPlan& p = ev.plan;
      s += fmt::format("  crack {}   {}from element {} at {} m, normal {}, radius {:.4g} m, sigma1 {:.4g} Pa: "
                       "{} tets marked, {} split, {} nodes duplicated\n",
                       k, p.ductile ? "(ductile) " : "", mesh.tet_id(p.origin_tet), vec_text(p.origin),
                       vec_text(p.normal), p.radius, p.stress, ev.tets_marked, ev.tets_split, ev.nodes_duplicated);
    }
    for (std::size_t k = 0; k < frac.fragments.size(); ++k) {
      const Fragment& f = frac.fragments[k];
      s += fmt::format("  fragment {} {} tets, volume {:.6g} m^3, mass {:.6g} kg, centre of mass {} m\n", k,
                       f.mesh.num_tets(), f.mass.volume, f.mass.mass, vec_text(f.mass.center));
    }
    if (plastic) {
      if (frac.plastic.yielded.empty())
        s += fmt::format("plasticity  no tet over the yield stress ({:.4g} Pa): the rest shape is unchanged\n",
                         mat.yield_stress);
      else
        s += fmt::format("plasticity  {} tet(s) yielded (von Mises over {:.4g} Pa), max plastic strain {:.4g}; "
                         "new rest shape in {}\n",
                         frac.plastic.yielded.size(), mat.yield_stress, max_plastic_strain(frac), rest_path);
    }
  } else if (scase->fracture_given) {
    s += "fracture    the case's \"fracture\" section is used with --fracture\n";
  }
  s += fmt::format("time        read {:.1f} ms, setup {:.1f} ms, solve {:.1f} ms (assembly {:.1f}, linear {:.1f}, "
                   "forces {:.1f}), {}write {:.1f} ms\n",
                   read_ms, setup_ms, report->total_ms, report->assembly_ms, report->linear_solve_ms,
                   report->force_ms, args.fracture ? fmt::format("fracture {:.1f} ms, ", fracture_ms) : "", write_ms);
  s += "output      ";
  for (std::size_t k = 0; k < outputs.size(); ++k) s += (k ? ", " : "") + outputs[k];
  s += "\n";
  std::fputs(s.c_str(), stdout);
  return kExitOk;
}

RunFn setup_static(CLI::App& sub) {
  auto args = std::make_shared<StaticArgs>();
  sub.add_option("mesh", args->mesh_path, "Tetrahedral mesh (.msh .vtk .vtu .mesh .inp .node/.ele)")->required();
  sub.add_option("--case", args->case_path, "Load case (JSON, docs/static_case.md)")->required();
  sub.add_option("--out", args->out_dir, "Output folder (default: <case name>_out)");
  sub.add_flag("--json", args->json, "Print the summary as JSON");
  sub.add_flag("--fracture", args->fracture,
               "Then crack and yield the solved body: fragments, cracks, plastic rest shape (docs/static_case.md)");
  sub.add_option("--fragment-format", args->fragment_format, "Format of the fragment_<k> meshes (default vtu)")
      ->check(CLI::IsMember({"vtu", "vtk", "msh", "mesh", "inp", "node"}));
  return [args] { return run_static(*args); };
}

const Registration reg{"static", "Static analysis of a mesh under anchors and loads", &setup_static};

}  // namespace
}  // namespace shatter::cli
