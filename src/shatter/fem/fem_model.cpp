// FemModel construction and the global internal force: a straightforward reference and a fast path
// (QR-rotated rest frames, specialised StVK code, fixed blocks with a deterministic gather).
#include "shatter/fem/fem_model.h"

#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <cmath>

#include "shatter/core/parallel.h"

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
        fd.corner_slot[static_cast<std::size_t>(4 * e + k)] = 3 * local[n];
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
// -ffp-contract=off each lane is computed exactly as the scalar formula would be, so the SSE2 and AVX2
// versions give the same bits).
// Vectors only live inside the force kernels (loads are built in place; the always-inlined helpers
// take them by pointer), so none crosses a call by value; GCC's -Wpsabi warns about the call ABI of
// such vectors.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
typedef double Lanes __attribute__((vector_size(4 * sizeof(double))));

// The kernels' shared steps. Always inlined into each target clone (the AVX2 clone then
// compiles them for AVX2 too); they take vectors only by pointer.

// c[lane][corner]: the corners of tets g0 .. g0 + 3; padding lanes repeat the first tet.
[[gnu::always_inline]] inline void gather_corners(const TetIndices* tets, const Vec3* x, std::int64_t g0, int lanes,
                                                  const Vec3* (&c)[4][4]) {
  for (int l = 0; l < 4; ++l) {
    const TetIndices& t = tets[g0 + (l < lanes ? l : 0)];
    for (int k = 0; k < 4; ++k) c[l][k] = &x[t[k]];
  }
}

// Add the corner forces out[3 k + axis] (one lane per tet) into the block's slots, in tet order.
[[gnu::always_inline]] inline void scatter_corner_forces(const Lanes* out, const std::int32_t* corner_slot,
                                                         std::int64_t g0, int lanes, double* slots) {
  for (int l = 0; l < lanes; ++l) {
    const std::int32_t* cs = corner_slot + 4 * (g0 + l);
    for (int k = 0; k < 4; ++k) {
      double* s = slots + cs[k];
      s[0] += out[3 * k][l];
      s[1] += out[3 * k + 1][l];
      s[2] += out[3 * k + 2][l];
    }
  }
}

// Lane-wise comparisons give a mask of 0 / -1 per lane.
typedef long long LaneMask __attribute__((vector_size(4 * sizeof(long long))));

// Lane-wise max and square root; a and b are plain names (each is read more than once). Macros, as
// no helper here returns a vector by value (see above).
#define SHATTER_LANE_MAX(a, b) ((a) > (b) ? (a) : (b))
#define SHATTER_LANE_SQRT(a) \
  Lanes { std::sqrt((a)[0]), std::sqrt((a)[1]), std::sqrt((a)[2]), std::sqrt((a)[3]) }

// m = max_ij |a_ij - b_ij| of two 3x3 matrices (row-major, nine lane vectors each).
[[gnu::always_inline]] inline void lane_max_abs_difference(const Lanes* a, const Lanes* b, Lanes* m) {
  *m = Lanes{0, 0, 0, 0};
  for (int i = 0; i < 9; ++i) {
    const Lanes d = a[i] - b[i];
    const Lanes nd = -d;
    const Lanes ad = SHATTER_LANE_MAX(d, nd);
    *m = SHATTER_LANE_MAX(*m, ad);
  }
}
// y = x^-T of a 3x3 matrix per lane (row-major) and det x: with a, b, c the columns of x,
// x^-T = [b x c, c x a, a x b] / det.
[[gnu::always_inline]] inline void lane_inverse_transpose(const Lanes* x, Lanes* y, Lanes* det) {
  const Lanes bc0 = x[4] * x[8] - x[7] * x[5], bc1 = x[7] * x[2] - x[1] * x[8], bc2 = x[1] * x[5] - x[4] * x[2];
  const Lanes ca0 = x[5] * x[6] - x[8] * x[3], ca1 = x[8] * x[0] - x[2] * x[6], ca2 = x[2] * x[3] - x[5] * x[0];
  const Lanes ab0 = x[3] * x[7] - x[6] * x[4], ab1 = x[6] * x[1] - x[0] * x[7], ab2 = x[0] * x[4] - x[3] * x[1];
  *det = x[0] * bc0 + x[3] * bc1 + x[6] * bc2;
  const Lanes inv = 1.0 / *det;
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
[[gnu::always_inline]] inline void lane_polar_rotation(const Lanes* F, int lanes, Lanes* R) {
  Lanes scale = Lanes{0, 0, 0, 0};
  for (int i = 0; i < 9; ++i) {
    const Lanes nf = -F[i];
    const Lanes af = SHATTER_LANE_MAX(F[i], nf);
    scale = SHATTER_LANE_MAX(scale, af);
  }
  Lanes X[9], Y[9], det;
  for (int i = 0; i < 9; ++i) X[i] = F[i];
  LaneMask ok{};
  bool converged = false, fixed_steps = false;
  // Near a rotation (every stiff body under load), a fixed count of plain steps suffices and no step
  // needs checking. With F = U (I + E) and m = max|F^T F - I|, |E| <= 1.6 m for m <= 0.03, and a
  // plain step maps |E| to at most |E|^2 / (2 (1 - |E|)): from |E| <= 0.05, four steps reach 1e-25
  // (round-off); from |E| <= 1e-3, three.
  {
    const Lanes c00 = F[0] * F[0] + F[3] * F[3] + F[6] * F[6], c11 = F[1] * F[1] + F[4] * F[4] + F[7] * F[7],
                c22 = F[2] * F[2] + F[5] * F[5] + F[8] * F[8], c01 = F[0] * F[1] + F[3] * F[4] + F[6] * F[7],
                c02 = F[0] * F[2] + F[3] * F[5] + F[6] * F[8], c12 = F[1] * F[2] + F[4] * F[5] + F[7] * F[8];
    const Lanes defect[6] = {c00 - 1.0, c11 - 1.0, c22 - 1.0, c01, c02, c12};
    Lanes m = Lanes{0, 0, 0, 0};
    for (const Lanes& d : defect) {
      const Lanes nd = -d;
      const Lanes ad = SHATTER_LANE_MAX(d, nd);
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
    Lanes change0, change;
    lane_max_abs_difference(X, Y, &change0);
    Lanes nx = X[0] * X[0], ny = Y[0] * Y[0];
    for (int i = 1; i < 9; ++i) nx += X[i] * X[i], ny += Y[i] * Y[i];
    const Lanes ratio = ny / nx;
    const Lanes root2 = SHATTER_LANE_SQRT(ratio);
    const Lanes root4 = SHATTER_LANE_SQRT(root2);
    const Lanes one = Lanes{1, 1, 1, 1};
    const Lanes z = change0 > 1e-2 ? root4 : one;
    const Lanes zi = 1.0 / z;
    Lanes next[9];
    for (int i = 0; i < 9; ++i) next[i] = 0.5 * (z * X[i] + Y[i] * zi);
    lane_max_abs_difference(next, X, &change);
    for (int i = 0; i < 9; ++i) X[i] = next[i];
    const LaneMask done = (change <= 1e-8) | ~ok;  // failed lanes are left to the fallback
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

// Edge k - 0 of each lane's tet along axis a (Ds built in registers: no store-to-load forwarding
// stalls), and four consecutive packed values as one lane vector.
// clang-format off
#define SHATTER_EDGE(k, a) \
  Lanes{(*c[0][k])[a] - (*c[0][0])[a], (*c[1][k])[a] - (*c[1][0])[a], \
        (*c[2][k])[a] - (*c[2][0])[a], (*c[3][k])[a] - (*c[3][0])[a]}
#define SHATTER_LOAD(p) Lanes{(p)[0], (p)[1], (p)[2], (p)[3]}
// clang-format on

namespace {

// A group of four tets in their QR-rotated rest frames (StVK and corotated): R^-1 (upper
// triangular), the rest volume V and F' = Ds R^-1 row-major, whose columns are a = d0 r00,
// b = d0 r01 + d1 r11 and c = d0 r02 + d1 r12 + d2 r22 for the edges d_k = x_{k+1} - x_0.
struct RotatedFrame {
  Lanes r00, r01, r02, r11, r12, r22, vol;
  Lanes F[9];
};

[[gnu::always_inline]] inline void load_rotated_frame(const double* packed, const Vec3* (&c)[4][4], std::int64_t g0,
                                                      RotatedFrame* f) {
  const double* r = packed + 7 * g0;  // 7 lane vectors per group of 4 tets
  f->r00 = SHATTER_LOAD(r), f->r01 = SHATTER_LOAD(r + 4), f->r02 = SHATTER_LOAD(r + 8);
  f->r11 = SHATTER_LOAD(r + 12), f->r12 = SHATTER_LOAD(r + 16), f->r22 = SHATTER_LOAD(r + 20);
  f->vol = SHATTER_LOAD(r + 24);
  const Lanes d0x = SHATTER_EDGE(1, 0), d0y = SHATTER_EDGE(1, 1), d0z = SHATTER_EDGE(1, 2);
  const Lanes d1x = SHATTER_EDGE(2, 0), d1y = SHATTER_EDGE(2, 1), d1z = SHATTER_EDGE(2, 2);
  const Lanes d2x = SHATTER_EDGE(3, 0), d2y = SHATTER_EDGE(3, 1), d2z = SHATTER_EDGE(3, 2);
  const Lanes &r00 = f->r00, &r01 = f->r01, &r02 = f->r02, &r11 = f->r11, &r12 = f->r12, &r22 = f->r22;
  f->F[0] = d0x * r00, f->F[1] = d0x * r01 + d1x * r11, f->F[2] = d0x * r02 + d1x * r12 + d2x * r22;
  f->F[3] = d0y * r00, f->F[4] = d0y * r01 + d1y * r11, f->F[5] = d0y * r02 + d1y * r12 + d2y * r22;
  f->F[6] = d0z * r00, f->F[7] = d0z * r01 + d1z * r11, f->F[8] = d0z * r02 + d1z * r12 + d2z * r22;
}

// The corner forces out[3 k + axis] from M = V P' (row-major): [f1 f2 f3] = M R^-T with R^-1
// upper triangular, f0 = -(f1 + f2 + f3).
[[gnu::always_inline]] inline void rotated_frame_forces(const Lanes* M, const RotatedFrame& f, Lanes* out) {
  const Lanes f1x = M[0] * f.r00 + M[1] * f.r01 + M[2] * f.r02, f1y = M[3] * f.r00 + M[4] * f.r01 + M[5] * f.r02,
              f1z = M[6] * f.r00 + M[7] * f.r01 + M[8] * f.r02;
  const Lanes f2x = M[1] * f.r11 + M[2] * f.r12, f2y = M[4] * f.r11 + M[5] * f.r12, f2z = M[7] * f.r11 + M[8] * f.r12;
  const Lanes f3x = M[2] * f.r22, f3y = M[5] * f.r22, f3z = M[8] * f.r22;
  out[0] = -(f1x + f2x + f3x), out[1] = -(f1y + f2y + f3y), out[2] = -(f1z + f2z + f3z);
  out[3] = f1x, out[4] = f1y, out[5] = f1z, out[6] = f2x, out[7] = f2y, out[8] = f2z;
  out[9] = f3x, out[10] = f3y, out[11] = f3z;
}

}  // namespace

namespace detail {

// StVK forces of the tets [lo, hi) of one block (lo a multiple of 4) in their QR-rotated rest frames
// (docs/method.md §2.1-2.2, §3): F' = Ds R^-1, S' = 2 mu E' + lambda tr(E') I, H = V F' S' R^-T,
// [f1 f2 f3] = H, f0 = -(f1 + f2 + f3); added into the block's slots in tet order.
[[gnu::target_clones("avx2", "default")]]
void stvk_forces_block(const double* packed, const TetIndices* tets, const std::int32_t* corner_slot, const Vec3* x,
                       std::int64_t lo, std::int64_t hi, double mu, double lambda, double* slots) {
  for (std::int64_t g0 = lo; g0 < hi; g0 += 4) {
    const int lanes = static_cast<int>(std::min<std::int64_t>(4, hi - g0));
    const Vec3* c[4][4];  // [lane][corner]
    gather_corners(tets, x, g0, lanes, c);
    RotatedFrame f;
    load_rotated_frame(packed, c, g0, &f);
    const Lanes& vol = f.vol;
    // F' columns a, b, c.
    const Lanes &ax = f.F[0], &bx = f.F[1], &cx = f.F[2], &ay = f.F[3], &by = f.F[4], &cy = f.F[5], &az = f.F[6],
                &bz = f.F[7], &cz = f.F[8];
    // C = F'^T F'.
    const Lanes caa = ax * ax + ay * ay + az * az, cbb = bx * bx + by * by + bz * bz, ccc = cx * cx + cy * cy + cz * cz;
    const Lanes cab = ax * bx + ay * by + az * bz, cac = ax * cx + ay * cy + az * cz, cbc = bx * cx + by * cy + bz * cz;
    // V S' = V (mu (C - I) + lambda/2 (tr C - 3) I).
    const Lanes vmu = vol * mu, vlh = vol * (0.5 * lambda);
    const Lanes ltr = vlh * (caa + cbb + ccc - 3.0);
    const Lanes shift = ltr - vmu;
    const Lanes saa = vmu * caa + shift, sbb = vmu * cbb + shift, scc = vmu * ccc + shift;
    const Lanes sab = vmu * cab, sac = vmu * cac, sbc = vmu * cbc;
    // F' (V S'), columns p, q, s.
    const Lanes px = ax * saa + bx * sab + cx * sac, py = ay * saa + by * sab + cy * sac,
                pz = az * saa + bz * sab + cz * sac;
    const Lanes qx = ax * sab + bx * sbb + cx * sbc, qy = ay * sab + by * sbb + cy * sbc,
                qz = az * sab + bz * sbb + cz * sbc;
    const Lanes sx = ax * sac + bx * sbc + cx * scc, sy = ay * sac + by * sbc + cy * scc,
                sz = az * sac + bz * sbc + cz * scc;
    // H = F' V S' R^-T (columns p, q, s of F' V S').
    const Lanes M[9] = {px, qx, sx, py, qy, sy, pz, qz, sz};
    Lanes out[12];
    rotated_frame_forces(M, f, out);
    scatter_corner_forces(out, corner_slot, g0, lanes, slots);
  }
}

// Linear (small-strain) forces of the tets [lo, hi) of one block (lo a multiple of 4): F = Ds Dm^-1,
// eps = (F + F^T)/2 - I, V P = V (2 mu eps + lambda tr(eps) I), [f1 f2 f3] = V P Dm^-T,
// f0 = -(f1 + f2 + f3); added into the block's slots in tet order (docs/method.md §2.2).
[[gnu::target_clones("avx2", "default")]]
void linear_forces_block(const double* packed, const TetIndices* tets, const std::int32_t* corner_slot, const Vec3* x,
                         std::int64_t lo, std::int64_t hi, double mu, double lambda, double* slots) {
  for (std::int64_t g0 = lo; g0 < hi; g0 += 4) {
    const int lanes = static_cast<int>(std::min<std::int64_t>(4, hi - g0));
    const Vec3* c[4][4];  // [lane][corner]
    gather_corners(tets, x, g0, lanes, c);
    const double* r = packed + 10 * g0;  // 10 lane vectors per group of 4 tets
    // M = Dm^-1, row-major.
    const Lanes m00 = SHATTER_LOAD(r), m01 = SHATTER_LOAD(r + 4), m02 = SHATTER_LOAD(r + 8);
    const Lanes m10 = SHATTER_LOAD(r + 12), m11 = SHATTER_LOAD(r + 16), m12 = SHATTER_LOAD(r + 20);
    const Lanes m20 = SHATTER_LOAD(r + 24), m21 = SHATTER_LOAD(r + 28), m22 = SHATTER_LOAD(r + 32);
    const Lanes vol = SHATTER_LOAD(r + 36);
    // Ds columns d0 d1 d2 (edges from corner 0).
    const Lanes d0x = SHATTER_EDGE(1, 0), d0y = SHATTER_EDGE(1, 1), d0z = SHATTER_EDGE(1, 2);
    const Lanes d1x = SHATTER_EDGE(2, 0), d1y = SHATTER_EDGE(2, 1), d1z = SHATTER_EDGE(2, 2);
    const Lanes d2x = SHATTER_EDGE(3, 0), d2y = SHATTER_EDGE(3, 1), d2z = SHATTER_EDGE(3, 2);
    // F = Ds M: F(i, j) = d0_i m0j + d1_i m1j + d2_i m2j.
    const Lanes fxx = d0x * m00 + d1x * m10 + d2x * m20, fxy = d0x * m01 + d1x * m11 + d2x * m21,
                fxz = d0x * m02 + d1x * m12 + d2x * m22;
    const Lanes fyx = d0y * m00 + d1y * m10 + d2y * m20, fyy = d0y * m01 + d1y * m11 + d2y * m21,
                fyz = d0y * m02 + d1y * m12 + d2y * m22;
    const Lanes fzx = d0z * m00 + d1z * m10 + d2z * m20, fzy = d0z * m01 + d1z * m11 + d2z * m21,
                fzz = d0z * m02 + d1z * m12 + d2z * m22;
    // V P, symmetric: diagonal 2 mu V (F_ii - 1) + lambda V tr(eps), off-diagonal mu V (F_ij + F_ji).
    const Lanes vmu = vol * mu, vl = vol * lambda;
    const Lanes ltr = vl * ((fxx - 1.0) + (fyy - 1.0) + (fzz - 1.0));
    const Lanes pxx = 2.0 * vmu * (fxx - 1.0) + ltr, pyy = 2.0 * vmu * (fyy - 1.0) + ltr,
                pzz = 2.0 * vmu * (fzz - 1.0) + ltr;
    const Lanes pxy = vmu * (fxy + fyx), pxz = vmu * (fxz + fzx), pyz = vmu * (fyz + fzy);
    // f_k (k = 1, 2, 3) = V P M^T column k-1, i.e. V P (row k-1 of M).
    const Lanes f1x = pxx * m00 + pxy * m01 + pxz * m02, f1y = pxy * m00 + pyy * m01 + pyz * m02,
                f1z = pxz * m00 + pyz * m01 + pzz * m02;
    const Lanes f2x = pxx * m10 + pxy * m11 + pxz * m12, f2y = pxy * m10 + pyy * m11 + pyz * m12,
                f2z = pxz * m10 + pyz * m11 + pzz * m12;
    const Lanes f3x = pxx * m20 + pxy * m21 + pxz * m22, f3y = pxy * m20 + pyy * m21 + pyz * m22,
                f3z = pxz * m20 + pyz * m21 + pzz * m22;
    const Lanes out[12] = {
        -(f1x + f2x + f3x), -(f1y + f2y + f3y), -(f1z + f2z + f3z), f1x, f1y, f1z, f2x, f2y, f2z, f3x, f3y, f3z};
    scatter_corner_forces(out, corner_slot, g0, lanes, slots);
  }
}

// Corotated forces of the tets [lo, hi) of one block (lo a multiple of 4) in their QR-rotated rest
// frames, like StVK's: F' = Ds R^-1 = F Q^T has the polar rotation R Q^T and the same S up to Q,
// so P' = 2 mu (F' - R') + lambda tr(R'^T F' - I) R' = P Q^T and H = V P' R^-T = V P Dm^-T
// (docs/method.md §2.2); f0 = -(f1 + f2 + f3); added into the block's slots in tet order.
[[gnu::target_clones("avx2", "default")]]
void corotated_forces_block(const double* packed, const TetIndices* tets, const std::int32_t* corner_slot,
                            const Vec3* x, std::int64_t lo, std::int64_t hi, double mu, double lambda, double* slots) {
  for (std::int64_t g0 = lo; g0 < hi; g0 += 4) {
    const int lanes = static_cast<int>(std::min<std::int64_t>(4, hi - g0));
    const Vec3* c[4][4];  // [lane][corner]
    gather_corners(tets, x, g0, lanes, c);
    RotatedFrame f;
    load_rotated_frame(packed, c, g0, &f);
    const Lanes* F = f.F;
    Lanes R[9];
    lane_polar_rotation(F, lanes, R);
    // V P' = 2 mu V (F' - R') + lambda V (tr(R'^T F') - 3) R'.
    Lanes tr = R[0] * F[0];
    for (int i = 1; i < 9; ++i) tr += R[i] * F[i];
    const Lanes vmu2 = f.vol * (2.0 * mu), vlt = f.vol * lambda * (tr - 3.0);
    Lanes P[9];
    for (int i = 0; i < 9; ++i) P[i] = vmu2 * (F[i] - R[i]) + vlt * R[i];
    Lanes out[12];
    rotated_frame_forces(P, f, out);  // H = V P' R^-T
    scatter_corner_forces(out, corner_slot, g0, lanes, slots);
  }
}

}  // namespace detail
#undef SHATTER_EDGE
#undef SHATTER_LOAD
#undef SHATTER_LANE_MAX
#undef SHATTER_LANE_SQRT
#pragma GCC diagnostic pop

FemModel make_fem_model(const TetMesh& rest_mesh, const Material& material, ModelKind kind) {
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
  for (std::size_t e = 0; e < n_tets; ++e) {
    const TetRest r = tet_rest(rest_mesh.corners(static_cast<Index>(e)));
    model.rest[e] = r;
    const double m = material.density * r.volume / 4.0;  // lumped: rho V / 4 per corner
    for (Index n : model.tets[e]) model.node_mass[static_cast<std::size_t>(n)] += m;
    store_fast_rest(model, e);
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
  std::vector<double>& scratch = workspace.slots;  // 3 doubles per slot, N
  const std::size_t n_slots = static_cast<std::size_t>(fd.block_slot_begin.back());
  if (scratch.size() < 3 * n_slots) scratch.resize(3 * n_slots);
  double* acc = scratch.data();
  const Vec3* xp = x.data();
  // 1. Per block, in tet order: tet forces added into the block's own slots.
  parallel_for(
      0, n_blocks,
      [&](std::int64_t b) {
        double* slots = acc + 3 * fd.block_slot_begin[static_cast<std::size_t>(b)];
        const std::int64_t n_block_slots =
            fd.block_slot_begin[static_cast<std::size_t>(b) + 1] - fd.block_slot_begin[static_cast<std::size_t>(b)];
        std::fill(slots, slots + 3 * n_block_slots, 0.0);
        const std::int64_t lo = b * fd.block_size, hi = std::min(n_tets, lo + fd.block_size);
        if (model.model == ModelKind::stvk) {
          detail::stvk_forces_block(fd.packed.data(), model.tets.data(), fd.corner_slot.data(), xp, lo, hi,
                                    model.lame.mu, model.lame.lambda, slots);
          return;
        }
        if (model.model == ModelKind::linear) {
          detail::linear_forces_block(fd.packed.data(), model.tets.data(), fd.corner_slot.data(), xp, lo, hi,
                                      model.lame.mu, model.lame.lambda, slots);
          return;
        }
        if (model.model == ModelKind::corotated) {
          detail::corotated_forces_block(fd.packed.data(), model.tets.data(), fd.corner_slot.data(), xp, lo, hi,
                                         model.lame.mu, model.lame.lambda, slots);
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
      const double* s = acc + 3 * fd.node_entry_slot[static_cast<std::size_t>(i)];
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
