// Structured tetrahedral meshes of shapes built from axis-aligned boxes by union, difference and
// intersection (with translations, uniform scales and rotations by multiples of 90 degrees).
//
// The face coordinates of all the boxes along each axis cut space into a rectilinear grid whose
// cells are each wholly inside or wholly outside the shape; every interval is split into pieces of
// about the edge length, the cells whose centre is inside are kept and each is cut into 6 tets
// around its main diagonal (Kuhn, as make_box_mesh: the same diagonal in every cell, so
// neighbouring cells conform). Sharp edges and corners are exact and the volume is the exact
// volume of the shape (up to rounding), at any size.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/meshing/sdf.h"

namespace shatter {

/// The world-space boxes of a box-CSG tree, or nullopt when the tree has anything else (another
/// primitive, a smooth union, a rotation that is not a multiple of 90 degrees about the axes).
std::optional<std::vector<Aabb>> box_csg_boxes(const Sdf& sdf);

/// Size settings of the box-CSG mesher.
struct BoxCsgDef {
  /// Wanted cell size, m: each grid interval of length L is split into max(1, round(L / h))
  /// pieces. If 0, chosen to get the count closest to `target_tets`.
  double edge_length = 0.0;
  std::int64_t target_tets = 0;  ///< wanted tet count when edge_length == 0
  /// Refuse grids with more cells than this (memory guard).
  std::int64_t max_cells = 20'000'000;
};

/// What the box-CSG mesher did.
struct BoxCsgReport {
  double edge_length = 0;        ///< h used, m
  std::array<Index, 3> grid{};   ///< intervals of the box-face grid along x, y, z
  std::array<Index, 3> cells{};  ///< cells along x, y, z after subdivision
  double exact_volume = 0;       ///< volume of the shape (sum of the inside grid cells), m^3
};

/// Mesh a box-CSG shape (box_csg_boxes(sdf) must succeed; an error otherwise). Nodes in grid
/// order (x fastest), only those used; tets positively oriented, cell by cell in grid order.
Result<TetMesh> mesh_box_csg(const Sdf& sdf, const BoxCsgDef& def, BoxCsgReport* report = nullptr);

}  // namespace shatter
