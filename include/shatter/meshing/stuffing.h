// Tetrahedral meshes of implicit shapes by isosurface stuffing on a body-centred cubic lattice
// (Labelle & Shewchuk 2007, "Isosurface Stuffing: Fast Tetrahedral Meshes with Good Dihedral
// Angles", SIGGRAPH): BCC lattice of spacing h, cut points where the SDF changes sign along a
// lattice edge, lattice vertices within alpha * edge length of a cut point warped onto it, and each
// BCC tet filled from the stencil table (stuffing_stencil.h) by the signs of its vertices.
//
// Grading (optional) coarsens the inside by edge collapse afterwards (coarsen.h).
//
// Limits: sharp edges and corners of the shape are rounded at the scale of h (the boundary
// interpolates points of the zero set, it does not follow creases); the dihedral-angle bounds below
// come from a numerical search of every configuration of the table, not a proof, and are lower than
// the paper's 10.7 degrees (docs/meshing.md).
#pragma once

#include <cstdint>

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/meshing/sdf.h"

namespace shatter {

/// Warp thresholds as fractions of the edge length (Labelle & Shewchuk 2007, section 3).
inline constexpr double kStuffingAlphaLong = 0.24999;   ///< for the long (axis-parallel) BCC edges
inline constexpr double kStuffingAlphaShort = 0.41189;  ///< for the short (diagonal) BCC edges
/// Dihedral-angle bounds of every tet stuffing outputs with these alphas, degrees: the extremes of
/// the stencil table over every configuration a warped BCC tet can take, found by exhaustive grid
/// and local search (tests/meshing/test_stuffing_stencil.cpp; docs/meshing.md). Sharpening and
/// grading only make changes that keep every tet inside them.
inline constexpr double kStuffingMinDihedralDeg = 9.3;    ///< smallest dihedral angle, degrees
inline constexpr double kStuffingMaxDihedralDeg = 161.7;  ///< largest dihedral angle, degrees

/// Settings of isosurface stuffing.
/// Memory the stuffer holds per lattice vertex, bytes: the distance (8), eleven cut parameters
/// (88), the warped flag (1), the position (24) and twelve key numbers (48).
inline constexpr std::int64_t kStuffingBytesPerLatticeVertex = 169;

struct StuffingDef {
  /// Lattice spacing h (the long BCC edge), m. If 0, chosen to get about `target_tets`.
  double edge_length = 0.0;
  /// Wanted number of tets when edge_length == 0 (h searched, within ~10 %).
  std::int64_t target_tets = 0;
  /// Warp thresholds as fractions of the edge length (Labelle & Shewchuk 2007, section 3), in
  /// (0, 0.5). The dihedral bounds above hold for the default values only.
  double alpha_long = kStuffingAlphaLong;    ///< long BCC edges
  double alpha_short = kStuffingAlphaShort;  ///< short BCC edges
  /// Move boundary nodes onto the shape's creases and corners (sharpen.h), inside the dihedral
  /// bounds, so sharp edges stay sharp instead of being rounded at the scale of h.
  bool sharpen = true;
  /// Grading: 0 keeps every tet at the lattice size. g > 0 coarsens the inside after stuffing
  /// (coarsen.h): the wanted edge length grows from h at depth h below the surface by g per unit
  /// depth, up to max_size_ratio * h. The boundary and the dihedral-angle bounds are kept.
  double grading = 0.0;
  double max_size_ratio = 8.0;  ///< cap on the graded edge length, in units of h
  /// Dihedral-angle range every tet changed by sharpening or grading must keep, degrees (clamped
  /// to the stencil bounds): tighter than the bounds, so neither lowers the mesh's quality much.
  double changed_min_dihedral_deg = 15.0;   ///< lower end, degrees
  double changed_max_dihedral_deg = 150.0;  ///< upper end, degrees
  /// False-position iterations for each cut point (distance functions converge in a few).
  int root_iterations = 16;
  /// Refuse lattices larger than this (memory guard): the lattice takes about
  /// kStuffingBytesPerLatticeVertex bytes per vertex, so the default is about 2 GiB. A shape far
  /// thinner than its bounding box (a corrupted surface with one far vertex) is what reaches it.
  std::int64_t max_lattice_vertices = 12'000'000;
};

/// What stuffing did.
struct StuffingReport {
  double edge_length = 0;                ///< h used, m
  std::int64_t lattice_vertices = 0;     ///< black + red lattice vertices evaluated
  std::int64_t cut_points = 0;           ///< cut points kept after warping
  std::int64_t warped = 0;               ///< lattice vertices warped onto the surface
  int attempts = 1;                      ///< meshings tried to reach target_tets
  std::int64_t tets_before_grading = 0;  ///< tets of the uniform mesh (= tets without grading)
  std::int64_t sharpened = 0;            ///< boundary node moves onto creases and corners
};

/// Mesh the inside (sdf < 0) of the shape. Nodes: used lattice vertices in lattice order, then cut
/// points. Tets positively oriented. Deterministic: identical output for any thread count.
Result<TetMesh> stuff_tets(const Sdf& sdf, const StuffingDef& def, StuffingReport* report = nullptr);

}  // namespace shatter
