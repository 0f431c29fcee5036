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
#include "shatter/meshing/box_csg_mesher.h"
#include "shatter/meshing/revolve_mesher.h"
#include "shatter/meshing/shape_json.h"
#include "shatter/meshing/stuffing.h"
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

Result<Sdf> primitive(const MeshArgs& a) {
  auto need = [](double v, const char* name) -> Result<void> {
    if (!(v > 0) || !std::isfinite(v)) return field_error(name, "expected a length > 0 m");
    return {};
  };
  auto vec = [](const std::vector<double>& v, const char* name) -> Result<Vec3> {
    if (v.size() != 3 || !(v[0] > 0 && v[1] > 0 && v[2] > 0))
      return field_error(name, "expected 3 lengths > 0 m");
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
  if (a.threads > 0) set_num_threads(a.threads);

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
    auto s = primitive(a);
    if (!s) return report_error(s.error().to_string(), kExitBadInput);
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
  if (a.edge_length > 0 || a.tets > 0) {
    def.edge_length = a.edge_length;
    def.target_tets = a.edge_length > 0 ? 0 : a.tets;
  }
  if (!(def.edge_length > 0) && def.target_tets <= 0)
    return report_error("give --edge-length H (m) or --tets N", kExitUsage);
  if (a.grading) {
    if (!(*a.grading >= 0) || !std::isfinite(*a.grading)) return report_error("--grading: expected a number >= 0", kExitUsage);
    def.grading = *a.grading;
  }
  if (a.no_sharpen) def.sharpen = false;
  if (!(a.refine > 0) || !std::isfinite(a.refine))
    return report_error("--refine: expected a factor > 0", kExitUsage);
  // About `refine` times as many tets: h / cbrt(refine), or the target count times refine.
  def.edge_length /= std::cbrt(a.refine);
  def.target_tets = static_cast<std::int64_t>(std::llround(static_cast<double>(def.target_tets) * a.refine));

  // Method: structured meshers where the shape qualifies (auto), else isosurface stuffing.
  const std::string& m = a.method;
  if (m != "auto" && m != "stuffing" && m != "structured" && m != "box-csg" && m != "revolve")
    return report_error("--method: expected auto, stuffing, structured, box-csg or revolve, got \"" + m + "\"",
                        kExitUsage);
  if (a.segments < 0 || (a.segments > 0 && a.segments < 3))
    return report_error("--segments: expected at least 3", kExitUsage);
  const bool is_box = box_csg_boxes(sdf).has_value();
  const bool is_revolve = revolved_shape(sdf).has_value();
  std::string method = "stuffing";
  if (m == "box-csg" || m == "revolve" || m == "structured") {
    const bool ok = m == "box-csg" ? is_box : m == "revolve" ? is_revolve : (is_box || is_revolve);
    if (!ok)
      return report_error((name.empty() ? std::string("shape") : name) + ": --method " + m +
                              ": the shape is not " +
                              (m == "box-csg"   ? "made of axis-aligned boxes (union, difference, intersection)"
                               : m == "revolve" ? "a single revolution"
                                                : "a box CSG or a single revolution"),
                          kExitBadInput);
    method = m == "structured" ? (is_box ? "box-csg" : "revolve") : m;
  } else if (m == "auto") {
    method = is_box ? "box-csg" : is_revolve ? "revolve" : "stuffing";
  }

  const auto t0 = std::chrono::steady_clock::now();
  StuffingReport report;
  std::optional<double> exact;  // exact volume from a structured mesher
  RevolveReport rr;
  Result<TetMesh> mesh = make_error("no mesh");
  if (method == "box-csg") {
    BoxCsgReport br;
    mesh = mesh_box_csg(sdf, {.edge_length = def.edge_length, .target_tets = def.target_tets}, &br);
    report.edge_length = br.edge_length;
    exact = br.exact_volume;
  } else if (method == "revolve") {
    mesh = mesh_revolution(sdf, {.edge_length = def.edge_length, .target_tets = def.target_tets, .segments = a.segments},
                           &rr);
    report.edge_length = rr.edge_length;
    exact = rr.exact_volume;
  } else {
    mesh = stuff_tets(sdf, def, &report);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!mesh) return report_error(mesh.error().to_string(), kExitBadInput);

  // Reference volume: analytic, exact for box CSG, or Richardson extrapolation from a mesh at h/2
  // (volume error ~ h^2, observed in tests/meshing): V ~ V(h/2) + (V(h/2) - V(h)) / 3.
  const QualitySummary q = mesh_quality(*mesh);
  std::optional<double> reference = sdf.analytic_volume();
  std::string reference_kind = reference ? "analytic" : "";
  if (!reference && exact) {
    reference = exact;
    reference_kind = "exact";
  }
  if (!reference && !a.no_reference && mesh->num_tets() <= 500'000) {
    // Same method at h/2 (grading does not change the volume, so the finer mesh is left uniform).
    auto fine = stuff_tets(sdf, {.edge_length = 0.5 * report.edge_length, .sharpen = def.sharpen});
    if (fine) {
      const double vf = total_volume(*fine);
      reference = vf + (vf - q.volume) / 3.0;
      reference_kind = "extrapolated from h/2";
    }
  }
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
    j["method"] = method;
    if (!a.output.empty()) j["output"] = a.output;
    j["edge_length"] = report.edge_length;
    j["nodes"] = mesh->num_nodes();
    j["tets"] = mesh->num_tets();
    j["boundary_triangles"] = boundary.triangles.size();
    j["components"] = components;
    j["dihedral_deg"] = {{"min", q.min_dihedral_deg}, {"max", q.max_dihedral_deg}};
    j["aspect_ratio"] = {{"min", q.min_aspect}, {"max", q.max_aspect}, {"mean", q.mean_aspect}};
    j["volume"] = q.volume;
    if (reference) {
      j["reference_volume"] = *reference;
      j["reference_kind"] = reference_kind;
      j["volume_error"] = (q.volume - *reference) / *reference;
    }
    if (method == "revolve") {
      j["segments"] = rr.segments;
      j["angular_levels"] = rr.levels;
    }
    j["lattice_vertices"] = report.lattice_vertices;
    j["warped"] = report.warped;
    if (method == "stuffing") j["sharpened"] = report.sharpened;
    if (method == "stuffing" && def.grading > 0) {
      j["grading"] = def.grading;
      j["tets_before_grading"] = report.tets_before_grading;
    }
    j["seconds"] = seconds;
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::string out;
    out += fmt::format("shape        {}\n", name);
    out += fmt::format("method       {}\n", method);
    out += fmt::format("edge length  {:.6g} m\n", report.edge_length);
    if (method == "revolve")
      out += fmt::format("segments     {} at the largest radius, {} angular level(s) below\n", rr.segments, rr.levels);
    out += fmt::format("nodes        {}\n", mesh->num_nodes());
    out += fmt::format("tets         {}\n", mesh->num_tets());
    if (method == "stuffing" && def.grading > 0)
      out += fmt::format("grading      {:g} ({} tets before)\n", def.grading, report.tets_before_grading);
    if (method == "stuffing" && def.sharpen)
      out += fmt::format("sharpened    {} boundary node moves onto creases and corners\n", report.sharpened);
    out += fmt::format("boundary     {} triangles, {} component(s)\n", boundary.triangles.size(), components);
    out += fmt::format("dihedral     {:.2f} .. {:.2f} deg\n", q.min_dihedral_deg, q.max_dihedral_deg);
    out += fmt::format("aspect       {:.3f} .. {:.3f} (mean {:.3f})\n", q.min_aspect, q.max_aspect, q.mean_aspect);
    out += fmt::format("volume       {:.9g} m^3\n", q.volume);
    if (reference)
      out += fmt::format("reference    {:.9g} m^3 ({}), error {:+.3f} %\n", *reference, reference_kind,
                         100.0 * (q.volume - *reference) / *reference);
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

const Registration reg{"mesh", "Tetrahedral mesh of a primitive, JSON shape or closed surface",
                       &setup_mesh};

}  // namespace
}  // namespace shatter::cli
