// Sharp features for meshes of implicit shapes: boundary nodes moved onto the creases and corners
// of the shape, where a mesh whose boundary interpolates the zero set would round them off.
//
// Each boundary node gathers surface samples around it (its own position, and the centres and
// edge midpoints of its boundary triangles, projected onto the zero set) with the shape's normals
// there, and solves the quadric error function of dual contouring (Ju et al. 2002, "Dual
// Contouring of Hermite Data"): the point nearest the node that is closest to every sample's
// tangent plane, with the small eigenvalues of the normal matrix dropped, so on a flat or smoothly
// curved patch it stays where it is, on a crease it goes to the crease line and at a corner to the
// corner. The move is made when the samples' normals really disagree (a crease), the new point is on
// the surface and within half an edge length, and every tet around the node stays positively
// oriented with dihedral angles inside the given bounds. Sequential in node order: the result does
// not depend on the thread count.
#pragma once

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/meshing/sdf.h"

namespace shatter {

struct SharpenDef {
  double edge_length = 0;       ///< the mesh's edge length h, m (> 0): scale of every tolerance
  double min_dihedral_deg = 0;  ///< every tet around a moved node keeps its angles in here
  double max_dihedral_deg = 180;
  double crease_angle_deg = 25;  ///< samples' normals must spread wider than this
  int passes = 3;
};

struct SharpenReport {
  Index boundary_nodes = 0;
  Index moved = 0;  ///< node moves made, over all passes
};

Result<SharpenReport> sharpen_features(TetMesh& mesh, const Sdf& sdf, const SharpenDef& def);

}  // namespace shatter
