// Crack planning: the r_frac rule, origin order, several cracks per load, time-averaged stress.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "shatter/fem/material.h"
#include "shatter/fracture/crack.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/topology.h"
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

// Regions found in the body's face table are those found by searching the node incidence, small
// (sorted) and spanning most of the mesh (scanned in order), branching or not.
TEST(PlanCracks, TheFaceTableGivesTheSameRegions) {
  const TetMesh m = make_box_mesh({.max = Vec3(4, 1, 1), .cells = {12, 3, 3}, .jitter = 0.2});
  const TetFaces faces = compute_faces(m);
  const Material mat = test_material(1e6);
  const auto stress = uniaxial(m, Vec3::UnitX(), [](const Vec3& c) { return 1.5e6 - 0.2e6 * std::abs(c.x() - 1.3); });
  for (const bool branch : {false, true})
    for (const double fraction : {0.05, 1.0}) {
      const CrackOptions options{.brittleness = 4, .radius_fraction = fraction, .max_cracks = 3, .branch = branch};
      const std::vector<CrackPlan> searched = plan_cracks(m, stress, mat, options);
      FaceNeighborTable known;
      const std::vector<CrackPlan> tabled = plan_cracks(m, stress, mat, options, {}, {}, &faces, &known);
      ASSERT_EQ(known.size(), m.tets.size());
      ASSERT_EQ(searched.size(), tabled.size());
      ASSERT_GE(searched.size(), branch || fraction < 1 ? 2u : 1u);  // one region may take the whole bar
      for (std::size_t k = 0; k < searched.size(); ++k) {
        EXPECT_EQ(searched[k].origin_tet, tabled[k].origin_tet);
        EXPECT_EQ(searched[k].tets, tabled[k].tets);
        EXPECT_TRUE(std::is_sorted(tabled[k].tets.begin(), tabled[k].tets.end()));
      }
      if (fraction == 1.0) {
        EXPECT_GT(searched[0].tets.size() * 16, m.tets.size());
      }
    }
}

// Growing only the first region (PlanRegions::first) gives the same plans; a branching plan's later
// regions are left empty, a non-branching plan's are grown (its later origins must avoid them).
TEST(PlanCracks, FirstRegionOnlyKeepsThePlans) {
  const TetMesh m = make_box_mesh({.max = Vec3(4, 1, 1), .cells = {12, 3, 3}, .jitter = 0.2});
  const Material mat = test_material(1e6);
  const auto stress = uniaxial(m, Vec3::UnitX(), [](const Vec3& c) { return 1.5e6 - 0.2e6 * std::abs(c.x() - 1.3); });
  for (const bool branch : {false, true}) {
    const CrackOptions options{.brittleness = 4, .radius_fraction = 0.3, .max_cracks = 3, .branch = branch};
    const std::vector<CrackPlan> all = plan_cracks(m, stress, mat, options);
    const std::vector<CrackPlan> first =
        plan_cracks(m, stress, mat, options, {}, {}, nullptr, nullptr, PlanRegions::first);
    ASSERT_GE(all.size(), 2u);
    ASSERT_EQ(all.size(), first.size());
    for (std::size_t k = 0; k < all.size(); ++k) {
      EXPECT_EQ(all[k].origin_tet, first[k].origin_tet);
      EXPECT_EQ(all[k].normal, first[k].normal);
      EXPECT_EQ(all[k].radius, first[k].radius);
      EXPECT_FALSE(all[k].tets.empty());
      if (k == 0 || !branch) {
        EXPECT_EQ(all[k].tets, first[k].tets);
      } else {
        EXPECT_TRUE(first[k].tets.empty());
      }
    }
  }
}

// Neighbours carried through a cut are the cut mesh's own (face_neighbor), for most tets; a region
// grown in them is the one grown by searching.
TEST(CrackRegion, NeighborsCarriedThroughACutAreTheCutMeshs) {
  const TetMesh m = make_box_mesh({.max = Vec3(4, 1, 1), .cells = {12, 3, 3}, .jitter = 0.2});
  const FaceNeighborTable before = face_neighbor_table(compute_faces(m));
  std::vector<Index> region;
  for (Index e = 0; e < m.num_tets(); ++e)
    if (m.corners(e).row(0).mean() > 1.0 && m.corners(e).row(0).mean() < 3.0) region.push_back(e);
  const CutResult cut = cut_mesh(m, {.point = Vec3(2.05, 0.5, 0.5), .normal = Vec3(1, 0.3, 0.1).normalized()}, region);
  ASSERT_GT(cut.tets_split, 0);
  ASSERT_GT(cut.faces_cut, 0);
  FaceNeighborTable carried = carry_face_neighbors(m, before, cut);
  const NodeTets incidence = node_tets(cut.mesh);
  std::size_t known = 0;
  for (Index e = 0; e < cut.mesh.num_tets(); ++e)
    for (int k = 0; k < 4; ++k) {
      if (carried[e][k] == kUnknownNeighbor) continue;
      ++known;
      EXPECT_EQ(carried[e][k], face_neighbor(cut.mesh, incidence, e, k)) << "tet " << e << " face " << k;
    }
  EXPECT_GT(known, 4 * cut.mesh.tets.size() / 2);
  EXPECT_LT(known, 4 * cut.mesh.tets.size());
  // changed_tets lists exactly the input tets whose corners changed.
  std::vector<Index> changed;
  for (Index e = 0; e < m.num_tets(); ++e)
    if (cut.mesh.tets[e] != m.tets[e]) changed.push_back(e);
  EXPECT_EQ(cut.changed_tets, changed);
  EXPECT_GT(changed.size(), static_cast<std::size_t>(cut.tets_split));  // node copies too
  // The table is the rule of carry_face_neighbors applied to every tet (not only the changed ones).
  auto kept = [&](Index e) {
    if (e >= m.num_tets() || cut.tet_parent[e] != e) return false;
    for (int c = 0; c < 4; ++c) {
      const NodeOrigin& o = cut.node_origin[cut.mesh.tets[e][c]];
      if (o.a != o.b || o.a != m.tets[e][c]) return false;
    }
    return true;
  };
  for (Index e = 0; e < cut.mesh.num_tets(); ++e)
    for (int k = 0; k < 4; ++k) {
      Index want = kUnknownNeighbor;
      if (kept(e)) {
        const Index n = before[e][k];
        if (n == -1) {
          want = -1;
        } else if (n >= 0 && kept(n)) {
          bool shares = true;
          for (int j = 0; j < 3; ++j) {
            const Index v = cut.mesh.tets[e][kTetFaces[k][j]];
            const TetIndices& u = cut.mesh.tets[n];
            shares = shares && (u[0] == v || u[1] == v || u[2] == v || u[3] == v);
          }
          if (shares) want = n;
        }
      }
      EXPECT_EQ(carried[e][k], want) << "tet " << e << " face " << k;
    }
  const Vec3 centre(2.5, 0.5, 0.5);
  const Index origin = cut.mesh.num_tets() - 1;
  EXPECT_EQ(crack_region(cut.mesh, carried, origin, centre, 1.5),
            crack_region(cut.mesh, incidence, origin, centre, 1.5));
}

TEST(PlanCracks, PerTetStrengthPicksTheWeakestTetFirst) {
  const TetMesh m = make_box_mesh({.max = Vec3(8, 1, 1), .cells = {16, 2, 2}});
  const Material mat = test_material(1e6);
  // Peak tension 1.2 MPa at x = 2.6; strengths 1.1 MPa, but one tet near x = 6 holds only 0.5 MPa.
  const auto stress = uniaxial(m, Vec3::UnitX(), [](const Vec3& c) { return 1.2e6 - 0.1e6 * std::abs(c.x() - 2.6); });
  std::vector<double> strength(static_cast<std::size_t>(m.num_tets()), 1.1e6);
  Index weak = -1;
  for (Index e = 0; e < m.num_tets() && weak < 0; ++e)
    if (std::abs(m.corners(e).row(0).mean() - 6.1) < 0.2) weak = e;
  ASSERT_GE(weak, 0);
  strength[static_cast<std::size_t>(weak)] = 0.5e6;
  const CrackOptions options{.brittleness = 0.5, .max_cracks = 2};
  const std::vector<CrackPlan> plans = plan_cracks(m, stress, mat, options, {}, strength);
  ASSERT_EQ(plans.size(), 2u);
  EXPECT_EQ(plans[0].origin_tet, weak);  // 0.86 / 0.5 = 1.7 times its strength, before 1.2 / 1.1
  EXPECT_NEAR(plans[1].origin.x(), 2.6, 0.3);
  const double body = m.bounds().extent().norm();
  const double r_min = options.min_radius_edges * 0.5 * std::sqrt(3.0);  // the cubes' diagonal
  // The radius follows each origin's own excess over its own strength.
  EXPECT_NEAR(plans[0].radius, body * 0.5 * (plans[0].stress / 0.5e6 - 1), 1e-9);
  EXPECT_GT(plans[0].radius, r_min);
  EXPECT_NEAR(plans[1].radius, r_min, 1e-9);  // 0.5 (1.2 / 1.1 - 1) of the body is less
  // Every tet at the material's strength plans exactly what no per-tet strengths plan.
  const std::vector<double> same(static_cast<std::size_t>(m.num_tets()), 1e6);
  const std::vector<CrackPlan> a = plan_cracks(m, stress, mat, options, {}, same);
  const std::vector<CrackPlan> b = plan_cracks(m, stress, mat, options);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].origin_tet, b[k].origin_tet);
    EXPECT_EQ(a[k].radius, b[k].radius);
    EXPECT_EQ(a[k].tets, b[k].tets);
  }
  // Strong tets do not crack under a tension over the material's strength.
  const std::vector<double> strong(static_cast<std::size_t>(m.num_tets()), 2e6);
  EXPECT_TRUE(plan_cracks(m, stress, mat, options, {}, strong).empty());
}

TEST(TensileStrengths, FollowWeibullsLawAndTheSeed) {
  Material mat = test_material(1e6);
  const TetMesh even = make_box_mesh({.max = Vec3(2, 1, 1), .cells = {40, 20, 20}});  // 96,000 equal tets
  EXPECT_TRUE(sample_tensile_strengths(even, mat, 1).empty());                        // no modulus: one strength
  mat.weibull_modulus = 8;
  const std::vector<double> s = sample_tensile_strengths(even, mat, 1);
  ASSERT_EQ(s.size(), even.tets.size());
  // The empirical distribution against P(s < x sigma_t) = 1 - exp(-ln 2 x^m); the
  // Dvoretzky-Kiefer-Wolfowitz bound at 96,000 samples is 0.008 with probability 1 - 1e-5 (and
  // the draw is deterministic).
  for (const double x : {0.7, 0.85, 0.95, 1.0, 1.05, 1.15, 1.3}) {
    const auto below = static_cast<double>(std::count_if(s.begin(), s.end(), [&](double v) { return v < x * 1e6; }));
    EXPECT_NEAR(below / static_cast<double>(s.size()), 1 - std::exp(-std::numbers::ln2 * std::pow(x, 8.0)), 0.008)
        << "at " << x << " sigma_t";
  }
  for (const double v : s) ASSERT_TRUE(std::isfinite(v) && v > 0);
  EXPECT_EQ(sample_tensile_strengths(even, mat, 1), s);  // the same seed, the same strengths
  const std::vector<double> other = sample_tensile_strengths(even, mat, 2);
  std::size_t equal = 0;
  for (std::size_t e = 0; e < s.size(); ++e) equal += s[e] == other[e];
  EXPECT_EQ(equal, 0u);
  // Uneven tets: (s / sigma_t)^m V_e / V_mean follows the law of a tet of mean volume (median 1),
  // and larger tets are weaker.
  const TetMesh jittered = make_box_mesh({.max = Vec3(2, 1, 1), .cells = {20, 10, 10}, .jitter = 0.3, .seed = 4});
  const std::vector<double> j = sample_tensile_strengths(jittered, mat, 7);
  double mean = 0;
  for (Index e = 0; e < jittered.num_tets(); ++e) mean += signed_volume(jittered, e) / jittered.num_tets();
  int below_median = 0;
  for (Index e = 0; e < jittered.num_tets(); ++e)
    below_median += std::pow(j[e] / 1e6, 8.0) * signed_volume(jittered, e) / mean < 1;
  EXPECT_NEAR(below_median / static_cast<double>(jittered.num_tets()), 0.5, 0.02);
  mat.tensile_strength = kInfinity;
  EXPECT_TRUE(sample_tensile_strengths(even, mat, 1).empty());  // never cracks: nothing to scatter
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
