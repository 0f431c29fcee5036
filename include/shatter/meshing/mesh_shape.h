// One entry point for meshing a shape: the choice between the structured meshers (box CSG,
// surfaces of revolution) and isosurface stuffing, and a reference volume to judge the mesh by
// (analytic, exact from a structured mesher, or extrapolated from a mesh at half the edge length).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/meshing/box_csg_mesher.h"
#include "shatter/meshing/revolve_mesher.h"
#include "shatter/meshing/sdf.h"
#include "shatter/meshing/stuffing.h"

namespace shatter {

/// How to mesh a shape. `automatic` takes a structured mesher where the shape qualifies (box CSG,
/// then a single revolution), else stuffing; `structured` is either structured mesher.
enum class MeshMethod { automatic, stuffing, structured, box_csg, revolve };

/// "auto", "stuffing", "structured", "box-csg", "revolve".
const char* to_string(MeshMethod method);
/// The inverse of to_string; an error listing the valid names otherwise.
Result<MeshMethod> parse_mesh_method(std::string_view name);

/// Settings of mesh_shape.
struct MeshShapeDef {
  /// Size (edge length or target tet count) for every method; grading, sharpening and the other
  /// stuffing settings for stuffing.
  StuffingDef stuffing;
  MeshMethod method = MeshMethod::automatic;  ///< which mesher to use
  /// Angular segments of the revolve mesher (0: from the edge length; otherwise >= 3).
  int segments = 0;
};

/// The mesh and what its mesher reported.
struct MeshShapeResult {
  TetMesh mesh;                              ///< the mesh, tets positively oriented
  MeshMethod method = MeshMethod::stuffing;  ///< the mesher used: stuffing, box_csg or revolve
  double edge_length = 0;                    ///< h used, m
  StuffingReport stuffing;                   ///< method stuffing (edge_length set for all)
  RevolveReport revolve;                     ///< method revolve
  BoxCsgReport box_csg;                      ///< method box_csg
  std::optional<double> exact_volume;        ///< the shape's volume from a structured mesher, m^3
};

/// Mesh `sdf` with the method `def` asks for. `name` names the shape in errors. Errors: a
/// structured method for a shape that does not qualify, a bad segment count, and the mesher's own.
Result<MeshShapeResult> mesh_shape(const Sdf& sdf, const MeshShapeDef& def, const std::string& name = "shape");

/// A volume to judge a mesh by, and where it came from.
struct ReferenceVolume {
  double volume = 0;  ///< m^3
  std::string kind;   ///< "analytic", "exact" or "extrapolated from h/2"
};

/// The volume to compare the mesh's with: the shape's analytic volume, else the structured
/// mesher's exact one, else (when `extrapolate`, the mesh has at most `max_tets` tets and the finer
/// lattice is not wasted on a shape far thinner than its bounds) a
/// Richardson extrapolation from a stuffed mesh at h/2 (volume error ~ h^2, observed in
/// tests/meshing): V ~ V(h/2) + (V(h/2) - V(h)) / 3. `mesh_volume`: the mesh's volume, m^3.
std::optional<ReferenceVolume> reference_volume(const Sdf& sdf, const MeshShapeDef& def, const MeshShapeResult& result,
                                                double mesh_volume, bool extrapolate = true, Index max_tets = 500'000);

}  // namespace shatter
