// Stencil table of isosurface stuffing; see stuffing_stencil.h for the numbering.
//
// Every clipped tet with inside (-) and outside (+) vertices is one of six cases, by the counts of
// -, 0 and + vertices: (1,0,3), (1,1,2) and (1,2,1) give one tet; (2,1,1) a pyramid on a
// quadrilateral (2 tets); (2,0,2) and (3,0,1) a triangular prism (3 tets). A prism is cut into 3
// tets from a vertex where two of its quadrilaterals' diagonals meet: the tet from that vertex to
// the opposite triangle, and the pyramid from it to the opposite quadrilateral.
#include "shatter/meshing/stuffing_stencil.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "shatter/mesh/quality.h"

namespace shatter::stuffing {
namespace {

using Tet = std::array<std::uint8_t, 4>;

void emit(StencilOutput& out, int a, int b, int c, int d) {
  out.tets[static_cast<std::size_t>(out.count++)] = {static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(b),
                                                     static_cast<std::uint8_t>(c), static_cast<std::uint8_t>(d)};
}

// Pivot of the quadrilateral on face (a, b, p), a and b inside, p outside: the diagonal runs from
// the pivot to the cut point on the other inside vertex's edge to p.
int quad_pivot(const StencilInput& in, int a, int b, int p) {
  if (is_long_edge(a, b)) {
    const bool first = in.long_pivot_first[a < 2 ? 0 : 1];
    const int lo = a < b ? a : b, hi = a < b ? b : a;
    return first ? lo : hi;
  }
  // a-b short: exactly one of a-p, b-p is long.
  const int on_long = is_long_edge(a, p) ? a : b;
  const int on_short = on_long == a ? b : a;
  return in.pivot_on_short ? on_short : on_long;
}

// Prism with triangles t0, t1 and rails t0[i]-t1[i]; quadrilateral i lies between rails i and
// i + 1 and diag[i] is true when its diagonal is t0[i]-t1[i+1], false for t0[i+1]-t1[i]. Returns
// false when the diagonals are cyclic (the prism then has no triangulation without a new point).
bool fill_prism(const std::array<int, 3>& t0, const std::array<int, 3>& t1, const std::array<bool, 3>& diag,
                StencilOutput& out) {
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3, prev = k;
    const bool t0_meets = diag[static_cast<std::size_t>(i)] && !diag[static_cast<std::size_t>(prev)];
    const bool t1_meets = diag[static_cast<std::size_t>(prev)] && !diag[static_cast<std::size_t>(i)];
    if (!t0_meets && !t1_meets) continue;
    const int x = t0_meets ? t0[static_cast<std::size_t>(i)] : t1[static_cast<std::size_t>(i)];
    const auto& opposite = t0_meets ? t1 : t0;
    emit(out, x, opposite[0], opposite[1], opposite[2]);
    // Quadrilateral j (rails j, k) does not contain x; split it by its own diagonal.
    const int a0 = t0[static_cast<std::size_t>(j)], b0 = t0[static_cast<std::size_t>(k)];
    const int a1 = t1[static_cast<std::size_t>(j)], b1 = t1[static_cast<std::size_t>(k)];
    if (diag[static_cast<std::size_t>(j)]) {  // a0-b1
      emit(out, x, a0, b0, b1);
      emit(out, x, a0, b1, a1);
    } else {  // b0-a1
      emit(out, x, a0, b0, a1);
      emit(out, x, b0, b1, a1);
    }
    return true;
  }
  return false;
}

double worst_shape(const StencilInput& in, const StencilOutput& out) {
  double w = std::numeric_limits<double>::infinity();
  for (int t = 0; t < out.count; ++t) {
    const Tet& k = out.tets[static_cast<std::size_t>(t)];
    w = std::min(w, std::abs(signed_shape_measure(in.x[k[0]], in.x[k[1]], in.x[k[2]], in.x[k[3]])));
  }
  return w;
}

}  // namespace

StencilOutput fill_stencil(const StencilInput& in) {
  StencilOutput out;
  int neg[4], zer[4], pos[4], nn = 0, nz = 0, np = 0;
  for (int i = 0; i < 4; ++i) {
    if (in.sign[static_cast<std::size_t>(i)] < 0)
      neg[nn++] = i;
    else if (in.sign[static_cast<std::size_t>(i)] > 0)
      pos[np++] = i;
    else
      zer[nz++] = i;
  }
  if (nn == 0) return out;
  if (np == 0) {
    emit(out, 0, 1, 2, 3);
    return out;
  }
  if (nn == 1) {
    const int a = neg[0];
    if (np == 3)
      emit(out, a, cut_point(a, pos[0]), cut_point(a, pos[1]), cut_point(a, pos[2]));
    else if (np == 2)
      emit(out, a, zer[0], cut_point(a, pos[0]), cut_point(a, pos[1]));
    else
      emit(out, a, zer[0], zer[1], cut_point(a, pos[0]));
    return out;
  }
  if (nn == 2 && nz == 1) {  // pyramid: apex the zero, base the quadrilateral on face (a, b, p)
    const int a = neg[0], b = neg[1], p = pos[0], z = zer[0];
    const int ca = cut_point(a, p), cb = cut_point(b, p);
    if (quad_pivot(in, a, b, p) == a) {
      emit(out, z, a, b, cb);
      emit(out, z, a, cb, ca);
    } else {
      emit(out, z, a, b, ca);
      emit(out, z, b, cb, ca);
    }
    return out;
  }
  if (nn == 2) {  // prism (a, a-p, a-q) / (b, b-p, b-q); quadrilateral 1 is the boundary cap
    const int a = neg[0], b = neg[1], p = pos[0], q = pos[1];
    const std::array<int, 3> t0{a, cut_point(a, p), cut_point(a, q)};
    const std::array<int, 3> t1{b, cut_point(b, p), cut_point(b, q)};
    const bool d0 = quad_pivot(in, a, b, p) == a;  // a-(b-p) on face (a, b, p)
    const bool d2 = quad_pivot(in, a, b, q) == b;  // (a-q)-b on face (a, b, q)
    StencilOutput best;
    double best_shape = -1;
    for (const bool d1 : {false, true}) {
      StencilOutput trial;
      if (!fill_prism(t0, t1, {d0, d1, d2}, trial)) continue;
      const double s = worst_shape(in, trial);
      if (best.count == 0 || s > best_shape) {  // the first acyclic choice even if s is NaN
        best_shape = s;
        best = trial;
      }
    }
    return best;
  }
  // (3,0,1): prism (a, b, c) / (a-p, b-p, c-p), every quadrilateral on a face shared with a neighbour.
  const int p = pos[0];
  const std::array<int, 3> t0{neg[0], neg[1], neg[2]};
  const std::array<int, 3> t1{cut_point(neg[0], p), cut_point(neg[1], p), cut_point(neg[2], p)};
  std::array<bool, 3> diag{};
  for (int i = 0; i < 3; ++i)
    diag[static_cast<std::size_t>(i)] =
        quad_pivot(in, t0[static_cast<std::size_t>(i)], t0[static_cast<std::size_t>((i + 1) % 3)], p) ==
        t0[static_cast<std::size_t>(i)];
  // Never cyclic: the inside vertex L on the long edge to p is the pivot of neither face through
  // L-p (both pivot on the short-edge vertex), so the three pivots cannot all differ.
  fill_prism(t0, t1, diag, out);
  return out;
}

}  // namespace shatter::stuffing
