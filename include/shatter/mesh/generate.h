// Structured meshes for tests and benchmarks: a box subdivided into cells, each cut into tets.
#pragma once

#include <array>
#include <cstdint>

#include "shatter/mesh/tet_mesh.h"

namespace shatter {

/// A structured box mesh: bounds, cell counts, split pattern and optional jitter.
struct BoxMeshDef {
  Vec3 min = Vec3::Zero();              ///< lowest corner, m
  Vec3 max = Vec3::Ones();              ///< highest corner, m
  std::array<Index, 3> cells{1, 1, 1};  ///< cells along x, y, z (each >= 1)
  /// Cells cut into 6 tets around the main diagonal (Kuhn; conforming, all cells alike) or
  /// 5 tets (one central tet; alternating parity so neighbouring cells conform).
  enum class Pattern { six, five } pattern = Pattern::six;
  /// Interior nodes moved by up to jitter * cell size in each axis (< 0.25 keeps tets valid).
  double jitter = 0.0;
  std::uint64_t seed = 1;  ///< random seed of the jitter
};

/// The box mesh of `def`. Nodes numbered x fastest, then y, then z; ids 1..N. Tets positively oriented.
TetMesh make_box_mesh(const BoxMeshDef& def);

/// Cells for a box of size `extent` (m) with about `target_tets` tets and near-cubic cells.
std::array<Index, 3> cells_for_tet_count(const Vec3& extent, std::int64_t target_tets,
                                         BoxMeshDef::Pattern pattern = BoxMeshDef::Pattern::six);

}  // namespace shatter
