// FemModel construction and the global internal force: a straightforward reference and a fast path
// (QR-rotated rest frames, specialised StVK code, fixed blocks with a deterministic gather).
#include "shatter/fem/fem_model.h"

#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "shatter/core/lanes.h"
#include "shatter/core/parallel.h"
#include "shatter/core/simd.h"

namespace shatter {
namespace {

constexpr std::int64_t kBlockSize = 1024;  // tets per block; fixed so results ignore thread count

// Upper-triangular R of Dm = Q^T R (Householder QR) with Q a rotation, returned as the 6 entries of
// R^-1. Householder's Q may be a reflection; then the last row of R and of Q change sign, so that
// F' = F Q^T keeps the sign of det F (the corotated model's polar rotation needs it; StVK's C = F'^T F'
// does not see it).
std::array<double, 6> rotated_rest_inverse(const TetRest& rest) {
  const Mat3 Dm = rest.Dm_inv.inverse();
  const Eigen::HouseholderQR<Mat3> qr(Dm);
  Mat3 R = qr.matrixQR().triangularView<Eigen::Upper>();
  if (Dm.determinant() * R(0, 0) * R(1, 1) * R(2, 2) < 0) R.row(2) = -R.row(2);  // det Q = det Dm / det R
  const Mat3 Rinv = R.triangularView<Eigen::Upper>().solve(Mat3::Identity());
  return {Rinv(0, 0), Rinv(0, 1), Rinv(0, 2), Rinv(1, 1), Rinv(1, 2), Rinv(2, 2)};
}

// Rows per tet of FastTetData::packed: StVK and corotated keep R^-1 of the rotated rest frame and V;
// the linear model, which is not rotation invariant, Dm^-1 and V.
int packed_rows(ModelKind kind) { return kind == ModelKind::linear ? 10 : 7; }

void store_fast_rest(FemModel& model, std::size_t e) {
  const TetRest& r = model.rest[e];
  const int rows = packed_rows(model.model);
  double* group = model.fast.packed.data() + static_cast<std::size_t>(rows) * (e / 4 * 4) + e % 4;
  if (model.model == ModelKind::linear) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) group[4 * (3 * i + j)] = r.Dm_inv(i, j);
    group[36] = r.volume;
    return;
  }
  const std::array<double, 6> ri = rotated_rest_inverse(r);
  for (int c = 0; c < 6; ++c) group[4 * c] = ri[static_cast<std::size_t>(c)];
  group[24] = r.volume;
}

void build_blocks(FemModel& model) {
  FastTetData& fd = model.fast;
  const std::int64_t n_tets = model.num_tets();
  fd.block_size = kBlockSize;
  const std::int64_t n_blocks = (n_tets + kBlockSize - 1) / kBlockSize;
  fd.corner_slot.assign(static_cast<std::size_t>(4 * n_tets), 0);
  fd.block_slot_begin.assign(static_cast<std::size_t>(n_blocks + 1), 0);
  std::vector<std::int64_t> slot_node;  // node of each global slot
  std::vector<std::int32_t> local(static_cast<std::size_t>(model.num_nodes), -1);
  for (std::int64_t b = 0; b < n_blocks; ++b) {
    const std::int64_t begin = static_cast<std::int64_t>(slot_node.size());
    fd.block_slot_begin[static_cast<std::size_t>(b)] = begin;
    const std::int64_t lo = b * kBlockSize, hi = std::min(n_tets, lo + kBlockSize);
    // Slots in order of first appearance in the block's tets.
    for (std::int64_t e = lo; e < hi; ++e) {
      for (int k = 0; k < 4; ++k) {
        const Index n = model.tets[static_cast<std::size_t>(e)][k];
        if (local[n] < 0) {
          local[n] = static_cast<std::int32_t>(static_cast<std::int64_t>(slot_node.size()) - begin);
          slot_node.push_back(n);
        }
        fd.corner_slot[static_cast<std::size_t>(4 * e + k)] = 4 * local[n];
      }
    }
    for (std::int64_t s = begin; s < static_cast<std::int64_t>(slot_node.size()); ++s)
      local[static_cast<std::size_t>(slot_node[static_cast<std::size_t>(s)])] = -1;
  }
  fd.block_slot_begin[static_cast<std::size_t>(n_blocks)] = static_cast<std::int64_t>(slot_node.size());
  // Node -> slots, in block order (slots are numbered block by block).
  fd.node_entry_begin.assign(static_cast<std::size_t>(model.num_nodes) + 1, 0);
  for (std::int64_t n : slot_node) ++fd.node_entry_begin[static_cast<std::size_t>(n) + 1];
  for (std::size_t i = 1; i < fd.node_entry_begin.size(); ++i) fd.node_entry_begin[i] += fd.node_entry_begin[i - 1];
  fd.node_entry_slot.assign(slot_node.size(), 0);
  std::vector<std::int64_t> fill(fd.node_entry_begin.begin(), fd.node_entry_begin.end() - 1);
  for (std::size_t s = 0; s < slot_node.size(); ++s)
    fd.node_entry_slot[static_cast<std::size_t>(fill[static_cast<std::size_t>(slot_node[s])]++)] =
        static_cast<std::int64_t>(s);
}

// Four tets at a time: every double below holds one value per lane (GCC vector extension; with
// -ffp-contract=off each lane is computed exactly as the scalar formula would be, so the baseline and
// AVX2 versions give the same bits).
// Vectors only live inside the force kernels (loads are built in place; the always-inlined helpers
// take them by pointer), so none crosses a call by value; GCC's -Wpsabi warns about the call ABI of
// such vectors. PlainLanes (core/lanes.h): these vectors never cross a call, so they need no
// 32-byte alignment.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"

// The kernels' shared steps. Always inlined into each kernel (the AVX2 kernel then compiles them for
// AVX2 too); they take vectors only by pointer.

// Node n as (x, y, z, w), w meaningless: one 32-byte load that also reads the next node's x, except
// for the last node, which has no next node.
[[gnu::always_inline]] inline void load_node(const Vec3* x, std::int64_t last_node, Index n, PlainLanes* p) {
  const double* q = x[n].data();
  if (n < last_node)
    std::memcpy(p, q, sizeof(PlainLanes));
  else
    *p = PlainLanes{q[0], q[1], q[2], 0.0};
}

// r = a0 b0 + a1 b1 + a2 b2 per lane, left to right.
[[gnu::always_inline]] inline void lane_dot3(const PlainLanes& a0, const PlainLanes& a1, const PlainLanes& a2,
                                             const PlainLanes& b0, const PlainLanes& b1, const PlainLanes& b2,
                                             PlainLanes* r) {
  *r = a0 * b0 + a1 * b1 + a2 * b2;
}

// The edges d_k = x_k - x_0 (k = 1, 2, 3) of the four tets g0 .. g0 + 3 as lane vectors
// d[3 (k - 1) + axis]; padding lanes (from `lanes` on) repeat the first tet. Each lane's edge is
// formed as (x, y, z, w) and the three are transposed to one vector per axis.
[[gnu::always_inline]] inline void load_edges(const TetIndices* tets, const Vec3* x, std::int64_t last_node,
                                              std::int64_t g0, int lanes, PlainLanes* d) {
  PlainLanes e[3][4];  // [edge][lane]: (x, y, z, w)
#pragma GCC unroll 4
  for (int l = 0; l < 4; ++l) {
    const TetIndices& t = tets[g0 + (l < lanes ? l : 0)];
    PlainLanes p0{}, pk{};  // set by load_node (GCC cannot see through its memcpy)
    load_node(x, last_node, t[0], &p0);
#pragma GCC unroll 4
    for (int k = 1; k < 4; ++k) {
      load_node(x, last_node, t[k], &pk);
      e[k - 1][l] = pk - p0;
    }
  }
#pragma GCC unroll 4
  for (int k = 0; k < 3; ++k) {
    const PlainLanes xz01 = __builtin_shufflevector(e[k][0], e[k][1], 0, 4, 2, 6);  // x0 x1 z0 z1
    const PlainLanes yw01 = __builtin_shufflevector(e[k][0], e[k][1], 1, 5, 3, 7);  // y0 y1 w0 w1
    const PlainLanes xz23 = __builtin_shufflevector(e[k][2], e[k][3], 0, 4, 2, 6);
    const PlainLanes yw23 = __builtin_shufflevector(e[k][2], e[k][3], 1, 5, 3, 7);
    d[3 * k] = __builtin_shufflevector(xz01, xz23, 0, 1, 4, 5);
    d[3 * k + 1] = __builtin_shufflevector(yw01, yw23, 0, 1, 4, 5);
    d[3 * k + 2] = __builtin_shufflevector(xz01, xz23, 2, 3, 6, 7);
  }
}

// Add the corner forces out[3 k + axis] (one lane per tet) into the block's slots (x, y, z, 0 each),
// in tet order: each lane's corner force is transposed to (fx, fy, fz, 0) and added as one vector.
[[gnu::always_inline]] inline void scatter_corner_forces(const PlainLanes* out, const std::int32_t* corner_slot,
                                                         std::int64_t g0, int lanes, double* slots) {
  const PlainLanes zero = PlainLanes{0, 0, 0, 0};
  PlainLanes f[4][4];  // [lane][corner]: (fx, fy, fz, 0)
#pragma GCC unroll 4
  for (int k = 0; k < 4; ++k) {
    const PlainLanes xy02 = __builtin_shufflevector(out[3 * k], out[3 * k + 1], 0, 4, 2, 6);  // x0 y0 x2 y2
    const PlainLanes xy13 = __builtin_shufflevector(out[3 * k], out[3 * k + 1], 1, 5, 3, 7);  // x1 y1 x3 y3
    const PlainLanes z02 = __builtin_shufflevector(out[3 * k + 2], zero, 0, 4, 2, 6);         // z0 0 z2 0
    const PlainLanes z13 = __builtin_shufflevector(out[3 * k + 2], zero, 1, 5, 3, 7);         // z1 0 z3 0
    f[0][k] = __builtin_shufflevector(xy02, z02, 0, 1, 4, 5);
    f[1][k] = __builtin_shufflevector(xy13, z13, 0, 1, 4, 5);
    f[2][k] = __builtin_shufflevector(xy02, z02, 2, 3, 6, 7);
    f[3][k] = __builtin_shufflevector(xy13, z13, 2, 3, 6, 7);
  }
#pragma GCC unroll 4
  for (int l = 0; l < lanes; ++l) {
    const std::int32_t* cs = corner_slot + 4 * (g0 + l);
#pragma GCC unroll 4
    for (int k = 0; k < 4; ++k) {
      double* s = slots + cs[k];
      PlainLanes sum;
      std::memcpy(&sum, s, sizeof(PlainLanes));
      sum += f[l][k];
      std::memcpy(s, &sum, sizeof(PlainLanes));
    }
  }
}

// Lane-wise max and square root; a and b are plain names (each is read more than once). Macros, as
// no helper here returns a vector by value (see above).
#define SHATTER_LANE_MAX(a, b) ((a) > (b) ? (a) : (b))
#define SHATTER_LANE_SQRT(a) \
  PlainLanes { std::sqrt((a)[0]), std::sqrt((a)[1]), std::sqrt((a)[2]), std::sqrt((a)[3]) }

// m = max_ij |a_ij - b_ij| of two 3x3 matrices (row-major, nine lane vectors each).
[[gnu::always_inline]] inline void lane_max_abs_difference(const PlainLanes* a, const PlainLanes* b, PlainLanes* m) {
  *m = PlainLanes{0, 0, 0, 0};
  for (int i = 0; i < 9; ++i) {
    const PlainLanes d = a[i] - b[i];
    const PlainLanes nd = -d;
    const PlainLanes ad = SHATTER_LANE_MAX(d, nd);
    *m = SHATTER_LANE_MAX(*m, ad);
  }
}
// y = x^-T of a 3x3 matrix per lane (row-major) and det x: with a, b, c the columns of x,
// x^-T = [b x c, c x a, a x b] / det.
[[gnu::always_inline]] inline void lane_inverse_transpose(const PlainLanes* x, PlainLanes* y, PlainLanes* det) {
  const PlainLanes bc0 = x[4] * x[8] - x[7] * x[5], bc1 = x[7] * x[2] - x[1] * x[8], bc2 = x[1] * x[5] - x[4] * x[2];
  const PlainLanes ca0 = x[5] * x[6] - x[8] * x[3], ca1 = x[8] * x[0] - x[2] * x[6], ca2 = x[2] * x[3] - x[5] * x[0];
  const PlainLanes ab0 = x[3] * x[7] - x[6] * x[4], ab1 = x[6] * x[1] - x[0] * x[7], ab2 = x[0] * x[4] - x[3] * x[1];
  *det = x[0] * bc0 + x[3] * bc1 + x[6] * bc2;
  const PlainLanes inv = 1.0 / *det;
  y[0] = bc0 * inv, y[1] = ca0 * inv, y[2] = ab0 * inv;
  y[3] = bc1 * inv, y[4] = ca1 * inv, y[5] = ab1 * inv;
  y[6] = bc2 * inv, y[7] = ca2 * inv, y[8] = ab2 * inv;
}

// R of the polar decomposition F = R S of four 3x3 matrices (row-major lanes), by Higham's scaled
// Newton iteration as polar_decomposition does (constitutive.cpp): X <- (z X + X^-T / z) / 2 with
// z = (|X^-T|_F / |X|_F)^(1/2) while a lane's step is large, plain Newton after; all lanes step
// together until every one has moved by at most 1e-8, then one more plain step lands them at
// round-off. A lane that is inverted, nearly singular (det F below 1e-6 of max|F|^3) or not
// converged in 30 steps gets polar_decomposition's answer (SVD where Newton cannot), so each lane's
// R is a rotation. Deterministic: a lane's steps depend on its group of four, which is fixed.
// Lanes from `lanes` on are padding: left as they come.
[[gnu::always_inline]] inline void lane_polar_rotation(const PlainLanes* F, int lanes, PlainLanes* R) {
  PlainLanes scale = PlainLanes{0, 0, 0, 0};
  for (int i = 0; i < 9; ++i) {
    const PlainLanes nf = -F[i];
    const PlainLanes af = SHATTER_LANE_MAX(F[i], nf);
    scale = SHATTER_LANE_MAX(scale, af);
  }
  PlainLanes X[9], Y[9], det;
  for (int i = 0; i < 9; ++i) X[i] = F[i];
  PlainLaneMask ok{};
  bool converged = false, fixed_steps = false;
  // Near a rotation (every stiff body under load), a fixed count of plain steps suffices and no step
  // needs checking. With F = U (I + E) and m = max|F^T F - I|, |E| <= 1.6 m for m <= 0.03, and a
  // plain step maps |E| to at most |E|^2 / (2 (1 - |E|)): from |E| <= 0.05, four steps reach 1e-25
  // (round-off); from |E| <= 1e-3, three.
  {
    const PlainLanes c00 = F[0] * F[0] + F[3] * F[3] + F[6] * F[6], c11 = F[1] * F[1] + F[4] * F[4] + F[7] * F[7],
                     c22 = F[2] * F[2] + F[5] * F[5] + F[8] * F[8], c01 = F[0] * F[1] + F[3] * F[4] + F[6] * F[7],
                     c02 = F[0] * F[2] + F[3] * F[5] + F[6] * F[8], c12 = F[1] * F[2] + F[4] * F[5] + F[7] * F[8];
    const PlainLanes defect[6] = {c00 - 1.0, c11 - 1.0, c22 - 1.0, c01, c02, c12};
    PlainLanes m = PlainLanes{0, 0, 0, 0};
    for (const PlainLanes& d : defect) {
      const PlainLanes nd = -d;
      const PlainLanes ad = SHATTER_LANE_MAX(d, nd);
      m = SHATTER_LANE_MAX(m, ad);
    }
    bool four = true, three = true;
    for (int l = 0; l < lanes; ++l) {
      four = four && m[l] <= 0.03;  // false for NaN too
      three = three && m[l] <= 6e-4;
    }
    if (four) {
      for (int step = 0; step < (three ? 3 : 4); ++step) {
        lane_inverse_transpose(X, Y, &det);
        if (step == 0)
          ok = det > 1e-6 * scale * scale * scale;  // det F: an inverted lane converges to a reflection
        else
          ok &= det > 0.0;
        for (int i = 0; i < 9; ++i) X[i] = 0.5 * (X[i] + Y[i]);
      }
      for (int i = 0; i < 9; ++i) R[i] = X[i];
      converged = fixed_steps = true;
    }
  }
  for (int step = 0; step < 30 && !converged; ++step) {
    lane_inverse_transpose(X, Y, &det);
    if (step == 0)
      ok = det > 1e-6 * scale * scale * scale;  // det F
    else
      ok &= det > 0.0;
    PlainLanes change0, change;
    lane_max_abs_difference(X, Y, &change0);
    PlainLanes nx = X[0] * X[0], ny = Y[0] * Y[0];
    for (int i = 1; i < 9; ++i) nx += X[i] * X[i], ny += Y[i] * Y[i];
    const PlainLanes ratio = ny / nx;
    const PlainLanes root2 = SHATTER_LANE_SQRT(ratio);
    const PlainLanes root4 = SHATTER_LANE_SQRT(root2);
    const PlainLanes one = PlainLanes{1, 1, 1, 1};
    const PlainLanes z = change0 > 1e-2 ? root4 : one;
    const PlainLanes zi = 1.0 / z;
    PlainLanes next[9];
    for (int i = 0; i < 9; ++i) next[i] = 0.5 * (z * X[i] + Y[i] * zi);
    lane_max_abs_difference(next, X, &change);
    for (int i = 0; i < 9; ++i) X[i] = next[i];
    const PlainLaneMask done = (change <= 1e-8) | ~ok;  // failed lanes are left to the fallback
    converged = done[0] && done[1] && done[2] && done[3];
  }
  if (!fixed_steps) {
    for (int i = 0; i < 9; ++i) R[i] = X[i];
    if (converged) {  // the checked iteration ends with one more plain step
      lane_inverse_transpose(X, Y, &det);
      ok &= det > 0.0;
      for (int i = 0; i < 9; ++i) R[i] = 0.5 * (X[i] + Y[i]);
    }
  }
  for (int l = 0; l < lanes; ++l) {
    bool finite = converged && ok[l] != 0;
    for (int i = 0; i < 9 && finite; ++i) finite = std::isfinite(R[i][l]);
    if (finite) continue;
    Mat3 f;
    for (int i = 0; i < 9; ++i) f(i / 3, i % 3) = F[i][l];
    const Mat3 r = polar_decomposition(f).R;
    for (int i = 0; i < 9; ++i) R[i][l] = r(i / 3, i % 3);
  }
}

}  // namespace

// Four consecutive packed values as one lane vector.
#define SHATTER_LOAD(p) \
  PlainLanes { (p)[0], (p)[1], (p)[2], (p)[3] }

namespace {

// What every block kernel reads and writes: the packed rest data, the tets, their corners' slots,
// the deformed positions (the last node is num_nodes - 1), the tets [lo, hi) of one block (lo a
// multiple of 4), the Lame constants and the block's slots (4 doubles each, N).
struct BlockArgs {
  const double* packed;
  const TetIndices* tets;
  const std::int32_t* corner_slot;
  const Vec3* x;
  std::int64_t last_node;
  std::int64_t lo, hi;
  double mu, lambda;
  double* slots;
};

// A group of four tets in their QR-rotated rest frames (StVK and corotated): R^-1 (upper
// triangular), the rest volume V and F' = Ds R^-1 row-major, whose columns are a = d0 r00,
// b = d0 r01 + d1 r11 and c = d0 r02 + d1 r12 + d2 r22 for the edges d_k = x_{k+1} - x_0.
struct RotatedFrame {
  PlainLanes r00, r01, r02, r11, r12, r22, vol;
  PlainLanes F[9];
};

[[gnu::always_inline]] inline void load_rotated_frame(const BlockArgs& a, std::int64_t g0, int lanes, RotatedFrame* f) {
  const double* r = a.packed + 7 * g0;  // 7 lane vectors per group of 4 tets
  f->r00 = SHATTER_LOAD(r), f->r01 = SHATTER_LOAD(r + 4), f->r02 = SHATTER_LOAD(r + 8);
  f->r11 = SHATTER_LOAD(r + 12), f->r12 = SHATTER_LOAD(r + 16), f->r22 = SHATTER_LOAD(r + 20);
  f->vol = SHATTER_LOAD(r + 24);
  PlainLanes d[9];  // d[3 k + axis]: edge k + 1
  load_edges(a.tets, a.x, a.last_node, g0, lanes, d);
  const PlainLanes &r00 = f->r00, &r01 = f->r01, &r02 = f->r02, &r11 = f->r11, &r12 = f->r12, &r22 = f->r22;
#pragma GCC unroll 4
  for (int i = 0; i < 3; ++i) {
    f->F[3 * i] = d[i] * r00;
    f->F[3 * i + 1] = d[i] * r01 + d[3 + i] * r11;
    f->F[3 * i + 2] = d[i] * r02 + d[3 + i] * r12 + d[6 + i] * r22;
  }
}

// The corner forces out[3 k + axis] from M = V P' (row-major): [f1 f2 f3] = M R^-T with R^-1
// upper triangular, f0 = -(f1 + f2 + f3).
[[gnu::always_inline]] inline void rotated_frame_forces(const PlainLanes* M, const RotatedFrame& f, PlainLanes* out) {
#pragma GCC unroll 4
  for (int i = 0; i < 3; ++i) {
    const PlainLanes f1 = M[3 * i] * f.r00 + M[3 * i + 1] * f.r01 + M[3 * i + 2] * f.r02;
    const PlainLanes f2 = M[3 * i + 1] * f.r11 + M[3 * i + 2] * f.r12;
    const PlainLanes f3 = M[3 * i + 2] * f.r22;
    out[i] = -(f1 + f2 + f3);
    out[3 + i] = f1, out[6 + i] = f2, out[9 + i] = f3;
  }
}

// StVK forces of one block's tets in their QR-rotated rest frames (docs/method.md §2.1-2.2, §3):
// F' = Ds R^-1, S' = 2 mu E' + lambda tr(E') I, H = V F' S' R^-T, [f1 f2 f3] = H,
// f0 = -(f1 + f2 + f3); added into the block's slots in tet order.
[[gnu::always_inline]] inline void stvk_forces_block(const BlockArgs& a) {
  for (std::int64_t g0 = a.lo; g0 < a.hi; g0 += 4) {
    const int lanes = static_cast<int>(std::min<std::int64_t>(4, a.hi - g0));
    RotatedFrame f;
    load_rotated_frame(a, g0, lanes, &f);
    const PlainLanes& vol = f.vol;
    // F' columns a, b, c.
    const PlainLanes &ax = f.F[0], &bx = f.F[1], &cx = f.F[2], &ay = f.F[3], &by = f.F[4], &cy = f.F[5], &az = f.F[6],
                     &bz = f.F[7], &cz = f.F[8];
    // C = F'^T F': dot products of the columns.
    PlainLanes caa, cbb, ccc, cab, cac, cbc;
    lane_dot3(ax, ay, az, ax, ay, az, &caa);
    lane_dot3(bx, by, bz, bx, by, bz, &cbb);
    lane_dot3(cx, cy, cz, cx, cy, cz, &ccc);
    lane_dot3(ax, ay, az, bx, by, bz, &cab);
    lane_dot3(ax, ay, az, cx, cy, cz, &cac);
    lane_dot3(bx, by, bz, cx, cy, cz, &cbc);
    // V S' = V (mu (C - I) + lambda/2 (tr C - 3) I).
    const PlainLanes vmu = vol * a.mu, vlh = vol * (0.5 * a.lambda);
    const PlainLanes ltr = vlh * (caa + cbb + ccc - 3.0);
    const PlainLanes shift = ltr - vmu;
    const PlainLanes saa = vmu * caa + shift, sbb = vmu * cbb + shift, scc = vmu * ccc + shift;
    const PlainLanes sab = vmu * cab, sac = vmu * cac, sbc = vmu * cbc;
    // M = F' (V S'), row-major; H = M R^-T.
    PlainLanes M[9];
#pragma GCC unroll 4
    for (int i = 0; i < 3; ++i) {
      const PlainLanes &fa = f.F[3 * i], &fb = f.F[3 * i + 1], &fc = f.F[3 * i + 2];
      lane_dot3(fa, fb, fc, saa, sab, sac, &M[3 * i]);
      lane_dot3(fa, fb, fc, sab, sbb, sbc, &M[3 * i + 1]);
      lane_dot3(fa, fb, fc, sac, sbc, scc, &M[3 * i + 2]);
    }
    PlainLanes out[12];
    rotated_frame_forces(M, f, out);
    scatter_corner_forces(out, a.corner_slot, g0, lanes, a.slots);
  }
}

// Linear (small-strain) forces of one block's tets: F = Ds Dm^-1, eps = (F + F^T)/2 - I,
// V P = V (2 mu eps + lambda tr(eps) I), [f1 f2 f3] = V P Dm^-T, f0 = -(f1 + f2 + f3); added into
// the block's slots in tet order (docs/method.md §2.2).
[[gnu::always_inline]] inline void linear_forces_block(const BlockArgs& a) {
  for (std::int64_t g0 = a.lo; g0 < a.hi; g0 += 4) {
    const int lanes = static_cast<int>(std::min<std::int64_t>(4, a.hi - g0));
    const double* r = a.packed + 10 * g0;  // 10 lane vectors per group of 4 tets
    // m = Dm^-1, row-major.
    PlainLanes m[9];
#pragma GCC unroll 9
    for (int i = 0; i < 9; ++i) m[i] = SHATTER_LOAD(r + 4 * i);
    const PlainLanes vol = SHATTER_LOAD(r + 36);
    PlainLanes d[9];  // Ds columns d0 d1 d2 (edges from corner 0): d[3 k + axis]
    load_edges(a.tets, a.x, a.last_node, g0, lanes, d);
    // F = Ds m: F(i, j) = d0_i m0j + d1_i m1j + d2_i m2j.
    PlainLanes F[9];
#pragma GCC unroll 4
    for (int i = 0; i < 3; ++i)
#pragma GCC unroll 4
      for (int j = 0; j < 3; ++j) lane_dot3(d[i], d[3 + i], d[6 + i], m[j], m[3 + j], m[6 + j], &F[3 * i + j]);
    // V P, symmetric: diagonal 2 mu V (F_ii - 1) + lambda V tr(eps), off-diagonal mu V (F_ij + F_ji).
    const PlainLanes vmu = vol * a.mu, vl = vol * a.lambda;
    const PlainLanes ltr = vl * ((F[0] - 1.0) + (F[4] - 1.0) + (F[8] - 1.0));
    PlainLanes P[9];
#pragma GCC unroll 4
    for (int i = 0; i < 3; ++i) P[4 * i] = 2.0 * vmu * (F[4 * i] - 1.0) + ltr;
    P[1] = P[3] = vmu * (F[1] + F[3]);
    P[2] = P[6] = vmu * (F[2] + F[6]);
    P[5] = P[7] = vmu * (F[5] + F[7]);
    // f_k (k = 1, 2, 3) = V P (row k - 1 of m).
    PlainLanes out[12];
#pragma GCC unroll 4
    for (int k = 1; k < 4; ++k)
#pragma GCC unroll 4
      for (int i = 0; i < 3; ++i)
        lane_dot3(P[3 * i], P[3 * i + 1], P[3 * i + 2], m[3 * (k - 1)], m[3 * (k - 1) + 1], m[3 * (k - 1) + 2],
                  &out[3 * k + i]);
#pragma GCC unroll 4
    for (int i = 0; i < 3; ++i) out[i] = -(out[3 + i] + out[6 + i] + out[9 + i]);
    scatter_corner_forces(out, a.corner_slot, g0, lanes, a.slots);
  }
}

// Corotated forces of one block's tets in their QR-rotated rest frames, like StVK's: F' = Ds R^-1 =
// F Q^T has the polar rotation R Q^T and the same S up to Q, so
// P' = 2 mu (F' - R') + lambda tr(R'^T F' - I) R' = P Q^T and H = V P' R^-T = V P Dm^-T
// (docs/method.md §2.2); f0 = -(f1 + f2 + f3); added into the block's slots in tet order.
[[gnu::always_inline]] inline void corotated_forces_block(const BlockArgs& a) {
  for (std::int64_t g0 = a.lo; g0 < a.hi; g0 += 4) {
    const int lanes = static_cast<int>(std::min<std::int64_t>(4, a.hi - g0));
    RotatedFrame f;
    load_rotated_frame(a, g0, lanes, &f);
    const PlainLanes* F = f.F;
    PlainLanes R[9];
    lane_polar_rotation(F, lanes, R);
    // V P' = 2 mu V (F' - R') + lambda V (tr(R'^T F') - 3) R'.
    PlainLanes tr = R[0] * F[0];
#pragma GCC unroll 9
    for (int i = 1; i < 9; ++i) tr += R[i] * F[i];
    const PlainLanes vmu2 = f.vol * (2.0 * a.mu), vlt = f.vol * a.lambda * (tr - 3.0);
    PlainLanes P[9];
#pragma GCC unroll 9
    for (int i = 0; i < 9; ++i) P[i] = vmu2 * (F[i] - R[i]) + vlt * R[i];
    PlainLanes out[12];
    rotated_frame_forces(P, f, out);  // H = V P' R^-T
    scatter_corner_forces(out, a.corner_slot, g0, lanes, a.slots);
  }
}

// Each kernel twice: for AVX2, and for the baseline (x86-64-v2 here). Same source, same
// operations, same bits; simd_isa picks one.
#define SHATTER_KERNEL_PAIR(name)                                           \
  [[gnu::target("avx2")]] void name##_avx2(const BlockArgs& a) { name(a); } \
  void name##_baseline(const BlockArgs& a) { name(a); }
SHATTER_KERNEL_PAIR(stvk_forces_block)
SHATTER_KERNEL_PAIR(linear_forces_block)
SHATTER_KERNEL_PAIR(corotated_forces_block)
#undef SHATTER_KERNEL_PAIR

}  // namespace
#undef SHATTER_LOAD
#undef SHATTER_LANE_MAX
#undef SHATTER_LANE_SQRT
#pragma GCC diagnostic pop

FemModel make_fem_model(const TetMesh& rest_mesh, const Material& material, ModelKind kind, const RestSource& from) {
  SHATTER_CHECK(!from.model || (from.model->model == kind && from.tet.size() == rest_mesh.tets.size()));
  FemModel model;
  model.model = kind;
  model.material = material;
  model.lame = lame_parameters(material);
  model.tets = rest_mesh.tets;
  model.num_nodes = rest_mesh.num_nodes();
  const std::size_t n_tets = model.tets.size();
  model.rest.resize(n_tets);
  model.node_mass.assign(static_cast<std::size_t>(model.num_nodes), 0.0);
  model.fast.packed.assign(static_cast<std::size_t>(packed_rows(kind)) * ((n_tets + 3) / 4 * 4), 0.0);
  const int rows = packed_rows(kind);
  for (std::size_t e = 0; e < n_tets; ++e) {
    const Index source = from.model ? from.tet[e] : -1;
    if (source >= 0) {
      const auto s = static_cast<std::size_t>(source);
      SHATTER_CHECK(s < from.model->rest.size());
      model.rest[e] = from.model->rest[s];
      const double* in = from.model->fast.packed.data() + static_cast<std::size_t>(rows) * (s / 4 * 4) + s % 4;
      double* out = model.fast.packed.data() + static_cast<std::size_t>(rows) * (e / 4 * 4) + e % 4;
      for (int row = 0; row < rows; ++row) out[4 * row] = in[4 * row];
    } else {
      model.rest[e] = tet_rest(rest_mesh.corners(static_cast<Index>(e)));
      store_fast_rest(model, e);
    }
    const double m = material.density * model.rest[e].volume / 4.0;  // lumped: rho V / 4 per corner
    for (Index n : model.tets[e]) model.node_mass[static_cast<std::size_t>(n)] += m;
  }
  build_blocks(model);
  return model;
}

void set_tet_rest(FemModel& model, Index e, const Mat34& rest_corners) {
  SHATTER_CHECK(e >= 0 && e < model.num_tets());
  model.rest[static_cast<std::size_t>(e)] = tet_rest(rest_corners);
  store_fast_rest(model, static_cast<std::size_t>(e));
}

void update_rest_shape(FemModel& model, const std::vector<Vec3>& rest_positions,
                       const std::vector<Index>& moved_nodes) {
  SHATTER_CHECK(static_cast<Index>(rest_positions.size()) == model.num_nodes);
  std::vector<char> moved(rest_positions.size(), 0);
  for (Index i : moved_nodes) moved[static_cast<std::size_t>(i)] = 1;
  for (Index e = 0; e < model.num_tets(); ++e) {
    const TetIndices& t = model.tets[static_cast<std::size_t>(e)];
    if (!moved[t[0]] && !moved[t[1]] && !moved[t[2]] && !moved[t[3]]) continue;
    Mat34 corners;
    for (int k = 0; k < 4; ++k) corners.col(k) = rest_positions[static_cast<std::size_t>(t[k])];
    set_tet_rest(model, e, corners);
  }
}

void internal_forces_reference(const FemModel& model, const std::vector<Vec3>& x, std::vector<Vec3>& f) {
  SHATTER_CHECK(static_cast<Index>(x.size()) == model.num_nodes);
  f.assign(x.size(), Vec3::Zero());
  for (std::size_t e = 0; e < model.tets.size(); ++e) {
    const TetIndices& t = model.tets[e];
    Mat34 xe;
    for (int k = 0; k < 4; ++k) xe.col(k) = x[static_cast<std::size_t>(t[k])];
    const Mat34 fe = tet_internal_forces(model.model, model.lame, model.rest[e], xe);
    for (int k = 0; k < 4; ++k) f[static_cast<std::size_t>(t[k])] += fe.col(k);
  }
}

void internal_forces(const FemModel& model, const std::vector<Vec3>& x, std::vector<Vec3>& f) {
  ForceWorkspace workspace;
  internal_forces(model, x, f, workspace);
}

void internal_forces(const FemModel& model, const std::vector<Vec3>& x, std::vector<Vec3>& f,
                     ForceWorkspace& workspace) {
  SHATTER_CHECK(static_cast<Index>(x.size()) == model.num_nodes);
  const FastTetData& fd = model.fast;
  const std::int64_t n_tets = model.num_tets();
  const std::int64_t n_blocks = static_cast<std::int64_t>(fd.block_slot_begin.size()) - 1;
  std::vector<double>& scratch = workspace.slots;  // 4 doubles per slot, N
  const std::size_t n_slots = static_cast<std::size_t>(fd.block_slot_begin.back());
  if (scratch.size() < 4 * n_slots) scratch.resize(4 * n_slots);
  double* acc = scratch.data();
  const Vec3* xp = x.data();
  using Kernel = void (*)(const BlockArgs&);
  const bool avx2 = simd_isa() == SimdIsa::avx2;
  Kernel kernel = nullptr;
  if (model.model == ModelKind::stvk) kernel = avx2 ? stvk_forces_block_avx2 : stvk_forces_block_baseline;
  if (model.model == ModelKind::linear) kernel = avx2 ? linear_forces_block_avx2 : linear_forces_block_baseline;
  if (model.model == ModelKind::corotated)
    kernel = avx2 ? corotated_forces_block_avx2 : corotated_forces_block_baseline;
  // 1. Per block, in tet order: tet forces added into the block's own slots.
  parallel_for(
      0, n_blocks,
      [&](std::int64_t b) {
        double* slots = acc + 4 * fd.block_slot_begin[static_cast<std::size_t>(b)];
        const std::int64_t n_block_slots =
            fd.block_slot_begin[static_cast<std::size_t>(b) + 1] - fd.block_slot_begin[static_cast<std::size_t>(b)];
        std::fill(slots, slots + 4 * n_block_slots, 0.0);
        const std::int64_t lo = b * fd.block_size, hi = std::min(n_tets, lo + fd.block_size);
        if (kernel != nullptr) {
          kernel(BlockArgs{.packed = fd.packed.data(),
                           .tets = model.tets.data(),
                           .corner_slot = fd.corner_slot.data(),
                           .x = xp,
                           .last_node = model.num_nodes - 1,
                           .lo = lo,
                           .hi = hi,
                           .mu = model.lame.mu,
                           .lambda = model.lame.lambda,
                           .slots = slots});
          return;
        }
        for (std::int64_t e = lo; e < hi; ++e) {
          const TetIndices& t = model.tets[static_cast<std::size_t>(e)];
          Mat34 xe;
          for (int k = 0; k < 4; ++k) xe.col(k) = xp[t[k]];
          const Mat34 fe = tet_internal_forces(model.model, model.lame, model.rest[static_cast<std::size_t>(e)], xe);
          for (int k = 0; k < 4; ++k) {
            double* s = slots + fd.corner_slot[static_cast<std::size_t>(4 * e + k)];
            s[0] += fe(0, k);
            s[1] += fe(1, k);
            s[2] += fe(2, k);
          }
        }
      },
      2);
  // 2. Per node: its slots' sums in block order.
  f.resize(x.size());
  parallel_for(0, model.num_nodes, [&](std::int64_t n) {
    double sx = 0, sy = 0, sz = 0;
    for (std::int64_t i = fd.node_entry_begin[static_cast<std::size_t>(n)];
         i < fd.node_entry_begin[static_cast<std::size_t>(n) + 1]; ++i) {
      const double* s = acc + 4 * fd.node_entry_slot[static_cast<std::size_t>(i)];
      sx += s[0];
      sy += s[1];
      sz += s[2];
    }
    f[static_cast<std::size_t>(n)] = Vec3(sx, sy, sz);
  });
}

double total_energy(const FemModel& model, const std::vector<Vec3>& x) {
  SHATTER_CHECK(static_cast<Index>(x.size()) == model.num_nodes);
  const std::int64_t n_tets = model.num_tets();
  if (model.model == ModelKind::stvk) {
    // V (mu tr(E'^2) + lambda/2 tr(E')^2) with E' = (F'^T F' - I)/2 and F' = Ds R^-1 (rotated rest
    // frame, see FastTetData).
    const double* packed = model.fast.packed.data();
    const double mu = model.lame.mu, half_lambda = 0.5 * model.lame.lambda;
    return parallel_sum(0, n_tets, 0.0, [&](std::int64_t e) {
      const TetIndices& t = model.tets[static_cast<std::size_t>(e)];
      const double* r = packed + 7 * (e / 4 * 4) + e % 4;
      const double r00 = r[0], r01 = r[4], r02 = r[8], r11 = r[12], r12 = r[16], r22 = r[20];
      const Vec3 d0 = x[t[1]] - x[t[0]], d1 = x[t[2]] - x[t[0]], d2 = x[t[3]] - x[t[0]];
      const Vec3 a = d0 * r00, b = d0 * r01 + d1 * r11, c = d0 * r02 + d1 * r12 + d2 * r22;
      const double eaa = 0.5 * (a.dot(a) - 1.0), ebb = 0.5 * (b.dot(b) - 1.0), ecc = 0.5 * (c.dot(c) - 1.0);
      const double eab = 0.5 * a.dot(b), eac = 0.5 * a.dot(c), ebc = 0.5 * b.dot(c);
      const double tr = eaa + ebb + ecc;
      const double e2 = eaa * eaa + ebb * ebb + ecc * ecc + 2.0 * (eab * eab + eac * eac + ebc * ebc);
      return r[24] * (mu * e2 + half_lambda * tr * tr);
    });
  }
  return parallel_sum(0, n_tets, 0.0, [&](std::int64_t e) {
    const TetIndices& t = model.tets[static_cast<std::size_t>(e)];
    Mat34 xe;
    for (int k = 0; k < 4; ++k) xe.col(k) = x[static_cast<std::size_t>(t[k])];
    return tet_energy(model.model, model.lame, model.rest[static_cast<std::size_t>(e)], xe);
  });
}

}  // namespace shatter
