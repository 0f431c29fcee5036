// Crack planning: the r_frac rule, origin order, several cracks per load, time-averaged stress.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "shatter/fem/material.h"
#include "shatter/fracture/crack.h"
#include "shatter/mesh/generate.h"
#include "support/test_support.h"

namespace shatter {
namespace {

Material test_material(double strength) {
  Material m;
  m.name = "test";
  m.youngs_modulus = 1e9;
  m.poisson_ratio = 0.25;
  m.density = 1000;
  m.tensile_strength = strength;
  m.yield_stress = kInfinity;
  m.fracture_toughness = kInfinity;
  return m;
}

/// Uniaxial stress along `axis` of magnitude s(centroid) per tet.
template <class F>
std::vector<TetStress> uniaxial(const TetMesh& m, const Vec3& axis, F&& s) {
  std::vector<Mat3> sigma;
  for (Index e = 0; e < m.num_tets(); ++e)
    sigma.push_back(s(Vec3(m.corners(e).rowwise().mean())) * axis * axis.transpose());
  return analyze_stresses(sigma);
}

TEST(CrackRadius, RuleAndMaterials) {
  EXPECT_EQ(crack_radius(1.0, 1.0, 4, 2.0, 0.1), 0.1);  // at strength: minimum
  EXPECT_NEAR(crack_radius(1.1, 1.0, 4, 2.0, 0.1), 0.8, 1e-14);
  EXPECT_EQ(crack_radius(2.0, 1.0, 4, 2.0, 0.1), 2.0);  // clamped to r_0
  EXPECT_LT(crack_radius(1.1, 1.0, 1, 2.0, 0.1), crack_radius(1.1, 1.0, 4, 2.0, 0.1));
  const double glass = material_brittleness(material_preset("glass").value(), 0.3);
  const double steel = material_brittleness(material_preset("steel").value(), 0.3);
  const double clay = material_brittleness(material_preset("clay").value(), 0.3);
  EXPECT_EQ(glass, 20.0);
  EXPECT_LT(steel, glass);
  EXPECT_NEAR(steel, 400e6 * std::sqrt(std::numbers::pi * 0.3) / 50e6, 1e-12);
  EXPECT_EQ(clay, 0.5);
}

TEST(PlanCracks, BelowStrengthNothingAboveOnePlane) {
  const TetMesh m = make_box_mesh({.max = Vec3(4, 1, 1), .cells = {8, 2, 2}});
  const Material mat = test_material(1e6);
  EXPECT_TRUE(plan_cracks(m, uniaxial(m, Vec3::UnitX(), [](const Vec3&) { return 0.999e6; }), mat).empty());
  // Peak tension at x = 2.6: the crack starts there, normal along x.
  const auto stress = uniaxial(m, Vec3::UnitX(), [](const Vec3& c) { return 1.2e6 - 0.1e6 * std::abs(c.x() - 2.6); });
  const std::vector<CrackPlan> plans = plan_cracks(m, stress, mat, {.brittleness = 4, .max_cracks = 1});
  ASSERT_EQ(plans.size(), 1u);
  EXPECT_NEAR(std::abs(plans[0].normal.x()), 1.0, 1e-12);
  EXPECT_NEAR(plans[0].origin.x(), 2.6, 0.3);
  EXPECT_NEAR(plans[0].stress, stress[plans[0].origin_tet].principal[0], 0);
  for (Index e = 0; e < m.num_tets(); ++e) EXPECT_LE(stress[e].principal[0], plans[0].stress);
  const double body = m.bounds().extent().norm();
  EXPECT_NEAR(plans[0].radius, std::min(1.0, 4 * (plans[0].stress / 1e6 - 1)) * body, 1e-12);
  EXPECT_TRUE(std::is_sorted(plans[0].tets.begin(), plans[0].tets.end()));
  EXPECT_TRUE(std::binary_search(plans[0].tets.begin(), plans[0].tets.end(), plans[0].origin_tet));
}

TEST(PlanCracks, SeveralSeparatedOrigins) {
  const TetMesh m = make_box_mesh({.max = Vec3(8, 1, 1), .cells = {16, 2, 2}});
  const Material mat = test_material(1e6);
  // Two peaks, at x = 1.5 (higher) and x = 6.5.
  const auto stress = uniaxial(m, Vec3::UnitX(), [](const Vec3& c) {
    return std::max(1.2e6 - 0.2e6 * std::abs(c.x() - 1.5), 1.15e6 - 0.2e6 * std::abs(c.x() - 6.5));
  });
  const CrackOptions options{.brittleness = 1, .radius_fraction = 0.15, .max_cracks = 4, .separation = 1.0};
  const std::vector<CrackPlan> plans = plan_cracks(m, stress, mat, options);
  ASSERT_GE(plans.size(), 2u);
  EXPECT_NEAR(plans[0].origin.x(), 1.5, 0.3);
  EXPECT_GE(plans[0].stress, plans[1].stress);
  for (std::size_t i = 0; i < plans.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) {
      EXPECT_GT((plans[i].origin - plans[j].origin).norm(), plans[j].radius);
      EXPECT_FALSE(std::binary_search(plans[j].tets.begin(), plans[j].tets.end(), plans[i].origin_tet));
    }
  bool second_peak = false;
  for (const CrackPlan& p : plans) second_peak |= std::abs(p.origin.x() - 6.5) < 0.3;
  EXPECT_TRUE(second_peak);
  EXPECT_EQ(plan_cracks(m, stress, mat, {.max_cracks = 1}).size(), 1u);
  EXPECT_TRUE(plan_cracks(m, stress, mat, {.max_cracks = 0}).empty());
}

TEST(PlanCracks, RegionDoesNotJumpGaps) {
  // Two separate bars side by side; a crack with a large radius stays in its own bar.
  TetMesh a = make_box_mesh({.max = Vec3(2, 1, 1), .cells = {4, 2, 2}});
  const TetMesh b = make_box_mesh({.min = Vec3(0, 1.2, 0), .max = Vec3(2, 2.2, 1), .cells = {4, 2, 2}});
  const Index n = a.num_nodes(), t = a.num_tets();
  for (const Vec3& p : b.positions) a.positions.push_back(p);
  for (TetIndices q : b.tets) {
    for (Index& v : q) v += n;
    a.tets.push_back(q);
  }
  const Material mat = test_material(1e6);
  const auto stress = uniaxial(a, Vec3::UnitX(), [](const Vec3& c) { return c.y() < 1.1 ? 3e6 : 0.0; });
  const auto plans = plan_cracks(a, stress, mat, {.brittleness = 10, .max_cracks = 1});
  ASSERT_EQ(plans.size(), 1u);
  for (Index e : plans[0].tets) EXPECT_LT(e, t);
}

TEST(StressHistory, SpikeVersusSustained) {
  const Mat3 s = 2e6 * Vec3::UnitX() * Vec3::UnitX().transpose();
  StressHistory spike(1, 0.01), sustained(1, 0.01);
  spike.update({s}, 0.001);
  for (int i = 0; i < 50; ++i) sustained.update({s}, 0.001);
  EXPECT_NEAR(spike.averaged()[0](0, 0), 2e6 * (1 - std::exp(-0.1)), 1e-6);
  EXPECT_NEAR(sustained.averaged()[0](0, 0), 2e6 * (1 - std::exp(-5.0)), 1e-3);
  // Only the sustained load reaches a strength of 1.5e6.
  EXPECT_LT(analyze_stress(spike.averaged()[0]).principal[0], 1.5e6);
  EXPECT_GT(analyze_stress(sustained.averaged()[0]).principal[0], 1.5e6);
  sustained.remap({0, 0, 0});
  ASSERT_EQ(sustained.averaged().size(), 3u);
  EXPECT_EQ(sustained.averaged()[2], sustained.averaged()[0]);
}

}  // namespace
}  // namespace shatter
