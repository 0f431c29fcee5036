// Element quality: dihedral angles and aspect ratio, per tet and summarised.
#pragma once

#include <array>

#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// The six interior dihedral angles of the tet with corners x (3x4, m), radians, at edges
/// (01,02,03,12,13,23).
std::array<double, 6> dihedral_angles(const Mat34& x);
/// Their cosines, without the arc cosine (for comparisons against fixed bounds); 0 at an edge of
/// a degenerate face.
std::array<double, 6> dihedral_cosines(const Mat34& x);

/// Shape measure of the tet (a, b, c, d): signed volume / (sum of squared edge lengths)^(3/2);
/// 0 when flat, negative when inverted, largest for the regular tet. Cheap (no roots but one).
double signed_shape_measure(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Aspect ratio of the tet with corners x = circumradius / (3 * inradius): 1 for the regular tet,
/// larger is worse, +inf for a degenerate tet.
double aspect_ratio(const Mat34& x);

/// Volume and quality extremes of a whole mesh (all zero, tets -1, for a mesh without tets).
struct QualitySummary {
  double volume = 0;            ///< total signed volume, m^3
  double min_tet_volume = 0;    ///< smallest signed tet volume, m^3
  double max_tet_volume = 0;    ///< largest signed tet volume, m^3
  double min_dihedral_deg = 0;  ///< smallest dihedral angle over all tets, degrees
  double max_dihedral_deg = 0;  ///< largest dihedral angle over all tets, degrees
  double min_aspect = 0;        ///< smallest aspect ratio
  double max_aspect = 0;        ///< largest aspect ratio
  double mean_aspect = 0;       ///< mean aspect ratio over the tets
  Index worst_aspect_tet = -1;  ///< tet index with the largest aspect ratio
  Index min_dihedral_tet = -1;  ///< tet index with the smallest dihedral angle
};
/// Volume, dihedral angles and aspect ratios of every tet, summarised.
QualitySummary mesh_quality(const TetMesh& mesh);

}  // namespace shatter
