// Structured tetrahedral meshes of surfaces of revolution (a closed (r, y) profile revolved about
// Y), suited to thin walls: the profile is resampled to the edge length and triangulated (ear
// clipping, best ear first, then Lawson flips to the constrained Delaunay triangulation of the
// resampled polygon; no interior points, so it is meant for profiles a few edge lengths thick at
// most), then swept about Y in N equal angular segments. Each triangle times segment is a prism
// cut into 3 tets: every quadrilateral face is split through its lowest-numbered vertex and the
// prism's lowest vertex is joined to the rest (Dompierre et al. 1999), so neighbouring prisms
// always conform. Profile vertices on the axis (r = 0) are one node shared by all segments, which
// turns the prisms touching the axis into a pyramid (2 tets) or a tet; axis nodes are numbered
// first so they are always the lowest vertex of their prism.
//
// Angular levels: a second sweep gives each profile point N / 2^k segments, k growing toward the
// axis so the spacing around it stays near the edge length (levels of neighbouring points differ
// by at most one). A triangle whose points are at two levels is swept two fine steps at a time; the
// polytope between its end triangles is filled by joining its faces (split by a rule of each face
// alone, so neighbours conform) to the vertex, or to a new node at the centre of its middle
// cross-section, that gives the best worst tet. The sweep with the larger smallest dihedral angle
// is returned; when some two-level polytope has no filling with positive tets, the plain sweep is.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/meshing/sdf.h"

namespace shatter {

/// A revolution profile and the transform placing it.
struct RevolvedShape {
  std::vector<Vec2> profile;  ///< closed (r, y) polygon, m
  Sdf::Transform transform;   ///< the transforms above the revolution node, composed
};
/// The revolution of `sdf` (a `revolution` node, possibly under transforms), or nullopt for any
/// other tree.
std::optional<RevolvedShape> revolved_shape(const Sdf& sdf);

/// Most angular segments of a sweep (given or derived from the edge length).
inline constexpr int kMaxRevolveSegments = 100'000;

/// Size settings of the revolve mesher. Sizes beyond the limits are refused before anything is
/// allocated (resampled profile points, segments, and their product as a tet estimate).
struct RevolveDef {
  /// Profile spacing and circumferential spacing at the largest radius, m. If 0, chosen to get
  /// about `target_tets`.
  double edge_length = 0.0;
  std::int64_t target_tets = 0;  ///< wanted tet count when edge_length == 0
  /// Angular segments; 0: max(min_segments, round(2 pi r_max / edge_length)).
  int segments = 0;
  int min_segments = 6;  ///< fewest segments of any sweep or angular level (>= 3)
  /// Most points of the resampled profile (its triangulation takes time quadratic in them).
  std::int64_t max_profile_points = 20'000;
  /// Most tets (3 per profile triangle and segment); also the largest target_tets.
  std::int64_t max_tets = 20'000'000;
};

/// What the revolve mesher did.
struct RevolveReport {
  double edge_length = 0;           ///< m
  int segments = 0;                 ///< angular segments N (at the largest radius)
  int levels = 0;                   ///< angular levels used: down to N / 2^levels near the axis
  std::int64_t profile_points = 0;  ///< resampled profile vertices
  std::int64_t triangles = 0;       ///< profile triangles
  double exact_volume = 0;          ///< Pappus volume of the profile (after the transform), m^3
};

/// Triangulation of a simple closed polygon (either orientation) without new points: ear
/// clipping, then Lawson flips of interior edges to the constrained Delaunay triangulation.
/// Triangles counter-clockwise, as indices into `polygon`. Error if the polygon is not simple.
Result<std::vector<std::array<Index, 3>>> triangulate_polygon(const std::vector<Vec2>& polygon);

/// Mesh a revolution (revolved_shape(sdf) must succeed). Nodes: axis vertices, then N / 2^level per
/// off-axis profile vertex (N without levels), then any centre nodes of two-level polytopes; tets
/// positively oriented. Deterministic.
Result<TetMesh> mesh_revolution(const Sdf& sdf, const RevolveDef& def, RevolveReport* report = nullptr);

}  // namespace shatter
