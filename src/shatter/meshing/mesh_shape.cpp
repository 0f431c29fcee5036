// Mesher choice and reference volume (see mesh_shape.h).
#include "shatter/meshing/mesh_shape.h"

#include <algorithm>
#include <cstdint>

#include "shatter/mesh/quality.h"

namespace shatter {

const char* to_string(MeshMethod method) {
  switch (method) {
    case MeshMethod::automatic: return "auto";
    case MeshMethod::stuffing: return "stuffing";
    case MeshMethod::structured: return "structured";
    case MeshMethod::box_csg: return "box-csg";
    case MeshMethod::revolve: return "revolve";
  }
  return "?";
}

Result<MeshMethod> parse_mesh_method(std::string_view name) {
  for (MeshMethod m :
       {MeshMethod::automatic, MeshMethod::stuffing, MeshMethod::structured, MeshMethod::box_csg, MeshMethod::revolve})
    if (name == to_string(m)) return m;
  return make_error("expected auto, stuffing, structured, box-csg or revolve, got \"" + std::string(name) + "\"");
}

Result<MeshShapeResult> mesh_shape(const Sdf& sdf, const MeshShapeDef& def, const std::string& name) {
  if (def.segments < 0 || (def.segments > 0 && def.segments < 3)) return field_error("segments", "expected at least 3");
  const bool is_box = box_csg_boxes(sdf).has_value();
  const bool is_revolve = revolved_shape(sdf).has_value();
  const MeshMethod m = def.method;
  MeshShapeResult out;
  switch (m) {
    case MeshMethod::automatic:
      out.method = is_box ? MeshMethod::box_csg : is_revolve ? MeshMethod::revolve : MeshMethod::stuffing;
      break;
    case MeshMethod::stuffing: out.method = MeshMethod::stuffing; break;
    case MeshMethod::box_csg:
    case MeshMethod::revolve:
    case MeshMethod::structured: {
      const bool ok = m == MeshMethod::box_csg   ? is_box
                      : m == MeshMethod::revolve ? is_revolve
                                                 : (is_box || is_revolve);
      if (!ok)
        return make_error((name.empty() ? std::string("shape") : name) + ": method " + std::string(to_string(m)) +
                          ": the shape is not " +
                          (m == MeshMethod::box_csg   ? "made of axis-aligned boxes (union, difference, intersection)"
                           : m == MeshMethod::revolve ? "a single revolution"
                                                      : "a box CSG or a single revolution"));
      out.method = m == MeshMethod::structured ? (is_box ? MeshMethod::box_csg : MeshMethod::revolve) : m;
      break;
    }
  }

  const StuffingDef& s = def.stuffing;
  Result<TetMesh> mesh = make_error("no mesh");
  if (out.method == MeshMethod::box_csg) {
    mesh = mesh_box_csg(sdf, {.edge_length = s.edge_length, .target_tets = s.target_tets}, &out.box_csg);
    out.stuffing.edge_length = out.box_csg.edge_length;
    out.exact_volume = out.box_csg.exact_volume;
  } else if (out.method == MeshMethod::revolve) {
    mesh = mesh_revolution(sdf, {.edge_length = s.edge_length, .target_tets = s.target_tets, .segments = def.segments},
                           &out.revolve);
    out.stuffing.edge_length = out.revolve.edge_length;
    out.exact_volume = out.revolve.exact_volume;
  } else {
    mesh = stuff_tets(sdf, s, &out.stuffing);
  }
  if (!mesh) return std::move(mesh.error());
  out.mesh = std::move(*mesh);
  out.edge_length = out.stuffing.edge_length;
  return out;
}

namespace {
// The extrapolated reference is skipped when its lattice would exceed both this many points and
// this many per tet of the mesh (a filled shape has about 3 to 16 per tet at h/2).
constexpr std::int64_t kReferenceLatticeFloor = 2'000'000;
constexpr std::int64_t kReferenceLatticePerTet = 100;
}  // namespace

std::optional<ReferenceVolume> reference_volume(const Sdf& sdf, const MeshShapeDef& def, const MeshShapeResult& result,
                                                double mesh_volume, bool extrapolate, Index max_tets) {
  if (const std::optional<double> v = sdf.analytic_volume()) return ReferenceVolume{*v, "analytic"};
  if (result.exact_volume) return ReferenceVolume{*result.exact_volume, "exact"};
  if (!extrapolate || result.mesh.num_tets() > max_tets) return std::nullopt;
  // The lattice at h/2 has eight times the points. Where the mesh fills little of its lattice (a
  // shape far thinner than its bounds, such as a surface with one stray vertex) that costs far
  // more than the mesh did: skip it rather than spend seconds and gigabytes on a report.
  const std::int64_t fine_lattice = 8 * result.stuffing.lattice_vertices;
  if (fine_lattice > std::max<std::int64_t>(kReferenceLatticeFloor, kReferenceLatticePerTet * result.mesh.num_tets()))
    return std::nullopt;
  // Stuffing at h/2 (grading does not change the volume, so the finer mesh is left uniform).
  auto fine = stuff_tets(sdf, {.edge_length = 0.5 * result.edge_length, .sharpen = def.stuffing.sharpen});
  if (!fine) return std::nullopt;
  const double vf = total_volume(*fine);
  return ReferenceVolume{vf + (vf - mesh_volume) / 3.0, "extrapolated from h/2"};
}

}  // namespace shatter
