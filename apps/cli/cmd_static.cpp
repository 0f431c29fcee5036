// `shatter static MESH --case CASE.json [--out DIR] [--json] [--fracture]`: static analysis of a mesh
// under the anchors and loads of a case file; writes displacements, element stresses and a VTU, and
// with --fracture the fragments, cracks and plastic rest shape of the solution; prints a summary
// (docs/static_case.md).
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "command.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/scene/static_analysis.h"
#include "shatter/scene/static_fracture.h"

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
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

std::string vec_text(const Vec3& v) { return fmt::format("[{:.6g}, {:.6g}, {:.6g}]", v.x(), v.y(), v.z()); }

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

  // Solve (and crack).
  auto analysis = run_static_analysis(*scase, mesh, {.fracture = args.fracture});
  if (!analysis) return report_error(analysis.error().to_string(), kExitBadInput);
  for (const std::string& w : analysis->resolved.warnings) std::fprintf(stderr, "shatter: warning: %s\n", w.c_str());
  const StaticReport& report = analysis->report;
  if (!report.converged)
    return report_error(
        fmt::format("the static solver did not converge: {} (Newton iterations {}, relative "
                    "residual {:.3g}, load fraction {:.3g}); no output written",
                    report.message, report.newton_iterations, report.relative_residual, report.load_fraction),
        kExitFailure);

  // Files.
  const auto t_write = Clock::now();
  const std::string out_dir = args.out_dir.empty() ? scase->name + "_out" : args.out_dir;
  auto written = write_static_outputs(out_dir, mesh, *analysis, args.fragment_format);
  if (!written) return report_error(written.error().to_string(), kExitOutput);
  const double write_ms = ms_since(t_write);
  const std::vector<std::string> outputs = written->all();
  const std::vector<std::string>& fragment_paths = written->fragments;
  const std::string& rest_path = written->rest_shape;

  const double setup_ms = analysis->setup_ms;
  const double fracture_ms = analysis->fracture_ms;
  const ResolvedStaticCase& resolved = analysis->resolved;
  const StaticProblem& problem = analysis->problem;
  const StaticSolverOptions& options = analysis->solver_options;
  const StaticResults& results = analysis->results;
  const FractureResult* frac = analysis->fracture ? &*analysis->fracture : nullptr;  // with --fracture
  const bool plastic = std::isfinite(scase->material.yield_stress);
  const Material& mat = scase->material;
  const Index maxu = results.max_displacement_node;
  const Index maxs = results.max_principal_tet;
  const Index maxvm = results.max_von_mises_tet;
  const double strength_ratio = results.max_principal_stress / mat.tensile_strength;
  const Vec3& gravity_load = analysis->gravity_load;

  if (args.json) {
    nlohmann::ordered_json j;
    j["case"] = args.case_path;
    j["name"] = scase->name;
    j["mesh"] = {
        {"file", args.mesh_path}, {"format", read->format}, {"nodes", mesh.num_nodes()}, {"tets", mesh.num_tets()}};
    j["material"] = {
        {"name", mat.name},
        {"youngs_modulus", mat.youngs_modulus},
        {"poisson_ratio", mat.poisson_ratio},
        {"density", mat.density},
        {"tensile_strength", std::isfinite(mat.tensile_strength) ? nlohmann::ordered_json(mat.tensile_strength)
                                                                 : nlohmann::ordered_json(nullptr)}};
    j["model"] = to_string(scase->model);
    j["held_nodes"] = resolved.num_held_nodes;
    j["total_load"] = {resolved.total_load.x(), resolved.total_load.y(), resolved.total_load.z()};
    j["gravity_load"] = {gravity_load.x(), gravity_load.y(), gravity_load.z()};
    j["solver"] = {{"converged", report.converged},
                   {"newton_iterations", report.newton_iterations},
                   {"load_steps", report.load_steps},
                   {"relative_residual", report.relative_residual},
                   {"linear_solver", to_string(options.linear.kind)},
                   {"linear_iterations", report.linear_iterations_total},
                   {"tangent", to_string(options.tangent)},
                   {"projected_iterations", report.projected_iterations},
                   {"direct_iterations", report.direct_iterations}};
    // One entry per Newton iteration (then the final residual): load fraction, relative residual
    // before the step, accepted step length, projected stiffness, PCG iterations.
    nlohmann::ordered_json history = nlohmann::ordered_json::array();
    for (const NewtonIteration& it : report.history)
      history.push_back({{"load_fraction", it.load_fraction},
                         {"relative_residual", it.relative_residual},
                         {"step_length", it.step_length},
                         {"projected", it.projected},
                         {"direct", it.direct},
                         {"linear_iterations", it.linear_iterations}});
    j["solver"]["history"] = std::move(history);
    const Vec3& u = results.displacement[maxu];
    j["max_displacement"] = {
        {"value", results.max_displacement}, {"node_id", mesh.node_id(maxu)}, {"vector", {u.x(), u.y(), u.z()}}};
    const Vec3& d = results.max_direction[maxs];
    j["max_principal_stress"] = {{"value", results.max_principal_stress},
                                 {"element_id", mesh.tet_id(maxs)},
                                 {"direction", {d.x(), d.y(), d.z()}}};
    j["max_von_mises"] = {{"value", results.max_von_mises}, {"element_id", mesh.tet_id(maxvm)}};
    j["would_crack"] = results.max_principal_stress > mat.tensile_strength;
    j["time_ms"] = {{"read", read_ms},
                    {"setup", setup_ms},
                    {"solve", report.total_ms},
                    {"assembly", report.assembly_ms},
                    {"linear_solve", report.linear_solve_ms},
                    {"forces", report.force_ms},
                    {"fracture", fracture_ms},
                    {"write", write_ms}};
    if (frac) {
      nlohmann::ordered_json jf;
      jf["broken"] = frac->fragments.size() > 1;
      nlohmann::ordered_json frags = nlohmann::ordered_json::array();
      for (std::size_t k = 0; k < frac->fragments.size(); ++k) {
        const Fragment& f = frac->fragments[k];
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
      for (const CrackEvent& ev : frac->events) {
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
                            {"yielded_tets", frac->plastic.yielded.size()},
                            {"max_plastic_strain", max_plastic_strain(*frac)},
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
  s +=
      fmt::format("material    {}: E = {:.4g} Pa, nu = {:.4g}, density = {:.4g} kg/m^3, tensile strength = {:.4g} Pa\n",
                  mat.name, mat.youngs_modulus, mat.poisson_ratio, mat.density, mat.tensile_strength);
  s += fmt::format("model       {}\n", to_string(scase->model));
  s += fmt::format("anchors     {} nodes held\n", resolved.num_held_nodes);
  s += fmt::format("loads       {} N nodal", vec_text(resolved.total_load));
  if (problem.gravity) s += fmt::format(", {} N gravity", vec_text(gravity_load));
  s += "\n";
  std::string linear = to_string(options.linear.kind);
  if (report.direct_iterations > 0 && options.linear.kind != LinearSolverKind::direct_ldlt)
    linear += fmt::format(", direct for {} where cheaper", report.direct_iterations);
  if (report.projected_iterations > 0) linear += fmt::format("; {} projected", report.projected_iterations);
  s += fmt::format("solver      converged: {} Newton iteration(s), {} load step(s), relative residual {:.3g} ({})\n",
                   report.newton_iterations, report.load_steps, report.relative_residual, linear);
  s += fmt::format("max |u|     {:.6g} m at node {} (u = {} m)\n", results.max_displacement, mesh.node_id(maxu),
                   vec_text(results.displacement[maxu]));
  s += fmt::format("max sigma1  {:.6g} Pa in element {} (direction {})\n", results.max_principal_stress,
                   mesh.tet_id(maxs), vec_text(results.max_direction[maxs]));
  if (std::isfinite(mat.tensile_strength))
    s += fmt::format("            {:.3g} x the tensile strength: {}\n", strength_ratio,
                     strength_ratio > 1 ? "it would crack there" : "no crack");
  s += fmt::format("max vM      {:.6g} Pa in element {}\n", results.max_von_mises, mesh.tet_id(maxvm));
  if (frac) {
    // The fragment count is the result's own: a mesh of separate pieces has several without a crack.
    if (frac->events.empty())
      s += fmt::format("fracture    nothing breaks: no crack, {} fragment(s)\n", frac->fragments.size());
    else
      s += fmt::format("fracture    {} crack(s), {} fragment(s)\n", frac->events.size(), frac->fragments.size());
    for (std::size_t k = 0; k < frac->events.size(); ++k) {
      const CrackEvent& ev = frac->events[k];
      const CrackPlan& p = ev.plan;
      s += fmt::format(
          "  crack {}   {}from element {} at {} m, normal {}, radius {:.4g} m, sigma1 {:.4g} Pa: "
          "{} tets marked, {} split, {} nodes duplicated\n",
          k, p.ductile ? "(ductile) " : "", mesh.tet_id(p.origin_tet), vec_text(p.origin), vec_text(p.normal), p.radius,
          p.stress, ev.tets_marked, ev.tets_split, ev.nodes_duplicated);
    }
    for (std::size_t k = 0; k < frac->fragments.size(); ++k) {
      const Fragment& f = frac->fragments[k];
      s += fmt::format("  fragment {} {} tets, volume {:.6g} m^3, mass {:.6g} kg, centre of mass {} m\n", k,
                       f.mesh.num_tets(), f.mass.volume, f.mass.mass, vec_text(f.mass.center));
    }
    if (plastic) {
      if (frac->plastic.yielded.empty())
        s += fmt::format("plasticity  no tet over the yield stress ({:.4g} Pa): the rest shape is unchanged\n",
                         mat.yield_stress);
      else
        s += fmt::format(
            "plasticity  {} tet(s) yielded (von Mises over {:.4g} Pa), max plastic strain {:.4g}; "
            "new rest shape in {}\n",
            frac->plastic.yielded.size(), mat.yield_stress, max_plastic_strain(*frac), rest_path);
    }
  } else if (scase->fracture_given) {
    s += "fracture    the case's \"fracture\" section is used with --fracture\n";
  }
  s += fmt::format(
      "time        read {:.1f} ms, setup {:.1f} ms, solve {:.1f} ms (assembly {:.1f}, linear {:.1f}, "
      "forces {:.1f}), {}write {:.1f} ms\n",
      read_ms, setup_ms, report.total_ms, report.assembly_ms, report.linear_solve_ms, report.force_ms,
      args.fracture ? fmt::format("fracture {:.1f} ms, ", fracture_ms) : "", write_ms);
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

const Registration static_command{"static", "Static analysis of a mesh under anchors and loads", &setup_static};

}  // namespace
}  // namespace shatter::cli
