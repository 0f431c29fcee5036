#include <gtest/gtest.h>

#include <cmath>

#include "fem_test_util.h"
#include "shatter/fem/constitutive.h"
#include "support/test_support.h"

namespace shatter {
namespace {

using test::kAllModels;

TEST(Constitutive, ParseModelKind) {
  for (ModelKind k : kAllModels) {
    const Result<ModelKind> r = parse_model_kind(to_string(k));
    ASSERT_OK(r);
    EXPECT_EQ(*r, k);
  }
  const Result<ModelKind> bad = parse_model_kind("neo-hookean");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("corotated"), std::string::npos);
}

// P = dpsi/dF and dP = d^2psi/dF^2 : dF by central differences, over random F and materials.
TEST(Constitutive, StressAndDifferentialMatchFiniteDifferences) {
  Random rng(11);
  for (ModelKind kind : kAllModels) {
    for (int trial = 0; trial < 50; ++trial) {
      const Lame lame = test::random_lame(rng);
      const Mat3 F = test::random_deformation(rng, 0.3);
      const double h = 1e-6;
      const Mat3 P = first_piola(kind, lame, F);
      Mat3 P_fd;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
          Mat3 Fp = F, Fm = F;
          Fp(i, j) += h;
          Fm(i, j) -= h;
          P_fd(i, j) = (energy_density(kind, lame, Fp) - energy_density(kind, lame, Fm)) / (2 * h);
        }
      }
      EXPECT_LT((P - P_fd).norm(), 1e-6 * P.norm()) << to_string(kind) << " trial " << trial;

      Mat3 dF;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) dF(i, j) = rng.uniform(-1, 1);
      const Mat3 dP = first_piola_differential(kind, lame, F, dF);
      const Mat3 dP_fd = (first_piola(kind, lame, F + h * dF) - first_piola(kind, lame, F - h * dF)) / (2 * h);
      EXPECT_LT((dP - dP_fd).norm(), 1e-6 * dP.norm()) << to_string(kind) << " trial " << trial;
    }
  }
}

TEST(Constitutive, RestStateIsStressFree) {
  const Lame lame{.mu = 3.0, .lambda = 2.0};
  for (ModelKind kind : kAllModels) {
    EXPECT_EQ(energy_density(kind, lame, Mat3::Identity()), 0.0) << to_string(kind);
    EXPECT_LT(first_piola(kind, lame, Mat3::Identity()).norm(), 1e-15) << to_string(kind);
  }
}

TEST(Constitutive, RotationInvariance) {
  Random rng(5);
  for (int trial = 0; trial < 30; ++trial) {
    const Lame lame = test::random_lame(rng);
    const Mat3 F = test::random_deformation(rng, 0.2);
    const Mat3 R = test::random_rotation(rng);
    for (ModelKind kind : {ModelKind::stvk, ModelKind::corotated}) {
      const double psi = energy_density(kind, lame, F);
      EXPECT_NEAR(energy_density(kind, lame, R * F), psi, 1e-13 * (1 + psi)) << to_string(kind);
      // P(R F) = R P(F).
      EXPECT_LT((first_piola(kind, lame, R * F) - R * first_piola(kind, lame, F)).norm(), 1e-13) << to_string(kind);
    }
  }
}

TEST(Constitutive, PolarDecomposition) {
  Random rng(8);
  for (int trial = 0; trial < 50; ++trial) {
    const Mat3 F = test::random_deformation(rng, 0.4);
    const Polar p = polar_decomposition(F);
    EXPECT_LT((p.R * p.S - F).norm(), 1e-14);
    EXPECT_LT((p.R.transpose() * p.R - Mat3::Identity()).norm(), 1e-14);
    EXPECT_NEAR(p.R.determinant(), 1.0, 1e-14);
    EXPECT_LT((p.S - p.S.transpose()).norm(), 1e-15);
  }
  // A pure rotation: R = F, S = I; an inverted F: det R still +1.
  const Mat3 Q = test::random_rotation(rng);
  const Polar p = polar_decomposition(Q);
  EXPECT_LT((p.R - Q).norm(), 1e-14);
  EXPECT_LT((p.S - Mat3::Identity()).norm(), 1e-14);
  const Mat3 inverted = Q * Vec3(1.1, 0.9, -0.2).asDiagonal();
  const Polar pi = polar_decomposition(inverted);
  EXPECT_NEAR(pi.R.determinant(), 1.0, 1e-14);
  EXPECT_LT((pi.R * pi.S - inverted).norm(), 1e-14);
}

// Corotated near a rotation (equal singular values): the differential still matches differences.
TEST(Constitutive, CorotatedSmoothNearRotation) {
  Random rng(9);
  const Lame lame{.mu = 1.0, .lambda = 1.5};
  for (int trial = 0; trial < 20; ++trial) {
    const Mat3 R = test::random_rotation(rng);
    Mat3 F = R;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F(i, j) += 1e-9 * rng.uniform(-1, 1);
    Mat3 dF;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) dF(i, j) = rng.uniform(-1, 1);
    const double h = 1e-6;
    const Mat3 dP = first_piola_differential(ModelKind::corotated, lame, F, dF);
    const Mat3 dP_fd =
        (first_piola(ModelKind::corotated, lame, F + h * dF) - first_piola(ModelKind::corotated, lame, F - h * dF)) /
        (2 * h);
    EXPECT_LT((dP - dP_fd).norm(), 1e-6 * dP.norm()) << trial;
  }
}

}  // namespace
}  // namespace shatter
