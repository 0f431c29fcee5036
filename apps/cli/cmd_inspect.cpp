// `shatter inspect MESH`: counts, bounds, volume, quality, components and every problem found.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

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

// Quality measured on a copy moved to the origin and scaled to unit size, volumes scaled back:
// angles and aspect ratios do not depend on the scale, and the intermediate products no longer
// overflow for coordinates near +-1e308 or a mesh scaled by 1e100 (they gave "volume -nan").
// (p - c) / half is computed as (p/2 - c/2) / (half/2) so that no step can overflow.
QualitySummary unit_scale_quality(const TetMesh& mesh, const Aabb& box) {
  const Vec3 c = 0.5 * box.min + 0.5 * box.max;
  const double half = (0.5 * box.max - 0.5 * box.min).maxCoeff();
  if (!(half > 0) || !std::isfinite(half) || !c.allFinite()) return mesh_quality(mesh);
  TetMesh unit;
  unit.tets = mesh.tets;
  unit.positions.reserve(mesh.positions.size());
  for (const Vec3& p : mesh.positions) unit.positions.emplace_back((0.5 * p - 0.5 * c) / (0.5 * half));
  QualitySummary q = mesh_quality(unit);
  const double s3 = half * half * half;  // may be inf: then so is the volume, and the report says so
  q.volume *= s3;
  q.min_tet_volume *= s3;
  q.max_tet_volume *= s3;
  return q;
}

/// Numbers for the report: a value that is not finite is named, never printed as "nan".
struct Numbers {
  std::vector<std::string> non_finite;  ///< the names of the values that were not finite
  std::string text(const std::string& name, double v, int precision, char kind) {
    if (std::isfinite(v))
      return kind == 'f' ? fmt::format("{:.{}f}", v, precision) : fmt::format("{:.{}g}", v, precision);
    non_finite.push_back(name);
    return "not finite";
  }
  nlohmann::ordered_json json(const std::string& name, double v) {
    if (std::isfinite(v)) return v;
    non_finite.push_back(name);
    return nullptr;
  }
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
    q = unit_scale_quality(mesh, box);
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
    Numbers n;
    if (!box.empty()) {
      j["bounds"] = {
          {"min",
           {n.json("bounds.min", box.min.x()), n.json("bounds.min", box.min.y()), n.json("bounds.min", box.min.z())}},
          {"max",
           {n.json("bounds.max", box.max.x()), n.json("bounds.max", box.max.y()), n.json("bounds.max", box.max.z())}}};
    }
    if (indices_ok && mesh.num_tets() > 0) {
      j["volume"] = n.json("volume", q.volume);
      j["tet_volume"] = {{"min", n.json("tet_volume.min", q.min_tet_volume)},
                         {"max", n.json("tet_volume.max", q.max_tet_volume)}};
      j["dihedral_deg"] = {{"min", n.json("dihedral_deg.min", q.min_dihedral_deg)},
                           {"max", n.json("dihedral_deg.max", q.max_dihedral_deg)}};
      j["aspect_ratio"] = {{"min", n.json("aspect_ratio.min", q.min_aspect)},
                           {"max", n.json("aspect_ratio.max", q.max_aspect)},
                           {"mean", n.json("aspect_ratio.mean", q.mean_aspect)},
                           {"worst_tet", mesh.tet_id(q.worst_aspect_tet)}};
      j["components"] = components;
      j["boundary_triangles"] = boundary_triangles;
    }
    // Values a double cannot hold (null above), named rather than left as a bare null.
    if (!n.non_finite.empty()) j["non_finite"] = n.non_finite;
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
    Numbers n;
    if (!box.empty()) {
      out += fmt::format("bounds      [{}, {}, {}] .. [{}, {}, {}] m\n", n.text("bounds", box.min.x(), 6, 'g'),
                         n.text("bounds", box.min.y(), 6, 'g'), n.text("bounds", box.min.z(), 6, 'g'),
                         n.text("bounds", box.max.x(), 6, 'g'), n.text("bounds", box.max.y(), 6, 'g'),
                         n.text("bounds", box.max.z(), 6, 'g'));
      const Vec3 e = box.extent();
      out += fmt::format("size        {} x {} x {} m\n", n.text("size", e.x(), 6, 'g'), n.text("size", e.y(), 6, 'g'),
                         n.text("size", e.z(), 6, 'g'));
    }
    if (indices_ok && mesh.num_tets() > 0) {
      out +=
          fmt::format("volume      {} m^3 (tet volume {} .. {})\n", n.text("volume", q.volume, 9, 'g'),
                      n.text("tet volume", q.min_tet_volume, 4, 'g'), n.text("tet volume", q.max_tet_volume, 4, 'g'));
      out += fmt::format("dihedral    {} .. {} deg\n", n.text("dihedral", q.min_dihedral_deg, 2, 'f'),
                         n.text("dihedral", q.max_dihedral_deg, 2, 'f'));
      out += fmt::format("aspect      {} .. {} (mean {}; worst tet {})\n", n.text("aspect", q.min_aspect, 3, 'f'),
                         n.text("aspect", q.max_aspect, 3, 'f'), n.text("aspect", q.mean_aspect, 3, 'f'),
                         mesh.tet_id(q.worst_aspect_tet));
      out += fmt::format("components  {}\n", components);
      out += fmt::format("boundary    {} triangles\n", boundary_triangles);
    }
    if (!n.non_finite.empty()) {
      std::vector<std::string> names;  // each once, in order
      for (const std::string& name : n.non_finite)
        if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
      out += fmt::format("not finite  {}: too large for a double, or from a degenerate tet\n", fmt::join(names, ", "));
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

const Registration inspect_command{"inspect", "Describe a mesh: counts, bounds, volume, quality, components, problems",
                                   &setup_inspect};

}  // namespace
}  // namespace shatter::cli
