// Constant-strain tet kernels (docs/method.md §2.2-2.3) and stress analysis helpers.
#include "shatter/fem/tet_kernels.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <cmath>

#include "shatter/core/assert.h"
#include "shatter/core/lanes.h"
#include "shatter/core/simd.h"

namespace shatter {

TetRest tet_rest(const Mat34& rest_corners) {
  Mat3 Dm;
  for (int k = 0; k < 3; ++k) Dm.col(k) = rest_corners.col(k + 1) - rest_corners.col(0);
  TetRest r;
  r.Dm_inv = Dm.inverse();
  r.volume = Dm.determinant() / 6.0;
  return r;
}

Mat43 shape_gradients(const TetRest& rest) {
  // b_j(u) for j = 1..3 is row j-1 of Dm^-1 (u - m0); b_0 = 1 - b_1 - b_2 - b_3.
  Mat43 B;
  B.row(0) = -rest.Dm_inv.colwise().sum();
  B.bottomRows<3>() = rest.Dm_inv;
  return B;
}

// Flattened: GCC at -O2 leaves the 3x3 product as a call (same operations either way).
[[gnu::flatten]] Mat3 deformation_gradient(const TetRest& rest, const Mat34& x) {
  Mat3 Ds;
  for (int k = 0; k < 3; ++k) Ds.col(k) = x.col(k + 1) - x.col(0);
  return Ds * rest.Dm_inv;  // F = Ds Dm^-1
}

double tet_energy(ModelKind kind, const Lame& lame, const TetRest& rest, const Mat34& x) {
  return rest.volume * energy_density(kind, lame, deformation_gradient(rest, x));
}

Mat34 tet_internal_forces(ModelKind kind, const Lame& lame, const TetRest& rest, const Mat34& x) {
  return tet_forces_from_stress(rest, first_piola(kind, lame, deformation_gradient(rest, x)));
}

Mat34 tet_forces_from_stress(const TetRest& rest, const Mat3& P) {
  const Mat3 H = rest.volume * P * rest.Dm_inv.transpose();  // [f1 f2 f3] = V P Dm^-T
  Mat34 f;
  f.rightCols<3>() = H;
  f.col(0) = -H.rowwise().sum();
  return f;
}

namespace {

// 3x3 blocks K_ij for StVK, from dP = dF S + F dS with dF = e_b g_j^T (docs/method.md §2.3):
// K_ij = V [ (g_i^T S g_j) I + mu u_j u_i^T + mu (g_i . g_j) F F^T + lambda u_i u_j^T ],
// with g_i = grad b_i and u_i = F g_i. K_ji = K_ij^T, so K is symmetric by construction.
// The linear model is the case F = I, S = 0.
// (Not inlined: flattened into its callers it runs 1.3-1.6x slower.)
[[gnu::noinline]] Mat12 stiffness_closed_form(const Lame& lame, double volume, const Mat43& B, const Mat3& F,
                                              const Mat3& S) {
  const Mat3 FFt = F * F.transpose();
  Mat34 u;
  for (int i = 0; i < 4; ++i) u.col(i) = F * B.row(i).transpose();
  const Mat43 SB = B * S;  // row i = (S g_i)^T
  Mat12 K;
  for (int i = 0; i < 4; ++i) {
    for (int j = i; j < 4; ++j) {
      const Vec3 gi = B.row(i).transpose(), gj = B.row(j).transpose();
      const Mat3 block = volume * (SB.row(i).dot(gj) * Mat3::Identity() + lame.mu * u.col(j) * u.col(i).transpose() +
                                   lame.mu * gi.dot(gj) * FFt + lame.lambda * u.col(i) * u.col(j).transpose());
      K.block<3, 3>(3 * i, 3 * j) = block;
      if (j != i) K.block<3, 3>(3 * j, 3 * i) = block.transpose();
    }
  }
  return K;
}

// Corotated blocks in closed form, from dP = 2 mu dF + lambda tr(R^T dF) R + c dR with
// c = lambda tr(S - I) - 2 mu and dR = R [w]x, (tr(S) I - S) w = axial(R^T dF - dF^T R)
// (first_piola_differential). For the column dF = e_b g_j^T (corner j moved along axis b) the
// axial vector is g_j x r_b with r_b = R^T e_b, and the c term of dP g_i is c R (w x g_i). Over the
// three axes b that gives, with g_i = grad b_i, u_i = R g_i and A_i = R [g_i]x:
//   K_ij = V [ 2 mu (g_i . g_j) I + lambda u_i u_j^T + A_i M A_j^T ],  M = c (tr(S) I - S)^-1.
// At rest (R = I, S = I, M = -mu I) this is linear elasticity's mu (g_i . g_j) I + mu g_j g_i^T +
// lambda g_i g_j^T. The upper blocks are computed and the lower ones are their transposes, so K is
// symmetric to the last bit. M is the only part that the projection changes (corotated_mode_matrix).
[[gnu::always_inline]] inline Mat12 corotated_blocks(const Lame& lame, const TetRest& rest, const Mat3& R,
                                                     const Mat3& M) {
  // Written out on plain arrays, the blocks' loops unrolled: as Eigen expressions GCC left the 3x3
  // products as calls, and at -O2 it does not unroll the loops (938 against 440-570 ns per tet).
  const Mat43 B = shape_gradients(rest);
  double g[4][3], u[4][3], A[4][3][3], AM[4][3][3];
  for (int i = 0; i < 4; ++i) {
    for (int k = 0; k < 3; ++k) g[i][k] = B(i, k);
    for (int a = 0; a < 3; ++a) {
      u[i][a] = R(a, 0) * g[i][0] + R(a, 1) * g[i][1] + R(a, 2) * g[i][2];
      // Row a of R [g]x: column k is R (g x e_k).
      A[i][a][0] = g[i][2] * R(a, 1) - g[i][1] * R(a, 2);
      A[i][a][1] = g[i][0] * R(a, 2) - g[i][2] * R(a, 0);
      A[i][a][2] = g[i][1] * R(a, 0) - g[i][0] * R(a, 1);
    }
    for (int a = 0; a < 3; ++a)
      for (int k = 0; k < 3; ++k) AM[i][a][k] = A[i][a][0] * M(0, k) + A[i][a][1] * M(1, k) + A[i][a][2] * M(2, k);
  }
  const double V = rest.volume, two_mu = 2.0 * lame.mu, lambda = lame.lambda;
  Mat12 K;
  for (int i = 0; i < 4; ++i) {
    for (int j = i; j < 4; ++j) {
      const double diagonal = two_mu * (g[i][0] * g[j][0] + g[i][1] * g[j][1] + g[i][2] * g[j][2]);
      double block[3][3];
#pragma GCC unroll 3
      for (int a = 0; a < 3; ++a)
#pragma GCC unroll 3
        for (int b = 0; b < 3; ++b)
          block[a][b] = V * (AM[i][a][0] * A[j][b][0] + AM[i][a][1] * A[j][b][1] + AM[i][a][2] * A[j][b][2] +
                             lambda * u[i][a] * u[j][b] + (a == b ? diagonal : 0.0));
#pragma GCC unroll 3
      for (int a = 0; a < 3; ++a)
#pragma GCC unroll 3
        for (int b = 0; b < 3; ++b) {
          // A diagonal block's two triangles are the same sums in another order: averaged.
          const double v = j == i ? 0.5 * (block[a][b] + block[b][a]) : block[a][b];
          K(3 * i + a, 3 * j + b) = v;
          K(3 * j + b, 3 * i + a) = v;
        }
    }
  }
  return K;
}

}  // namespace

[[gnu::flatten]] Mat12 corotated_stiffness(const Lame& lame, const TetRest& rest, const Polar& p) {
  const double c = lame.lambda * (p.S.trace() - 3.0) - 2.0 * lame.mu;
  const Mat3 G_inv = (p.S.trace() * Mat3::Identity() - p.S).inverse();
  return corotated_blocks(lame, rest, p.R, c * 0.5 * (G_inv + G_inv.transpose()));
}

Mat12 tet_stiffness_from_differential(ModelKind kind, const Lame& lame, const TetRest& rest, const Mat34& x) {
  const Mat3 F = deformation_gradient(rest, x);
  const Mat43 B = shape_gradients(rest);
  Mat12 K;
  for (int j = 0; j < 4; ++j) {
    for (int b = 0; b < 3; ++b) {
      // Unit displacement of corner j along axis b: dF = e_b grad(b_j)^T.
      Mat3 dF = Mat3::Zero();
      dF.row(b) = B.row(j);
      const Mat3 dH = rest.volume * first_piola_differential(kind, lame, F, dF) * rest.Dm_inv.transpose();
      K.block<3, 1>(0, 3 * j + b) = -dH.rowwise().sum();
      for (int i = 1; i < 4; ++i) K.block<3, 1>(3 * i, 3 * j + b) = dH.col(i - 1);
    }
  }
  return K;
}

namespace {
// F and S = 2 mu E + lambda tr(E) I of a tet, for StVK's stiffness and its projection. Inlined
// (always_inline: returning them as a struct ran 7 % slower).
[[gnu::always_inline]] inline void stvk_deformation(const Lame& lame, const TetRest& rest, const Mat34& x, Mat3& F,
                                                    Mat3& S) {
  F = deformation_gradient(rest, x);
  const Mat3 E = 0.5 * (F.transpose() * F - Mat3::Identity());
  S = 2.0 * lame.mu * E + lame.lambda * E.trace() * Mat3::Identity();
}
// Flattened (see deformation_gradient).
[[gnu::flatten]] Mat12 stvk_stiffness(const Lame& lame, const TetRest& rest, const Mat34& x) {
  Mat3 F, S;
  stvk_deformation(lame, rest, x, F, S);
  return stiffness_closed_form(lame, rest.volume, shape_gradients(rest), F, S);
}
}  // namespace

Mat12 tet_stiffness(ModelKind kind, const Lame& lame, const TetRest& rest, const Mat34& x) {
  switch (kind) {
    case ModelKind::stvk: return stvk_stiffness(lame, rest, x);
    case ModelKind::linear:
      return stiffness_closed_form(lame, rest.volume, shape_gradients(rest), Mat3::Identity(), Mat3::Zero());
    case ModelKind::corotated:
      return corotated_stiffness(lame, rest, polar_decomposition(deformation_gradient(rest, x)));
  }
  return tet_stiffness_from_differential(kind, lame, rest, x);
}

namespace {
// Whether the symmetric S is positive semi-definite by Sylvester's criterion on all its principal
// minors: a zero S (a body at rest) and any clearly semi-definite one pass without the eigenvalue
// decomposition; a borderline one may fail it and is decomposed. A singular S that passes (uniaxial
// stress, diag(s, 0, 0)) can get a negative eigenvalue of round-off size from the decomposition;
// skipping it leaves that artefact unprojected.
bool clearly_psd(const Mat3& S) {
  const double a = S(0, 0), b = S(1, 1), c = S(2, 2), d = S(0, 1), e = S(0, 2), f = S(1, 2);
  if (a < 0 || b < 0 || c < 0) return false;
  if (a * b - d * d < 0 || a * c - e * e < 0 || b * c - f * f < 0) return false;
  return a * (b * c - f * f) - d * (d * c - f * e) + e * (d * f - b * e) >= 0;
}
}  // namespace

// Flattened (see deformation_gradient).
[[gnu::flatten]] Mat12 stvk_projected_stiffness(const Lame& lame, const TetRest& rest, const Mat34& x) {
  Mat3 F, S;  // once for both terms
  stvk_deformation(lame, rest, x, F, S);
  const Mat43 B = shape_gradients(rest);
  Mat12 k = stiffness_closed_form(lame, rest.volume, B, F, S);
  // The negative part of S, found only when there may be one. Clearly semi-definite, counted over
  // the refills of one drop: 45 % of the cinder blocks' tets (their first refill is at rest), 17 %
  // of the clay teddy's. The decomposition costs about as much as the closed form (150 against
  // 177 ns). The reference scenes keep their bits; a singular S may differ by round-off (above).
  Eigen::SelfAdjointEigenSolver<Mat3> eig;
  bool has_negative = false;
  if (!clearly_psd(S)) {
    eig.computeDirect(S);
    has_negative = eig.eigenvalues()[0] < 0.0;
  }
  if (has_negative) {
    Mat3 negative = Mat3::Zero();
    for (int q = 0; q < 3; ++q)
      if (eig.eigenvalues()[q] < 0.0)
        negative += eig.eigenvalues()[q] * eig.eigenvectors().col(q) * eig.eigenvectors().col(q).transpose();
    const Mat4 g = rest.volume * (B * negative * B.transpose());
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) k.block<3, 3>(3 * i, 3 * j).diagonal().array() -= g(i, j);
  }
  return 0.5 * (k + k.transpose());
}

// The corotated energy's Hessian in F (9x9) has a closed-form eigensystem (Smith, De Goes & Kim,
// "Analytic eigensystems for isotropic distortion energies", 2019). With S = sum_k s_k v_k v_k^T:
// on the three twist modes R [v_k]x / sqrt(2) the eigenvalue is 2 mu + 2 c / (s_a + s_b) ({a, b}
// the other two indices); on vec(R) it is 2 mu + 3 lambda; on the five other modes 2 mu. Only the
// twist modes can be negative (c < 0: compression), and only M's eigenvalues c / (s_a + s_b) carry
// them: clamping them at -mu zeroes those modes, K = V D^T H+ D with D = dF/dx. A compressed tet
// whose twist eigenvalues are all positive (tr(S) I - S + (c / mu) I clearly semi-definite) takes
// the exact stiffness, bit for bit, without the 3x3 eigenproblem.
Mat12 corotated_projected_stiffness(const Lame& lame, const TetRest& rest, const Mat34& x) {
  return corotated_projected_stiffness(lame, rest, polar_decomposition(deformation_gradient(rest, x)));
}

[[gnu::flatten]] Mat12 corotated_projected_stiffness(const Lame& lame, const TetRest& rest, const Polar& p) {
  const double c = lame.lambda * (p.S.trace() - 3.0) - 2.0 * lame.mu;
  const Mat3 G = p.S.trace() * Mat3::Identity() - p.S;
  const bool exact =
      c < 0.0 ? clearly_psd(G + (c / lame.mu) * Mat3::Identity()) : clearly_psd(G) && G.determinant() > 0.0;
  if (exact) {
    const Mat3 G_inv = G.inverse();
    return corotated_blocks(lame, rest, p.R, c * 0.5 * (G_inv + G_inv.transpose()));
  }
  Eigen::SelfAdjointEigenSolver<Mat3> eig;
  eig.computeDirect(p.S);
  const Vec3 s = eig.eigenvalues();
  Mat3 M = Mat3::Zero();
  for (int k = 0; k < 3; ++k) {
    const double m = c / (s.sum() - s[k]);
    // A zero s_a + s_b (an element flattened onto a line) has no finite Hessian: the mode gets 0.
    const double clamped = std::isfinite(m) ? std::max(m, -lame.mu) : -lame.mu;
    M += clamped * eig.eigenvectors().col(k) * eig.eigenvectors().col(k).transpose();
  }
  return corotated_blocks(lame, rest, p.R, 0.5 * (M + M.transpose()));
}

Mat12 project_psd(const Mat12& K) {
  const Mat12 Ks = 0.5 * (K + K.transpose());
  const Eigen::SelfAdjointEigenSolver<Mat12> eig(Ks);
  const auto& values = eig.eigenvalues();
  if (values.minCoeff() >= 0) return Ks;
  // Remove the negative part: Ks - sum_{l < 0} l v v^T.
  Mat12 out = Ks;
  for (int k = 0; k < 12; ++k) {
    if (values[k] < 0) out -= values[k] * eig.eigenvectors().col(k) * eig.eigenvectors().col(k).transpose();
  }
  return 0.5 * (out + out.transpose());
}

[[gnu::flatten]] Mat3 cauchy_stress(ModelKind kind, const Lame& lame, const Mat3& F) {
  const Mat3 P = first_piola(kind, lame, F);
  if (kind == ModelKind::linear) return P;  // small-strain stress, symmetric
  const Mat3 s = P * F.transpose() / F.determinant();
  return 0.5 * (s + s.transpose());
}

namespace {

// Cyclic Jacobi (Golub & Van Loan, Alg. 8.5.2) on the six entries of four symmetric matrices at
// once: zero each off-diagonal entry in turn until they are negligible against the diagonal. A
// diagonal input takes no rotation at all. The rotation of plane (p, q) changes a_pp, a_qq, a_pq
// and the two entries a_rp, a_rq of the third index r only, written out on those in Rutishauser's
// tau form (less round-off than the full products). A rotation is a chain of divisions and square
// roots; four matrices side by side share the divisions' vector instructions and overlap their
// latencies. Lanes that are done (or whose entry is already zero) keep their values, so each lane
// gets the bits it would get alone. Reads the upper triangles of in[0..n); writes out[0..n).
template <bool kAvx2>
[[gnu::always_inline]] inline void jacobi_lanes(const Mat3* const* in, Principal* const* out, int n) {
  Lanes d[3], o[3], v[3][3];  // diagonal; off-diagonal (0,1), (0,2), (1,2); v[row][column]
  for (int l = 0; l < 4; ++l) {
    const Mat3 m = l < n ? *in[l] : Mat3::Zero();  // a zero matrix is done at once
    d[0][l] = m(0, 0), d[1][l] = m(1, 1), d[2][l] = m(2, 2);
    o[0][l] = m(0, 1), o[1][l] = m(0, 2), o[2][l] = m(1, 2);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) v[i][j][l] = i == j ? 1.0 : 0.0;
  }
  // Plane k of a sweep is (p, q); with r the third index, a_rp and a_rq are o[kRp[k]], o[kRq[k]].
  constexpr int kP[3] = {0, 0, 1}, kQ[3] = {1, 2, 2};
  constexpr int kRp[3] = {1, 0, 0}, kRq[3] = {2, 2, 1};
  const auto any = [](const LaneMask& m) { return (m[0] | m[1] | m[2] | m[3]) != 0; };
  const Lanes one = {1.0, 1.0, 1.0, 1.0};
  LaneMask done = {0, 0, 0, 0};
  for (int sweep = 0; sweep < 32; ++sweep) {
    const Lanes off = o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
    const Lanes scale = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + 2.0 * off;
    done = done | (off == 0.0) | (off <= 1e-36 * scale);
    if (!any(~done)) break;
    for (int k = 0; k < 3; ++k) {
      const int p = kP[k], q = kQ[k], rp = kRp[k], rq = kRq[k];
      const Lanes apq = o[k];
      const LaneMask active = ~done & (apq != 0.0);
      if (!any(active)) continue;
      // t = tan(phi), the smaller root of t^2 + 2 theta t - 1 = 0, theta = (a_qq - a_pp) / (2 a_pq);
      // then c = 1 / r and tau = s / (1 + c) = t / (r + 1) with r = sqrt(1 + t^2).
      const Lanes theta = (d[q] - d[p]) / (2.0 * (active ? apq : one));
      const Lanes abs_theta = theta < 0.0 ? -theta : theta;
      const Lanes root_theta = theta * theta + 1.0;
      const Lanes sign = theta >= 0.0 ? one : -one;
      // Past 1e150, theta^2 would overflow: t = 1 / (2 theta) to round-off there.
      const Lanes t = abs_theta > 1e150 ? 0.5 / theta : sign / (abs_theta + lane_sqrt<kAvx2>(root_theta));
      const Lanes r = lane_sqrt<kAvx2>(t * t + 1.0);
      const Lanes c = 1.0 / r;
      const Lanes sn = t * c;
      const Lanes tau = t / (r + 1.0);
      d[p] = active ? d[p] - t * apq : d[p];
      d[q] = active ? d[q] + t * apq : d[q];
      o[k] = active ? Lanes{} : apq;
      const Lanes a_rp = o[rp], a_rq = o[rq];
      o[rp] = active ? a_rp - sn * (a_rq + tau * a_rp) : a_rp;
      o[rq] = active ? a_rq + sn * (a_rp - tau * a_rq) : a_rq;
      for (auto& row : v) {
        const Lanes vp = row[p], vq = row[q];
        row[p] = active ? vp - sn * (vq + tau * vp) : vp;
        row[q] = active ? vq + sn * (vp - tau * vq) : vq;
      }
    }
  }
  for (int l = 0; l < n; ++l) {
    // Sort descending; stable, so equal eigenvalues keep their axis order.
    std::array<int, 3> order{0, 1, 2};
    for (int k = 1; k < 3; ++k)
      for (int i = k; i > 0 && d[order[static_cast<std::size_t>(i)]][l] > d[order[static_cast<std::size_t>(i - 1)]][l];
           --i)
        std::swap(order[static_cast<std::size_t>(i)], order[static_cast<std::size_t>(i - 1)]);
    Principal& res = *out[l];
    for (int k = 0; k < 3; ++k) {
      const int c = order[static_cast<std::size_t>(k)];
      res.values[k] = d[c][l];
      for (int i = 0; i < 3; ++i) res.vectors(i, k) = v[i][c][l];
    }
    // Sign rule: the largest-magnitude component of columns 0 and 1 is positive; column 2 = 0 x 1.
    for (int k = 0; k < 2; ++k) {
      Eigen::Index imax = 0;
      for (int i = 1; i < 3; ++i)
        if (std::abs(res.vectors(i, k)) > std::abs(res.vectors(imax, k))) imax = i;
      if (res.vectors(imax, k) < 0) res.vectors.col(k) = -res.vectors.col(k);
    }
    res.vectors.col(2) = res.vectors.col(0).cross(res.vectors.col(1));
  }
}

[[gnu::target("avx2"), gnu::flatten]] void jacobi_lanes_avx2(const Mat3* const* in, Principal* const* out, int n) {
  jacobi_lanes<true>(in, out, n);
}
void jacobi_lanes_baseline(const Mat3* const* in, Principal* const* out, int n) { jacobi_lanes<false>(in, out, n); }

void jacobi(const Mat3* const* in, Principal* const* out, int n) {
  (simd_isa() == SimdIsa::avx2 ? jacobi_lanes_avx2 : jacobi_lanes_baseline)(in, out, n);
}

}  // namespace

Principal principal_stresses(const Mat3& m) {
  Principal out;
  const Mat3* in[1] = {&m};
  Principal* res[1] = {&out};
  jacobi(in, res, 1);
  return out;
}

void principal_stresses(std::span<const Mat3> m, std::span<Principal> out) {
  SHATTER_CHECK(m.size() == out.size());
  for (std::size_t i = 0; i < m.size(); i += 4) {
    const int n = static_cast<int>(std::min<std::size_t>(4, m.size() - i));
    const Mat3* in[4] = {};
    Principal* res[4] = {};
    for (int l = 0; l < n; ++l) {
      in[l] = &m[i + static_cast<std::size_t>(l)];
      res[l] = &out[i + static_cast<std::size_t>(l)];
    }
    jacobi(in, res, n);
  }
}

double von_mises(const Mat3& s) {
  const double d01 = s(0, 0) - s(1, 1), d12 = s(1, 1) - s(2, 2), d20 = s(2, 2) - s(0, 0);
  const double sh = s(0, 1) * s(0, 1) + s(1, 2) * s(1, 2) + s(0, 2) * s(0, 2);
  return std::sqrt(0.5 * (d01 * d01 + d12 * d12 + d20 * d20) + 3.0 * sh);
}

}  // namespace shatter
