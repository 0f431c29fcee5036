// The stencil table of isosurface stuffing (Labelle & Shewchuk 2007, section 3 and figure 4): how
// one BCC tet, after warping, is filled with output tets. Kept apart from the lattice code so the
// table can be checked on its own, configuration by configuration (tests/meshing/
// test_stuffing_stencil.cpp), and the dihedral-angle bounds it gives found by search.
//
// Local numbering of a BCC tet: vertices 0..3 with 0-1 the black long edge (two cube corners) and
// 2-3 the red long edge (two cube centres); the other four edges are short. Local point 4 + e is
// the cut point on edge e, edges in the order of kStencilEdges.
#pragma once

#include <array>
#include <cstdint>

#include "shatter/core/types.h"

namespace shatter::stuffing {

inline constexpr int kStencilEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

/// Local point of the cut point on edge (i, j), i != j.
constexpr int cut_point(int i, int j) {
  const int a = i < j ? i : j, b = i < j ? j : i;
  return 4 + (a == 0 ? b - 1 : (a == 1 ? b + 1 : 5));
}

/// Edge (i, j) of the BCC tet is long (length h) rather than short (h sqrt(3) / 2).
constexpr bool is_long_edge(int i, int j) { return (i < 2) == (j < 2); }

struct StencilInput {
  /// Vertex signs after warping: -1 inside, 0 on the surface (warped or exactly zero), +1 outside.
  std::array<int, 4> sign{};
  /// Parity rule for a quadrilateral whose two inside vertices are a long edge: true when vertex
  /// 0 (for the black edge 0-1) or 2 (red edge 2-3) is its pivot, false for 1 or 3. It must be a
  /// function of the edge alone, so the two BCC tets sharing the quadrilateral agree; the lattice
  /// uses the parity of the edge's position along its axis.
  std::array<bool, 2> long_pivot_first{true, true};
  /// Positions of the 10 local points (cut points only where a -/+ edge has one); used to pick the
  /// diagonal of the boundary cap, which no other tet shares.
  std::array<Vec3, 10> x{};
  /// Diagonal of a quadrilateral whose inside vertices are joined by a short edge: from the vertex
  /// whose edge to the outside vertex is short (true, the table's choice) or long (false; kept for
  /// the bound search that chose it).
  bool pivot_on_short = true;
};

/// Up to 3 tets (local points), orientation not normalised.
struct StencilOutput {
  std::array<std::array<std::uint8_t, 4>, 3> tets{};
  int count = 0;
};

/// Fill one BCC tet: nothing without an inside vertex (also when all four are on the surface),
/// the whole tet without an outside vertex, else one of six clipped cases. The quadrilateral faces a clipped tet shares with its neighbours are split
/// by a rule of the face alone: when the face's two inside vertices a, b are joined by a short
/// edge, the diagonal runs from the vertex whose edge to the outside vertex is short to the cut
/// point on the long edge; when they are joined by a long edge, by the parity rule above. The
/// boundary cap of a tet with two inside and two outside vertices takes whichever diagonal keeps
/// the prism triangulable and gives the better worst tet.
StencilOutput fill_stencil(const StencilInput& in);

}  // namespace shatter::stuffing
