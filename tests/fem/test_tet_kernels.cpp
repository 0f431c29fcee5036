#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>
#include <functional>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "fem_test_util.h"
#include "shatter/core/simd.h"
#include "shatter/fem/tet_kernels.h"
#include "shatter/mesh/tet_mesh.h"
#include "support/test_support.h"

namespace shatter {
namespace {

using test::kAllModels;

Mat34 deform(const Mat34& m, const Mat3& F, const Vec3& t) {
  Mat34 x;
  for (int k = 0; k < 4; ++k) x.col(k) = F * m.col(k) + t;
  return x;
}

Vec12 flat(const Mat34& f) { return Eigen::Map<const Vec12>(f.data()); }

TEST(TetKernels, RestData) {
  Random rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const Mat34 m = test::random_tet(rng, 2.0);
    const TetRest r = tet_rest(m);
    EXPECT_NEAR(r.volume, signed_volume(m.col(0), m.col(1), m.col(2), m.col(3)), 1e-14);
    EXPECT_LT((deformation_gradient(r, m) - Mat3::Identity()).norm(), 1e-13);
    // Shape gradients: sum to zero; sum_j x_j grad(b_j)^T = F for any x.
    const Mat43 B = shape_gradients(r);
    EXPECT_LT(B.colwise().sum().norm(), 1e-12);
    Mat34 x = m;
    for (int k = 0; k < 4; ++k) x.col(k) += rng.uniform_vec3(-0.1, 0.1);
    EXPECT_LT((x * B - deformation_gradient(r, x)).norm(), 1e-12);
  }
}

// Forces = dU/dx and stiffness = d(forces)/dx by central differences over random shapes and
// deformations.
TEST(TetKernels, ForcesAndStiffnessMatchFiniteDifferences) {
  Random rng(2);
  for (ModelKind kind : kAllModels) {
    for (int trial = 0; trial < 40; ++trial) {
      const Lame lame = test::random_lame(rng);
      const double scale = rng.uniform(0.01, 10.0);
      const Mat34 m = test::random_tet(rng, scale);
      const TetRest r = tet_rest(m);
      const Mat3 g = test::random_deformation(rng, 0.3);  // drawn before the shift, whatever the compiler
      const Mat34 x = deform(m, g, scale * rng.uniform_vec3(-1, 1));
      const double h = 1e-6 * scale;
      const Vec12 f = flat(tet_internal_forces(kind, lame, r, x));
      const Mat12 K = tet_stiffness(kind, lame, r, x);
      Vec12 f_fd;
      Mat12 K_fd;
      for (int c = 0; c < 12; ++c) {
        Mat34 xp = x, xm = x;
        xp(c % 3, c / 3) += h;
        xm(c % 3, c / 3) -= h;
        f_fd[c] = (tet_energy(kind, lame, r, xp) - tet_energy(kind, lame, r, xm)) / (2 * h);
        K_fd.col(c) =
            (flat(tet_internal_forces(kind, lame, r, xp)) - flat(tet_internal_forces(kind, lame, r, xm))) / (2 * h);
      }
      EXPECT_LT((f - f_fd).norm(), 1e-6 * f.norm()) << to_string(kind) << " trial " << trial;
      EXPECT_LT((K - K_fd).norm(), 1e-6 * K.norm()) << to_string(kind) << " trial " << trial;
      // Closed forms agree with the column-by-column construction from dP.
      const Mat12 K_dP = tet_stiffness_from_differential(kind, lame, r, x);
      EXPECT_LT((K - K_dP).norm(), 1e-12 * K.norm()) << to_string(kind) << " trial " << trial;
      // Symmetric to round-off; forces balance (sum zero).
      EXPECT_LT((K - K.transpose()).norm(), 1e-13 * K.norm()) << to_string(kind);
      EXPECT_LT((K_dP - K_dP.transpose()).norm(), 1e-13 * K.norm()) << to_string(kind);
      EXPECT_LT(tet_internal_forces(kind, lame, r, x).rowwise().sum().norm(), 1e-13 * f.norm());
    }
  }
}

TEST(TetKernels, RigidMotionsGiveNoForceNoStress) {
  Random rng(3);
  for (int trial = 0; trial < 30; ++trial) {
    const Lame lame = test::random_lame(rng);
    const Mat34 m = test::random_tet(rng, 1.0);
    const TetRest r = tet_rest(m);
    const Mat3 R = test::random_rotation(rng);
    const Vec3 t = rng.uniform_vec3(-10, 10);
    const double force_scale = lame.mu * r.volume;  // N for unit strain on a unit tet
    for (ModelKind kind : kAllModels) {
      // Translation: zero for every model.
      const Mat34 xt = deform(m, Mat3::Identity(), t);
      EXPECT_LT(tet_internal_forces(kind, lame, r, xt).norm(), 1e-12 * force_scale) << to_string(kind);
      EXPECT_LT(cauchy_stress(kind, lame, deformation_gradient(r, xt)).norm(), 1e-12 * lame.mu);
      // Rotation: zero for stvk and corotated; the stiffness annihilates rigid motions too.
      const Mat34 xr = deform(m, R, t);
      const Mat3 F = deformation_gradient(r, xr);
      const Vec12 f = flat(tet_internal_forces(kind, lame, r, xr));
      if (kind == ModelKind::linear) {
        // Documented limitation: small-strain elasticity sees a finite rotation as strain.
        EXPECT_GT(cauchy_stress(kind, lame, F).norm(), 1e-3 * lame.mu);
        continue;
      }
      EXPECT_LT(f.norm(), 1e-12 * force_scale) << to_string(kind);
      EXPECT_LT(cauchy_stress(kind, lame, F).norm(), 1e-12 * lame.mu) << to_string(kind);
      EXPECT_LT(tet_energy(kind, lame, r, xr), 1e-24 * force_scale);
      const Mat12 K = tet_stiffness(kind, lame, r, xr);
      Vec12 shift, spin;
      const Vec3 w = rng.unit_vec3();
      for (int k = 0; k < 4; ++k) {
        shift.segment<3>(3 * k) = Vec3(1, 2, 3);
        spin.segment<3>(3 * k) = w.cross(xr.col(k));
      }
      EXPECT_LT((K * shift).norm(), 1e-12 * K.norm()) << to_string(kind);
      EXPECT_LT((K * spin).norm(), 1e-12 * K.norm() * xr.norm()) << to_string(kind);
    }
  }
}

// Single right-angled tet m0 = 0, m_i = e_i under the uniaxial stretch F = diag(s, 1, 1):
// E = diag((s^2 - 1)/2, 0, 0), S = diag((2 mu + lambda) e, lambda e, lambda e) with e = (s^2 - 1)/2,
// P = F S = diag(s S11, S22, S33), sigma = F S F^T / s = diag(s S11, S22 / s, S33 / s);
// Dm = I, V = 1/6, so f_i = P e_i / 6 (i = 1..3) and f0 = -(f1 + f2 + f3).
TEST(TetKernels, SingleTetStVKUniaxialStretch) {
  Mat34 m = Mat34::Zero();
  m(0, 1) = m(1, 2) = m(2, 3) = 1.0;
  const TetRest r = tet_rest(m);
  const Lame lame{.mu = 26e9, .lambda = 41e9};
  for (double s : {0.98, 1.001, 1.25}) {
    const double e = 0.5 * (s * s - 1.0);
    const double S11 = (2 * lame.mu + lame.lambda) * e, S22 = lame.lambda * e;
    Mat34 x = m;
    x(0, 1) = s;
    const Mat34 f = tet_internal_forces(ModelKind::stvk, lame, r, x);
    Mat34 expected = Mat34::Zero();
    expected(0, 1) = s * S11 / 6;
    expected(1, 2) = S22 / 6;
    expected(2, 3) = S22 / 6;
    expected.col(0) = -expected.rightCols<3>().rowwise().sum();
    EXPECT_LT((f - expected).norm(), 1e-14 * expected.norm()) << s;
    const Mat3 sigma = cauchy_stress(ModelKind::stvk, lame, deformation_gradient(r, x));
    const Mat3 sigma_expected = Vec3(s * S11, S22 / s, S22 / s).asDiagonal();
    EXPECT_LT((sigma - sigma_expected).norm(), 1e-14 * sigma_expected.norm()) << s;
    EXPECT_NEAR(tet_energy(ModelKind::stvk, lame, r, x), (lame.mu * e * e + 0.5 * lame.lambda * e * e) / 6,
                1e-14 * S11 * e);
  }
}

TEST(TetKernels, ProjectPsd) {
  Random rng(4);
  for (int trial = 0; trial < 20; ++trial) {
    // Known spectrum with negatives.
    Mat12 A;
    for (int i = 0; i < 12; ++i)
      for (int j = 0; j < 12; ++j) A(i, j) = rng.uniform(-1, 1);
    const Eigen::HouseholderQR<Mat12> qr(A);
    const Mat12 Q = qr.householderQ();
    Vec12 d;
    for (int i = 0; i < 12; ++i) d[i] = rng.uniform(-5, 5);
    const Mat12 K = Q * d.asDiagonal() * Q.transpose();
    const Mat12 P = project_psd(K);
    const Mat12 expected = Q * d.cwiseMax(0.0).asDiagonal() * Q.transpose();
    EXPECT_LT((P - expected).norm(), 1e-12 * K.norm());
    const Eigen::SelfAdjointEigenSolver<Mat12> eig(P);
    EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-12 * K.norm());
    // Already PSD (strictly): unchanged, bit for bit.
    const Mat12 Kp = Q * d.cwiseAbs().asDiagonal() * Q.transpose();
    const Mat12 Kps = 0.5 * (Kp + Kp.transpose());
    EXPECT_EQ(project_psd(Kps), Kps);
  }
  // A stiffness under strong compression is indefinite; projected it is not.
  const Mat34 m = test::random_tet(rng);
  const TetRest r = tet_rest(m);
  const Mat34 x = deform(m, 0.5 * Mat3::Identity(), Vec3::Zero());
  const Lame lame{.mu = 1, .lambda = 1};
  const Mat12 K = tet_stiffness(ModelKind::stvk, lame, r, x);
  const Mat12 Ks = 0.5 * (K + K.transpose());
  EXPECT_LT(Eigen::SelfAdjointEigenSolver<Mat12>(Ks).eigenvalues().minCoeff(), -1e-3 * K.norm());
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Mat12>(project_psd(K)).eigenvalues().minCoeff(), -1e-12 * K.norm());
}

// The corotated projection against an independent one: the 9x9 Hessian in F built column by
// column from first_piola_differential, projected by a numerical eigen-decomposition, mapped to the
// corners by D = dF/dx (K = V D^T H+ D). Mild deformations keep the exact stiffness bit for bit;
// strong compressions are indefinite and come out positive semi-definite.
TEST(TetKernels, CorotatedProjectionClampsTheHessianInF) {
  Random rng(5);
  using Mat9 = Eigen::Matrix<double, 9, 9>;
  using Mat9x12 = Eigen::Matrix<double, 9, 12>;
  int indefinite = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Lame lame = test::random_lame(rng);
    const Mat34 m = test::random_tet(rng, rng.uniform(0.01, 10.0));
    const TetRest r = tet_rest(m);
    // Stretches along a random axis (every twist eigenvalue positive), then general deformations
    // squashed by up to 60 % along a random axis, each with a random rotation. (Any compression
    // makes a twist mode negative: at rest they are the rotations' zero modes.)
    const Vec3 axis = rng.unit_vec3();
    const Mat3 rotation = test::random_rotation(rng);
    const Mat3 F = trial < 40 ? Mat3(rotation * (Mat3::Identity() + rng.uniform(0.01, 0.3) * axis * axis.transpose()))
                              : Mat3(rotation * (Mat3::Identity() - rng.uniform(0.05, 0.6) * axis * axis.transpose()) *
                                     test::random_deformation(rng, 0.2));
    const Mat34 x = deform(m, F, Vec3::Zero());
    const Mat12 K = tet_stiffness(ModelKind::corotated, lame, r, x);
    const Mat12 Kp = corotated_projected_stiffness(lame, r, x);
    // Hessian in F: column 3 c + b (dF = e_b e_c^T) is vec(dP) in the same ordering.
    Mat9 H;
    for (int c = 0; c < 3; ++c)
      for (int b = 0; b < 3; ++b) {
        Mat3 dF = Mat3::Zero();
        dF(b, c) = 1.0;
        const Mat3 dP = first_piola_differential(ModelKind::corotated, lame, F, dF);
        H.col(3 * c + b) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
      }
    const Eigen::SelfAdjointEigenSolver<Mat9> eig(0.5 * (H + H.transpose()));
    const Mat9 H_plus =
        eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
    // D: vec(dF) for each corner displacement, dF = dx_i grad(b_i)^T.
    const Mat43 B = shape_gradients(r);
    Mat9x12 D = Mat9x12::Zero();
    for (int i = 0; i < 4; ++i)
      for (int b = 0; b < 3; ++b)
        for (int c = 0; c < 3; ++c) D(3 * c + b, 3 * i + b) = B(i, c);
    const Mat12 expected = r.volume * D.transpose() * H_plus * D;
    const double scale = (r.volume * D.transpose() * H * D).norm();
    EXPECT_LT((Kp - expected).norm(), 1e-9 * scale) << "trial " << trial;
    EXPECT_EQ(Kp, Kp.transpose()) << "trial " << trial;
    EXPECT_EQ(K, K.transpose()) << "trial " << trial;
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Mat12>(Kp).eigenvalues().minCoeff(), -1e-12 * scale) << "trial " << trial;
    // A stretch has no negative twist mode: the exact stiffness, bit for bit.
    if (trial < 40) {
      EXPECT_EQ(Kp, K) << "trial " << trial;
    }
    // H is in Pa, K in N/m: each against its own size.
    if (eig.eigenvalues().minCoeff() < -1e-9 * H.norm()) {
      ++indefinite;
      EXPECT_LT(Eigen::SelfAdjointEigenSolver<Mat12>(K).eigenvalues().minCoeff(), -1e-9 * scale);
    }
  }
  // Most squashed tets needed the clamp.
  EXPECT_GT(indefinite, 80);
}

void expect_eigen_pairs(const Mat3& A, const Principal& p) {
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT((A * p.vectors.col(k) - p.values[k] * p.vectors.col(k)).norm(), 1e-13 * (1 + A.norm()));
    EXPECT_NEAR(p.vectors.col(k).norm(), 1.0, 1e-14);
  }
  EXPECT_NEAR(p.vectors.determinant(), 1.0, 1e-14);
  EXPECT_GE(p.values[0], p.values[1]);
  EXPECT_GE(p.values[1], p.values[2]);
}

TEST(TetKernels, PrincipalStressesExactOnRepeatedEigenvalues) {
  const double a = 3.7e6, b = -1.2e6;
  for (const Vec3& diag : {Vec3(a, a, b), Vec3(b, a, a), Vec3(a, b, a), Vec3(a, a, a), Vec3(0, 0, 0)}) {
    const Mat3 A = diag.asDiagonal();
    const Principal p = principal_stresses(A);
    Vec3 sorted = diag;
    std::sort(sorted.data(), sorted.data() + 3, std::greater<double>());
    EXPECT_EQ(p.values, sorted) << diag.transpose();
    // Eigenvectors are exact coordinate axes.
    for (int k = 0; k < 3; ++k) EXPECT_EQ(p.vectors.col(k).cwiseAbs().maxCoeff(), 1.0);
    expect_eigen_pairs(A, p);
  }
  const Principal iso = principal_stresses(a * Mat3::Identity());
  EXPECT_EQ(iso.vectors, Mat3::Identity());
}

TEST(TetKernels, PrincipalStressesRandomAndDeterministic) {
  Random rng(6);
  for (int trial = 0; trial < 200; ++trial) {
    const Mat3 Q = test::random_rotation(rng);
    Vec3 d = rng.uniform_vec3(-1e8, 1e8);
    if (trial % 3 == 0) d[1] = d[0];  // a repeated pair, rotated
    const Mat3 A = Q * d.asDiagonal() * Q.transpose();
    const Mat3 As = 0.5 * (A + A.transpose());
    const Principal p = principal_stresses(As);
    std::sort(d.data(), d.data() + 3, std::greater<double>());
    EXPECT_LT((p.values - d).norm(), 1e-14 * d.norm() * 10);
    expect_eigen_pairs(As, p);
    const Principal again = principal_stresses(As);
    EXPECT_EQ(p.values, again.values);
    EXPECT_EQ(p.vectors, again.vectors);
  }
}

TEST(TetKernels, PrincipalStressesFourAtATimeGiveTheBitsOfOneAtATime) {
  // Random tensors, rotated repeated pairs, diagonal ones, zero, a NaN and a huge one, in every
  // position of a group of four and in groups cut short; both instruction sets.
  Random rng(11);
  std::vector<Mat3> tensors;
  for (int trial = 0; trial < 60; ++trial) {
    const Mat3 Q = test::random_rotation(rng);
    Vec3 d = rng.uniform_vec3(-1e8, 1e8);
    if (trial % 4 == 1) d[2] = d[0];
    Mat3 A = Q * d.asDiagonal() * Q.transpose();
    if (trial % 4 == 2) A = d.asDiagonal();
    if (trial % 4 == 3 && trial % 8 == 3) A(0, 1) = 1e-300;  // one entry all but zero
    tensors.emplace_back(A);
  }
  tensors.emplace_back(Mat3::Zero());
  tensors.emplace_back(Mat3::Constant(std::numeric_limits<double>::quiet_NaN()));
  tensors.emplace_back(1e200 * Mat3::Identity() + 1e40 * Mat3::Ones());
  // Bit for bit: NaN equals NaN, and -0 differs from +0.
  const auto same_bits = [](const Principal& a, const Principal& b) {
    for (int i = 0; i < 3; ++i) {
      if (std::bit_cast<std::uint64_t>(a.values[i]) != std::bit_cast<std::uint64_t>(b.values[i])) return false;
      for (int j = 0; j < 3; ++j)
        if (std::bit_cast<std::uint64_t>(a.vectors(i, j)) != std::bit_cast<std::uint64_t>(b.vectors(i, j)))
          return false;
    }
    return true;
  };
  const SimdIsa saved = simd_isa();
  for (const SimdIsa isa : {SimdIsa::baseline, SimdIsa::avx2}) {
    set_simd_isa(isa);
    for (std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{6}, tensors.size()}) {
      std::vector<Principal> batch(count);
      principal_stresses(std::span<const Mat3>(tensors.data(), count), std::span(batch));
      for (std::size_t i = 0; i < count; ++i) {
        EXPECT_TRUE(same_bits(principal_stresses(tensors[i]), batch[i])) << i;
      }
    }
  }
  set_simd_isa(saved);
  // And the same bits from either instruction set.
  set_simd_isa(SimdIsa::avx2);
  const bool have_avx2 = simd_isa() == SimdIsa::avx2;  // else the loop above ran the baseline twice
  set_simd_isa(saved);
  if (!have_avx2) GTEST_SKIP() << "no AVX2 on this CPU: only the baseline kernel was checked";
  set_simd_isa(SimdIsa::baseline);
  std::vector<Principal> baseline(tensors.size()), avx2(tensors.size());
  principal_stresses(std::span<const Mat3>(tensors), std::span(baseline));
  set_simd_isa(SimdIsa::avx2);
  principal_stresses(std::span<const Mat3>(tensors), std::span(avx2));
  set_simd_isa(saved);
  for (std::size_t i = 0; i < tensors.size(); ++i) EXPECT_TRUE(same_bits(baseline[i], avx2[i])) << i;
}

TEST(TetKernels, VonMises) {
  const double s = 2.5e8;
  EXPECT_DOUBLE_EQ(von_mises(Vec3(s, 0, 0).asDiagonal()), s);    // uniaxial
  EXPECT_DOUBLE_EQ(von_mises(Mat3(s * Mat3::Identity())), 0.0);  // hydrostatic
  Mat3 shear = Mat3::Zero();
  shear(0, 1) = shear(1, 0) = s;
  EXPECT_NEAR(von_mises(shear), std::sqrt(3.0) * s, 1e-15 * s);  // pure shear
  Random rng(7);
  const Mat3 Q = test::random_rotation(rng);
  EXPECT_NEAR(von_mises(Q * Vec3(s, 0, 0).asDiagonal() * Q.transpose()), s, 1e-14 * s);
}

}  // namespace
}  // namespace shatter
