// `shatter inspect MESH`: counts, bounds, volume, quality, components and every problem found.
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <string>

#include "command.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/quality.h"
#include "shatter/mesh/topology.h"
#include "shatter/mesh/validate.h"

namespace shatter::cli {
namespace {

struct InspectArgs {
  std::string path;
  bool json = false;
};

int run_inspect(const InspectArgs& args) {
  auto read = read_mesh(args.path, ReadMeshOptions{.validate = false});
  if (!read) return report_error(read.error().to_string(), kExitBadInput);
  const TetMesh& mesh = read->mesh;
  const ValidationReport report = validate_mesh(mesh);
  const bool indices_ok =
      report.count(MeshProblemKind::index_out_of_range) == 0 && report.count(MeshProblemKind::attribute_size) == 0;
  const Aabb box = mesh.bounds();
  QualitySummary q;
  Index components = 0, boundary_triangles = 0;
  if (indices_ok) {
    q = mesh_quality(mesh);
    components = connected_components(mesh).count;
    boundary_triangles = static_cast<Index>(boundary_surface(mesh).triangles.size());
  }
  std::size_t errors = 0, warnings = 0;
  for (std::size_t k = 0; k < report.counts.size(); ++k) {
    const bool is_warning = k == static_cast<std::size_t>(MeshProblemKind::inverted_tet) ||
                            k == static_cast<std::size_t>(MeshProblemKind::unreferenced_node);
    (is_warning ? warnings : errors) += report.counts[k];
  }

  if (args.json) {
    nlohmann::ordered_json j;
    j["file"] = args.path;
    j["format"] = read->format;
    j["nodes"] = mesh.num_nodes();
    j["tets"] = mesh.num_tets();
    j["skipped"] = read->skipped;
    if (!box.empty()) {
      j["bounds"] = {{"min", {box.min.x(), box.min.y(), box.min.z()}},
                     {"max", {box.max.x(), box.max.y(), box.max.z()}}};
    }
    if (indices_ok && mesh.num_tets() > 0) {
      j["volume"] = q.volume;
      j["tet_volume"] = {{"min", q.min_tet_volume}, {"max", q.max_tet_volume}};
      j["dihedral_deg"] = {{"min", q.min_dihedral_deg}, {"max", q.max_dihedral_deg}};
      j["aspect_ratio"] = {{"min", q.min_aspect},
                           {"max", q.max_aspect},
                           {"mean", q.mean_aspect},
                           {"worst_tet", mesh.tet_id(q.worst_aspect_tet)}};
      j["components"] = components;
      j["boundary_triangles"] = boundary_triangles;
    }
    nlohmann::ordered_json counts = nlohmann::ordered_json::object();
    for (std::size_t k = 0; k < report.counts.size(); ++k)
      if (report.counts[k] > 0) counts[to_string(static_cast<MeshProblemKind>(k))] = report.counts[k];
    j["problem_counts"] = counts;
    nlohmann::ordered_json problems = nlohmann::ordered_json::array();
    for (const MeshProblem& p : report.problems)
      problems.push_back({{"kind", to_string(p.kind)},
                          {"severity", p.severity == Severity::error ? "error" : "warning"},
                          {"message", p.message}});
    j["problems"] = problems;
    j["valid"] = errors == 0;
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::string out;
    out += fmt::format("file        {}\n", args.path);
    out += fmt::format("format      {}\n", read->format);
    out += fmt::format("nodes       {}\n", mesh.num_nodes());
    out += fmt::format("tets        {}\n", mesh.num_tets());
    for (const std::string& s : read->skipped) out += fmt::format("skipped     {}\n", s);
    if (!box.empty()) {
      out += fmt::format("bounds      [{:.6g}, {:.6g}, {:.6g}] .. [{:.6g}, {:.6g}, {:.6g}] m\n", box.min.x(),
                         box.min.y(), box.min.z(), box.max.x(), box.max.y(), box.max.z());
      const Vec3 e = box.extent();
      out += fmt::format("size        {:.6g} x {:.6g} x {:.6g} m\n", e.x(), e.y(), e.z());
    }
    if (indices_ok && mesh.num_tets() > 0) {
      out += fmt::format("volume      {:.9g} m^3 (tet volume {:.4g} .. {:.4g})\n", q.volume, q.min_tet_volume,
                         q.max_tet_volume);
      out += fmt::format("dihedral    {:.2f} .. {:.2f} deg\n", q.min_dihedral_deg, q.max_dihedral_deg);
      out += fmt::format("aspect      {:.3f} .. {:.3f} (mean {:.3f}; worst tet {})\n", q.min_aspect, q.max_aspect,
                         q.mean_aspect, mesh.tet_id(q.worst_aspect_tet));
      out += fmt::format("components  {}\n", components);
      out += fmt::format("boundary    {} triangles\n", boundary_triangles);
    }
    out += fmt::format("problems    {} error(s), {} warning(s)\n", errors, warnings);
    for (const MeshProblem& p : report.problems)
      out += fmt::format("  {}: {}: {}\n", p.severity == Severity::error ? "error" : "warning", to_string(p.kind),
                         p.message);
    for (std::size_t k = 0; k < report.counts.size(); ++k) {
      std::size_t shown = 0;
      for (const MeshProblem& p : report.problems) shown += static_cast<std::size_t>(p.kind) == k;
      if (report.counts[k] > shown)
        out +=
            fmt::format("  ... and {} more {}\n", report.counts[k] - shown, to_string(static_cast<MeshProblemKind>(k)));
    }
    std::fputs(out.c_str(), stdout);
  }
  return errors == 0 ? kExitOk : kExitBadInput;
}

RunFn setup_inspect(CLI::App& sub) {
  auto args = std::make_shared<InspectArgs>();
  sub.add_option("MESH", args->path, "Mesh file (.msh .vtk .vtu .mesh .inp .node/.ele)")->required();
  sub.add_flag("--json", args->json, "Print the report as JSON");
  return [args] { return run_inspect(*args); };
}

const Registration reg{"inspect", "Describe a mesh: counts, bounds, volume, quality, components, problems",
                       &setup_inspect};

}  // namespace
}  // namespace shatter::cli
