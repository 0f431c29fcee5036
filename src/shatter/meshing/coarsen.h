// Grading: coarsen the inside of a tet mesh by edge collapse, leaving its boundary untouched.
//
// Isosurface stuffing makes tets of one size everywhere; a solid needs fine tets only near its
// surface, where the cracks and contacts are. coarsen_interior collapses short interior edges,
// shortest first, until edges are about as long as a sizing function asks (typically growing with
// depth below the surface). A collapse is made only when it keeps the mesh a valid triangulation
// of the same region (link condition, every changed tet positively oriented) and every changed tet
// inside the given dihedral-angle bounds, so a mesh inside the bounds stays inside them. After each
// pass the interior nodes the collapses touched move to the centre of their neighbours when that
// makes none of their tets worse (so more collapses pass the shape test next time). Boundary
// nodes never move or disappear: the boundary surface and the volume are unchanged.
// Sequential and ordered by (length, node ids): the result does not depend on the thread count.
#pragma once

#include <functional>

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter {

struct CoarsenDef {
  /// Wanted edge length at a point, m (> 0). Edges shorter than `collapse_ratio` times the mean of
  /// the sizes at their ends are collapsed when allowed.
  std::function<double(const Vec3&)> size;
  double collapse_ratio = 0.8;
  /// Every tet a collapse changes must have dihedral angles inside [min, max], degrees.
  double min_dihedral_deg = 0;
  double max_dihedral_deg = 180;
  int max_passes = 30;
};

struct CoarsenReport {
  Index collapses = 0;
  Index smoothed = 0;  ///< interior node moves to the centre of their neighbours
  int passes = 0;
  Index tets_before = 0, tets_after = 0;
};

/// Coarsen in place. Node order and tet order of what survives are kept; node ids, tags and sets of
/// the input are dropped (the meshers call this before assigning any).
Result<CoarsenReport> coarsen_interior(TetMesh& mesh, const CoarsenDef& def);

}  // namespace shatter
