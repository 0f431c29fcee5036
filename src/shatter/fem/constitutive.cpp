// StVK, linear and corotated energy densities, first Piola-Kirchhoff stresses and their differentials.
#include "shatter/fem/constitutive.h"

#include <Eigen/SVD>

#include <cmath>
#include <string>

namespace shatter {
namespace {

// Green strain E = (F^T F - I) / 2 (docs/method.md §2.1).
// The small kernels below are flattened: GCC at -O2 leaves Eigen's fixed-size 3x3 products and
// sums as calls, which cost more than their arithmetic. Inlining keeps every operation and its
// order, so the results are the same bits.
[[gnu::flatten]] Mat3 green_strain(const Mat3& F) { return 0.5 * (F.transpose() * F - Mat3::Identity()); }

// S = 2 mu E + lambda tr(E) I.
Mat3 stvk_S(const Lame& l, const Mat3& E) { return 2.0 * l.mu * E + l.lambda * E.trace() * Mat3::Identity(); }

// Small strain eps = (F + F^T)/2 - I.
Mat3 small_strain(const Mat3& F) { return 0.5 * (F + F.transpose()) - Mat3::Identity(); }

// dR of the polar decomposition F = R S along dF: R^T dR = [w]x with (tr(S) I - S) w =
// axial(R^T dF - dF^T R) (Twigg & Kacic-Alesic 2010; McAdams et al. 2011).
Mat3 polar_rotation_differential(const Polar& p, const Mat3& dF) {
  const Mat3 A = p.R.transpose() * dF;
  const Mat3 skew = A - A.transpose();
  const Vec3 rhs(skew(2, 1), skew(0, 2), skew(1, 0));
  const Mat3 G = p.S.trace() * Mat3::Identity() - p.S;
  const Vec3 w = G.inverse() * rhs;
  Mat3 W;
  W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return p.R * W;
}

}  // namespace

Result<ModelKind> parse_model_kind(std::string_view name) {
  if (name == "stvk") return ModelKind::stvk;
  if (name == "linear") return ModelKind::linear;
  if (name == "corotated") return ModelKind::corotated;
  return field_error("model", "unknown constitutive model '" + std::string(name) + "'; valid: stvk, linear, corotated");
}

const char* to_string(ModelKind kind) {
  switch (kind) {
    case ModelKind::stvk: return "stvk";
    case ModelKind::linear: return "linear";
    case ModelKind::corotated: return "corotated";
  }
  return "?";
}

namespace {

// X^-T = cof(X) / det X: the columns of the cofactor matrix are cross products of X's columns.
// Returns false when det X is not positive (or not finite).
bool inverse_transpose(const Mat3& X, Mat3& out) {
  const Vec3 a = X.col(0), b = X.col(1), c = X.col(2);
  const Vec3 bc = b.cross(c);
  const double det = a.dot(bc);
  if (!(det > 0.0) || !std::isfinite(det)) return false;
  out.col(0) = bc / det;
  out.col(1) = c.cross(a) / det;
  out.col(2) = a.cross(b) / det;
  return true;
}

// R by Higham's scaled Newton iteration X <- (z X + X^-T / z) / 2 from X = F, z =
// (|X^-1|_F / |X|_F)^(1/2) (N. J. Higham, "Computing the polar decomposition", 1986). For det F > 0
// it converges quadratically to the orthogonal factor, which is then a rotation: 4-6 iterations from
// a stretch of 10x, 2-3 near a rotation, each a cofactor inverse. False when F is inverted, nearly
// singular (det F below 1e-6 of |F|^3) or does not converge in 30 iterations: the SVD does those.
bool polar_rotation_newton(const Mat3& F, Mat3& R) {
  const double scale = F.cwiseAbs().maxCoeff();
  if (!(F.determinant() > 1e-6 * scale * scale * scale)) return false;
  Mat3 X = F, Y;
  for (int k = 0; k < 30; ++k) {
    if (!inverse_transpose(X, Y)) return false;
    // Scaling speeds up the first iterations; near convergence z -> 1 and is dropped so the last
    // ones are plain Newton (quadratic, and exactly orthogonality-restoring).
    const double change0 = (X - Y).cwiseAbs().maxCoeff();
    const double z = change0 > 1e-2 ? std::sqrt(std::sqrt(Y.squaredNorm() / X.squaredNorm())) : 1.0;
    const Mat3 next = 0.5 * (z * X + Y / z);
    const double change = (next - X).cwiseAbs().maxCoeff();
    X = next;
    if (change <= 1e-15) {
      R = X;
      return true;
    }
    if (change <= 1e-8) {
      // Quadratic convergence: one more step lands at round-off.
      if (!inverse_transpose(X, Y)) return false;
      R = 0.5 * (X + Y);
      return true;
    }
  }
  return false;
}

}  // namespace

[[gnu::noinline]] Polar polar_decomposition(const Mat3& F) {
  Mat3 R;
  if (polar_rotation_newton(F, R)) {
    Polar p;
    p.R = R;
    const Mat3 S = R.transpose() * F;
    p.S = 0.5 * (S + S.transpose());
    return p;
  }
  const Eigen::JacobiSVD<Mat3> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 U = svd.matrixU();
  const Mat3& V = svd.matrixV();
  // Singular values come sorted descending; for det(U V^T) < 0 flip the smallest one's direction.
  if ((U * V.transpose()).determinant() < 0) U.col(2) = -U.col(2);
  Polar p;
  p.R = U * V.transpose();
  const Mat3 S = p.R.transpose() * F;
  p.S = 0.5 * (S + S.transpose());
  return p;
}

[[gnu::flatten]] double corotated_energy_density(const Lame& l, const Mat3& F, const Polar& p) {
  // psi = mu |F - R|^2 + lambda/2 tr(S - I)^2
  const double tr = p.S.trace() - 3.0;
  return l.mu * (F - p.R).squaredNorm() + 0.5 * l.lambda * tr * tr;
}

[[gnu::flatten]] Mat3 corotated_first_piola(const Lame& l, const Mat3& F, const Polar& p) {
  // P = 2 mu (F - R) + lambda tr(S - I) R
  return 2.0 * l.mu * (F - p.R) + l.lambda * (p.S.trace() - 3.0) * p.R;
}

[[gnu::flatten]] double energy_density(ModelKind kind, const Lame& l, const Mat3& F) {
  switch (kind) {
    case ModelKind::stvk: {
      // psi = mu tr(E^2) + lambda/2 tr(E)^2
      const Mat3 E = green_strain(F);
      const double tr = E.trace();
      return l.mu * E.squaredNorm() + 0.5 * l.lambda * tr * tr;
    }
    case ModelKind::linear: {
      const Mat3 e = small_strain(F);
      const double tr = e.trace();
      return l.mu * e.squaredNorm() + 0.5 * l.lambda * tr * tr;
    }
    case ModelKind::corotated: return corotated_energy_density(l, F, polar_decomposition(F));
  }
  return 0;
}

[[gnu::flatten]] Mat3 first_piola(ModelKind kind, const Lame& l, const Mat3& F) {
  switch (kind) {
    case ModelKind::stvk: return F * stvk_S(l, green_strain(F));  // P = F S
    case ModelKind::linear: {
      const Mat3 e = small_strain(F);
      return 2.0 * l.mu * e + l.lambda * e.trace() * Mat3::Identity();
    }
    case ModelKind::corotated: return corotated_first_piola(l, F, polar_decomposition(F));
  }
  return Mat3::Zero();
}

Mat3 first_piola_differential(ModelKind kind, const Lame& l, const Mat3& F, const Mat3& dF) {
  switch (kind) {
    case ModelKind::stvk: {
      // dP = dF S + F dS, dS = 2 mu dE + lambda tr(dE) I, dE = (dF^T F + F^T dF)/2
      const Mat3 S = stvk_S(l, green_strain(F));
      const Mat3 dE = 0.5 * (dF.transpose() * F + F.transpose() * dF);
      return dF * S + F * stvk_S(l, dE);
    }
    case ModelKind::linear:
      // dP = mu (dF + dF^T) + lambda tr(dF) I
      return l.mu * (dF + dF.transpose()) + l.lambda * dF.trace() * Mat3::Identity();
    case ModelKind::corotated: {
      // dP = 2 mu dF + lambda tr(R^T dF) R + (lambda tr(S - I) - 2 mu) dR
      const Polar p = polar_decomposition(F);
      const Mat3 dR = polar_rotation_differential(p, dF);
      return 2.0 * l.mu * dF + l.lambda * (p.R.transpose() * dF).trace() * p.R +
             (l.lambda * (p.S.trace() - 3.0) - 2.0 * l.mu) * dR;
    }
  }
  return Mat3::Zero();
}

}  // namespace shatter
