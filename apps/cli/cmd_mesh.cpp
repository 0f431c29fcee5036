// `shatter mesh`: tetrahedral mesh of a primitive, a JSON shape or a closed surface (isosurface
// stuffing, or a structured mesher for box-CSG shapes and surfaces of revolution), written in any
// volume format, with a quality report on stdout.
#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "command.h"
#include "shatter/core/parallel.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/quality.h"
#include "shatter/mesh/topology.h"
#include "shatter/meshing/mesh_shape.h"
#include "shatter/meshing/shape_json.h"
#include "shatter/meshing/surface_sdf.h"

namespace shatter::cli {
namespace {

struct MeshArgs {
  std::string shape, primitive, surface, output;
  double radius = 0, height = 0, major_radius = 0, minor_radius = 0;
  std::vector<double> size, radii;
  double edge_length = 0;
  std::int64_t tets = 0;
  double refine = 1.0;
  std::optional<double> grading;  // unset: from the shape file, else 0
  bool binary = false, json = false, no_reference = false, no_sharpen = false;
  int threads = 0;
  std::string method = "auto";
  int segments = 0;
};

Result<TriSurface> load_surface(const std::string& path) {
  auto r = read_surface(path);
  if (!r) return std::move(r.error());
  return std::move(r->surface);
}

// The largest tet count and refinement factor the command line takes: the meshers refuse more
// than 20 million tets anyway, and these keep the product a whole number far from overflow.
constexpr std::int64_t kMaxTargetTets = 20'000'000;
constexpr double kMaxRefine = 1000;

Result<Sdf> primitive(const MeshArgs& a) {
  auto need = [](double v, const char* name) -> Result<void> {
    if (!(v > 0) || !std::isfinite(v)) return field_error(name, "expected a length > 0 m");
    return {};
  };
  auto vec = [](const std::vector<double>& v, const char* name) -> Result<Vec3> {
    if (v.size() != 3 || !(v[0] > 0 && v[1] > 0 && v[2] > 0)) return field_error(name, "expected 3 lengths > 0 m");
    return Vec3(v[0], v[1], v[2]);
  };
  const std::string& p = a.primitive;
  if (p == "sphere") {
    if (auto r = need(a.radius, "--radius"); !r) return r.error();
    return Sdf::sphere(a.radius);
  }
  if (p == "box") {
    SHATTER_TRY(s, vec(a.size, "--size"));
    return Sdf::box(0.5 * *s);
  }
  if (p == "ellipsoid") {
    SHATTER_TRY(s, vec(a.radii, "--radii"));
    return Sdf::ellipsoid(*s);
  }
  if (p == "cylinder" || p == "capsule" || p == "cone") {
    if (auto r = need(a.radius, "--radius"); !r) return r.error();
    if (auto r = need(a.height, "--height"); !r) return r.error();
    if (p == "cylinder") return Sdf::cylinder(a.radius, 0.5 * a.height);
    if (p == "capsule") return Sdf::capsule(a.radius, 0.5 * a.height);
    return Sdf::cone(a.radius, a.height);
  }
  if (p == "torus") {
    if (auto r = need(a.major_radius, "--major-radius"); !r) return r.error();
    if (auto r = need(a.minor_radius, "--minor-radius"); !r) return r.error();
    if (!(a.minor_radius < a.major_radius)) return field_error("--minor-radius", "expected < --major-radius");
    return Sdf::torus(a.major_radius, a.minor_radius);
  }
  return field_error("--primitive", "unknown primitive \"" + p +
                                        "\"; expected sphere, box, cylinder, capsule, cone, torus, ellipsoid");
}

int run_mesh(const MeshArgs& a) {
  const int sources = !a.shape.empty() + !a.primitive.empty() + !a.surface.empty();
  if (sources != 1) return report_error("give exactly one of --shape, --primitive, --surface", kExitUsage);
  // Bounded before it reaches the threading runtime, which sizes per-thread state by the count.
  if (a.threads < 0 || a.threads > kMaxThreads)
    return report_error("--threads: expected 1 to " + std::to_string(kMaxThreads) + " (0: all hardware threads), got " +
                            std::to_string(a.threads),
                        kExitUsage);
  if (a.threads > 0) set_num_threads(a.threads);
  // A bad output extension is a usage error found before the (possibly long) meshing.
  if (!a.output.empty() && mesh_format_from_path(a.output) == MeshFormat::unknown)
    return report_error(a.output + ": unknown output extension; expected .msh .vtu .vtk .mesh .inp .node .ele",
                        kExitUsage);

  // The shape.
  Sdf sdf;
  std::string name;
  StuffingDef def;
  if (!a.shape.empty()) {
    auto f = read_shape_json(a.shape, &load_surface);
    if (!f) return report_error(f.error().to_string(), kExitBadInput);
    sdf = f->sdf;
    name = f->name;
    def.edge_length = f->edge_length;
    def.target_tets = f->target_tets;
    def.grading = f->grading;
    def.sharpen = f->sharpen;
  } else if (!a.primitive.empty()) {
    auto s = primitive(a);  // its sizes come from the command line only: a usage error
    if (!s) return report_error(s.error().to_string(), kExitUsage);
    sdf = *s;
    name = a.primitive;
  } else {
    auto surf = load_surface(a.surface);
    if (!surf) return report_error(surf.error().to_string(), kExitBadInput);
    auto d = SurfaceDistance::create(*surf, a.surface);
    if (!d) return report_error(d.error().to_string(), kExitBadInput);
    sdf = Sdf::surface(*d);
    name = a.surface;
  }
  // Size: the command line overrides the shape file.
  if (a.edge_length < 0) return report_error("--edge-length: expected a length > 0 m", kExitUsage);
  if (a.tets < 0 || a.tets > kMaxTargetTets)
    return report_error("--tets: expected a count from 1 to " + std::to_string(kMaxTargetTets), kExitUsage);
  if (a.edge_length > 0 || a.tets > 0) {
    def.edge_length = a.edge_length;
    def.target_tets = a.edge_length > 0 ? 0 : a.tets;
  }
  if (!(def.edge_length > 0) && def.target_tets <= 0)
    return report_error("give --edge-length H (m) or --tets N", kExitUsage);
  if (a.grading) {
    if (!(*a.grading >= 0) || !std::isfinite(*a.grading))
      return report_error("--grading: expected a number >= 0", kExitUsage);
    def.grading = *a.grading;
  }
  if (a.no_sharpen) def.sharpen = false;
  if (!(a.refine > 0) || !(a.refine <= kMaxRefine))
    return report_error("--refine: expected a factor > 0 and at most " + format_number(kMaxRefine), kExitUsage);
  // About `refine` times as many tets: h / cbrt(refine), or the target count times refine.
  def.edge_length /= std::cbrt(a.refine);
  def.target_tets = static_cast<std::int64_t>(std::llround(static_cast<double>(def.target_tets) * a.refine));

  auto method = parse_mesh_method(a.method);
  if (!method) return report_error("--method: " + method.error().message, kExitUsage);
  if (a.segments < 0 || (a.segments > 0 && a.segments < 3) || a.segments > kMaxRevolveSegments)
    return report_error("--segments: expected 3 to " + std::to_string(kMaxRevolveSegments), kExitUsage);
  const MeshShapeDef shape_def{.stuffing = def, .method = *method, .segments = a.segments};

  const auto t0 = std::chrono::steady_clock::now();
  auto meshed = mesh_shape(sdf, shape_def, name);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!meshed) {
    // Errors of the meshers (sizes, profiles, methods) come after the file was read: name it.
    Error e = meshed.error();
    if (e.file.empty()) e.file = !a.shape.empty() ? a.shape : a.surface;
    // A size given on the command line is named as its option.
    if (e.field == "edge_length" && a.edge_length > 0) e.field = "--edge-length";
    if (e.field == "edge_length" && a.edge_length <= 0 && a.tets > 0) e.field = "--tets";
    return report_error(e.to_string(), kExitBadInput);
  }
  const TetMesh* mesh = &meshed->mesh;
  const std::string used = to_string(meshed->method);
  const StuffingReport& report = meshed->stuffing;
  const RevolveReport& rr = meshed->revolve;

  const QualitySummary q = mesh_quality(*mesh);
  const std::optional<ReferenceVolume> ref =
      reference_volume(sdf, shape_def, *meshed, q.volume, /*extrapolate=*/!a.no_reference);
  const TriSurface boundary = boundary_surface(*mesh);
  const Index components = connected_components(*mesh).count;

  if (!a.output.empty()) {
    MeshWriteOptions wo;
    wo.binary = a.binary;
    if (auto w = write_mesh(a.output, *mesh, wo); !w) return report_error(w.error().to_string(), kExitOutput);
  }

  if (a.json) {
    nlohmann::ordered_json j;
    j["shape"] = name;
    j["method"] = used;
    if (!a.output.empty()) j["output"] = a.output;
    j["edge_length"] = report.edge_length;
    j["nodes"] = mesh->num_nodes();
    j["tets"] = mesh->num_tets();
    j["boundary_triangles"] = boundary.triangles.size();
    j["components"] = components;
    j["dihedral_deg"] = {{"min", q.min_dihedral_deg}, {"max", q.max_dihedral_deg}};
    j["aspect_ratio"] = {{"min", q.min_aspect}, {"max", q.max_aspect}, {"mean", q.mean_aspect}};
    j["volume"] = q.volume;
    if (ref) {
      j["reference_volume"] = ref->volume;
      j["reference_kind"] = ref->kind;
      j["volume_error"] = (q.volume - ref->volume) / ref->volume;
    }
    if (used == "revolve") {
      j["segments"] = rr.segments;
      j["angular_levels"] = rr.levels;
    }
    j["lattice_vertices"] = report.lattice_vertices;
    j["warped"] = report.warped;
    if (used == "stuffing") j["sharpened"] = report.sharpened;
    if (used == "stuffing" && def.grading > 0) {
      j["grading"] = def.grading;
      j["tets_before_grading"] = report.tets_before_grading;
    }
    j["seconds"] = seconds;
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::string out;
    out += fmt::format("shape        {}\n", name);
    out += fmt::format("method       {}\n", used);
    out += fmt::format("edge length  {:.6g} m\n", report.edge_length);
    if (used == "revolve")
      out += fmt::format("segments     {} at the largest radius, {} angular level(s) below\n", rr.segments, rr.levels);
    out += fmt::format("nodes        {}\n", mesh->num_nodes());
    out += fmt::format("tets         {}\n", mesh->num_tets());
    if (used == "stuffing" && def.grading > 0)
      out += fmt::format("grading      {:g} ({} tets before)\n", def.grading, report.tets_before_grading);
    if (used == "stuffing" && def.sharpen)
      out += fmt::format("sharpened    {} boundary node moves onto creases and corners\n", report.sharpened);
    out += fmt::format("boundary     {} triangles, {} component(s)\n", boundary.triangles.size(), components);
    out += fmt::format("dihedral     {:.2f} .. {:.2f} deg\n", q.min_dihedral_deg, q.max_dihedral_deg);
    out += fmt::format("aspect       {:.3f} .. {:.3f} (mean {:.3f})\n", q.min_aspect, q.max_aspect, q.mean_aspect);
    out += fmt::format("volume       {:.9g} m^3\n", q.volume);
    if (ref)
      out += fmt::format("reference    {:.9g} m^3 ({}), error {:+.3f} %\n", ref->volume, ref->kind,
                         100.0 * (q.volume - ref->volume) / ref->volume);
    out += fmt::format("time         {:.3f} s\n", seconds);
    std::fputs(out.c_str(), stdout);
  }
  if (!a.output.empty()) std::fprintf(stderr, "shatter: wrote %s\n", a.output.c_str());
  return kExitOk;
}

RunFn setup_mesh(CLI::App& sub) {
  auto a = std::make_shared<MeshArgs>();
  sub.add_option("--shape", a->shape, "Shape description (JSON, docs/meshing.md)");
  sub.add_option("--primitive", a->primitive, "sphere, box, cylinder, capsule, cone, torus, ellipsoid");
  sub.add_option("--surface", a->surface, "Closed triangle surface (.obj .ply .stl)");
  sub.add_option("--radius", a->radius, "Primitive radius, m");
  sub.add_option("--height", a->height, "Primitive height (cylinder, capsule segment, cone), m");
  sub.add_option("--size", a->size, "Box size X Y Z, m")->expected(3);
  sub.add_option("--radii", a->radii, "Ellipsoid semi-axes X Y Z, m")->expected(3);
  sub.add_option("--major-radius", a->major_radius, "Torus ring radius, m");
  sub.add_option("--minor-radius", a->minor_radius, "Torus tube radius, m");
  sub.add_option("--edge-length,-H", a->edge_length, "Lattice spacing h, m");
  sub.add_option("--tets,-n", a->tets, "Target tet count (h searched)");
  sub.add_option("--grading", a->grading,
                 "Stuffing: coarsen the inside, edge length growing by this much per unit depth (0: uniform)");
  sub.add_flag("--no-sharpen", a->no_sharpen, "Stuffing: leave creases and corners rounded (no feature snapping)");
  sub.add_option("--refine", a->refine, "About this many times more tets than asked (assets at x10, x100)");
  sub.add_option("-o,--output", a->output, "Output mesh (.msh .vtu .vtk .mesh .inp .node)");
  sub.add_flag("--binary", a->binary, "Binary payload where the format has one");
  sub.add_flag("--json", a->json, "Print the report as JSON");
  sub.add_flag("--no-reference", a->no_reference, "Skip the reference-volume mesh for non-analytic shapes");
  sub.add_option("--method", a->method,
                 "auto (default: box-csg or revolve where the shape qualifies, else stuffing), stuffing, "
                 "structured, box-csg, revolve");
  sub.add_option("--segments", a->segments, "Angular segments for the revolve mesher (default from the edge length)");
  sub.add_option("--threads", a->threads, "Threads (default: all; output is identical for any count)");
  return [a] { return run_mesh(*a); };
}

const Registration mesh_command{"mesh", "Tetrahedral mesh of a primitive, JSON shape or closed surface", &setup_mesh};

}  // namespace
}  // namespace shatter::cli
