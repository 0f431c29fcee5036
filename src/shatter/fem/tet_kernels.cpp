// Constant-strain tet kernels (docs/method.md §2.2-2.3) and stress analysis helpers.
#include "shatter/fem/tet_kernels.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <cmath>

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
  const Mat3 P = first_piola(kind, lame, deformation_gradient(rest, x));
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

// Corotated blocks from dP = 2 mu dF + lambda tr(R^T dF) R + c dR, c = lambda tr(S - I) - 2 mu, and
// dR = R [w]x with (tr(S) I - S) w = axial(R^T dF - dF^T R) (first_piola_differential). For the
// column dF = e_b g_j^T (corner j moved along axis b): R^T dF = r_b g_j^T with r_b = R^T e_b, so
// tr(R^T dF) = r_b . g_j and the axial vector is g_j x r_b. The polar decomposition and
// (tr(S) I - S)^-1 are found once per tet, not once per column.
Mat12 corotated_stiffness(const Lame& lame, const TetRest& rest, const Mat34& x) {
  const Mat3 F = deformation_gradient(rest, x);
  const Polar p = polar_decomposition(F);
  const Mat3 G_inv = (p.S.trace() * Mat3::Identity() - p.S).inverse();
  const double c = lame.lambda * (p.S.trace() - 3.0) - 2.0 * lame.mu;
  const Mat43 B = shape_gradients(rest);
  const Mat3 Dm_inv_t = rest.Dm_inv.transpose();
  Mat12 K;
  for (int j = 0; j < 4; ++j) {
    const Vec3 g = B.row(j).transpose();
    for (int b = 0; b < 3; ++b) {
      const Vec3 r = p.R.row(b).transpose();
      const Vec3 w = G_inv * g.cross(r);
      Mat3 W;
      W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
      Mat3 dP = lame.lambda * r.dot(g) * p.R + c * (p.R * W);
      dP.row(b) += 2.0 * lame.mu * g.transpose();
      const Mat3 dH = rest.volume * dP * Dm_inv_t;
      K.block<3, 1>(0, 3 * j + b) = -dH.rowwise().sum();
      for (int i = 1; i < 4; ++i) K.block<3, 1>(3 * i, 3 * j + b) = dH.col(i - 1);
    }
  }
  return K;
}

}  // namespace

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
    case ModelKind::corotated: return corotated_stiffness(lame, rest, x);
  }
  return tet_stiffness_from_differential(kind, lame, rest, x);
}

// Flattened (see deformation_gradient).
[[gnu::flatten]] Mat12 stvk_projected_stiffness(const Lame& lame, const TetRest& rest, const Mat34& x) {
  Mat3 F, S;  // once for both terms
  stvk_deformation(lame, rest, x, F, S);
  const Mat43 B = shape_gradients(rest);
  Mat12 k = stiffness_closed_form(lame, rest.volume, B, F, S);
  Eigen::SelfAdjointEigenSolver<Mat3> eig;
  eig.computeDirect(S);
  if (eig.eigenvalues()[0] < 0.0) {
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

Principal principal_stresses(const Mat3& m) {
  Mat3 a = m.selfadjointView<Eigen::Upper>();
  Mat3 v = Mat3::Identity();
  // Cyclic Jacobi: zero each off-diagonal entry in turn (Golub & Van Loan, Alg. 8.5.2) until they
  // are negligible against the diagonal. A diagonal input takes no rotation at all.
  for (int sweep = 0; sweep < 32; ++sweep) {
    const double off = a(0, 1) * a(0, 1) + a(0, 2) * a(0, 2) + a(1, 2) * a(1, 2);
    if (off == 0.0) break;
    const double scale = a.squaredNorm();
    if (off <= 1e-36 * scale) break;
    for (int p = 0; p < 2; ++p) {
      for (int q = p + 1; q < 3; ++q) {
        if (a(p, q) == 0.0) continue;
        Eigen::JacobiRotation<double> rot;
        rot.makeJacobi(a, p, q);  // symmetric Schur 2x2: zeroes a(p, q)
        a.applyOnTheLeft(p, q, rot.adjoint());
        a.applyOnTheRight(p, q, rot);
        v.applyOnTheRight(p, q, rot);
        a(p, q) = a(q, p) = 0.0;
      }
    }
  }
  // Sort descending; stable, so equal eigenvalues keep their axis order.
  // (Insertion sort: std::stable_sort allocates a buffer, even for three.)
  std::array<int, 3> order{0, 1, 2};
  for (int k = 1; k < 3; ++k)
    for (int i = k; i > 0 && a(order[i], order[i]) > a(order[i - 1], order[i - 1]); --i)
      std::swap(order[i], order[i - 1]);
  Principal out;
  for (int k = 0; k < 3; ++k) {
    out.values[k] = a(order[k], order[k]);
    out.vectors.col(k) = v.col(order[k]);
  }
  for (int k = 0; k < 2; ++k) {
    Eigen::Index imax = 0;
    for (int i = 1; i < 3; ++i)
      if (std::abs(out.vectors(i, k)) > std::abs(out.vectors(imax, k))) imax = i;
    if (out.vectors(imax, k) < 0) out.vectors.col(k) = -out.vectors.col(k);
  }
  out.vectors.col(2) = out.vectors.col(0).cross(out.vectors.col(1));
  return out;
}

double von_mises(const Mat3& s) {
  const double d01 = s(0, 0) - s(1, 1), d12 = s(1, 1) - s(2, 2), d20 = s(2, 2) - s(0, 0);
  const double sh = s(0, 1) * s(0, 1) + s(1, 2) * s(1, 2) + s(0, 2) * s(0, 2);
  return std::sqrt(0.5 * (d01 * d01 + d12 * d12 + d20 * d20) + 3.0 * sh);
}

}  // namespace shatter
