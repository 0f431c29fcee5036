// Plasticity: yield by von Mises, permanent set past yield, spring-back below, rigid motions
// removed, rest tets kept positive, ductile failure after accumulated plastic strain.
#include <gtest/gtest.h>

#include "shatter/core/random.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fem/material.h"
#include "shatter/fracture/plasticity.h"
#include "shatter/fracture/stress.h"
#include "shatter/mesh/generate.h"
#include "support/test_support.h"

namespace shatter {
namespace {

Material soft_metal() {
  Material m;
  m.name = "test_metal";
  m.youngs_modulus = 1e9;
  m.poisson_ratio = 0.3;
  m.density = 8000;
  m.tensile_strength = 1e8;
  m.yield_stress = 1e6;
  m.fracture_toughness = kInfinity;
  return m;
}

std::vector<Vec3> affine(const TetMesh& m, const Mat3& F, const Vec3& t = Vec3::Zero()) {
  std::vector<Vec3> x;
  for (const Vec3& p : m.positions) x.push_back(F * p + t);
  return x;
}

TEST(Plasticity, BelowYieldSpringsBack) {
  const TetMesh m = make_box_mesh({.max = Vec3(4, 1, 1), .cells = {8, 2, 2}});
  const Material mat = soft_metal();
  const double eps = 0.9 * mat.yield_stress / mat.youngs_modulus;  // uniaxial: sigma = E eps < yield
  const Mat3 F = Vec3(1 + eps, 1 - mat.poisson_ratio * eps, 1 - mat.poisson_ratio * eps).asDiagonal();
  const auto x = affine(m, F);
  const auto stress = compute_stresses(make_fem_model(m, mat, ModelKind::linear), x);
  const PlasticResult r = apply_plasticity(make_fem_model(m, mat, ModelKind::linear), m.positions, x, stress, {});
  EXPECT_TRUE(r.yielded.empty());
  EXPECT_TRUE(r.moved_nodes.empty());
  EXPECT_EQ(r.rest_positions, m.positions);
  for (double p : r.plastic_strain) EXPECT_EQ(p, 0.0);
}

TEST(Plasticity, PastYieldKeepsAPermanentSet) {
  const TetMesh m = make_box_mesh({.max = Vec3(4, 1, 1), .cells = {8, 2, 2}});
  const Material mat = soft_metal();
  const double eps = 3 * mat.yield_stress / mat.youngs_modulus;
  const Mat3 F = Vec3(1 + eps, 1 - mat.poisson_ratio * eps, 1 - mat.poisson_ratio * eps).asDiagonal();
  // A rotated, translated copy of the stretched bar must give the same rest update.
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const auto x = affine(m, F);
  const auto xr = affine(m, R * F, Vec3(5, -3, 2));
  const PlasticityOptions options{.creep = 0.5};
  const PlasticResult a = apply_plasticity(make_fem_model(m, mat, ModelKind::linear), m.positions, x,
                                           compute_stresses(make_fem_model(m, mat, ModelKind::linear), x), {}, options);
  const PlasticResult b =
      apply_plasticity(make_fem_model(m, mat, ModelKind::linear), m.positions, xr,
                       compute_stresses(make_fem_model(m, mat, ModelKind::corotated), xr), {}, options);
  const PlasticResult c =
      apply_plasticity(make_fem_model(m, mat, ModelKind::linear), m.positions, x,
                       compute_stresses(make_fem_model(m, mat, ModelKind::corotated), x), {}, options);
  ASSERT_EQ(a.yielded.size(), m.tets.size());
  ASSERT_EQ(b.yielded.size(), m.tets.size());
  // Uniform stress: every node gets w = creep (1 - sigma_y / sigma_vm); sigma_vm = E eps = 3 sigma_y.
  // Every tet yielded, so the rigid fit uses all nodes: the stretch is about the centroid.
  const double w = 0.5 * (1 - 1.0 / 3.0);
  const Vec3 centre(2, 0.5, 0.5);
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const Vec3 expected = m.positions[i] + w * (F - Mat3::Identity()) * (m.positions[i] - centre);
    EXPECT_LT((a.rest_positions[i] - expected).norm(), 1e-12);
    EXPECT_LT((b.rest_positions[i] - c.rest_positions[i]).norm(), 1e-12);
  }
  const Aabb box = [&] {
    Aabb bb;
    for (const Vec3& p : a.rest_positions) bb.extend(p);
    return bb;
  }();
  EXPECT_NEAR(box.extent().x(), 4 * (1 + w * eps), 1e-12);
  EXPECT_NEAR(a.plastic_strain[0], w * 3 * mat.yield_stress / mat.youngs_modulus, 1e-12);
  EXPECT_TRUE(a.failed.empty());
  // Unloading from the new rest shape: the stress at the same deformed shape is lower.
  TetMesh new_rest = m;
  new_rest.positions = a.rest_positions;
  const auto after = compute_stresses(make_fem_model(new_rest, mat, ModelKind::linear), x);
  EXPECT_LT(after[0].von_mises, compute_stresses(make_fem_model(m, mat, ModelKind::linear), x)[0].von_mises);
  // Repeated events accumulate plastic strain until the tets fail (ductile crack origins).
  std::vector<double> strain;
  int events = 0;
  PlasticResult r;
  do {
    r = apply_plasticity(make_fem_model(m, mat, ModelKind::linear), m.positions, x,
                         compute_stresses(make_fem_model(m, mat, ModelKind::linear), x), strain,
                         {.creep = 0.5, .max_plastic_strain = 0.0105});
    strain = r.plastic_strain;
    ++events;
  } while (r.failed.empty() && events < 100);
  EXPECT_EQ(r.failed.size(), m.tets.size());
  EXPECT_EQ(events, static_cast<int>(std::floor(0.0105 / (w * 3e-3))) + 1);
}

TEST(Plasticity, ElasticPartStaysPut) {
  // Only the right half is stretched past yield; the left half (elastic, as if anchored) keeps its
  // rest positions and the permanent set is relative to it.
  const TetMesh m = make_box_mesh({.max = Vec3(4, 1, 1), .cells = {8, 2, 2}});
  const Material mat = soft_metal();
  const double eps = 3 * mat.yield_stress / mat.youngs_modulus;
  std::vector<Vec3> x = m.positions;
  for (Vec3& p : x)
    if (p.x() > 2) p.x() += eps * (p.x() - 2);
  const PlasticResult r = apply_plasticity(make_fem_model(m, mat, ModelKind::linear), m.positions, x,
                                           compute_stresses(make_fem_model(m, mat, ModelKind::stvk), x), {});
  ASSERT_FALSE(r.yielded.empty());
  EXPECT_LT((r.rotation - Mat3::Identity()).norm(), 1e-12);
  for (Index i = 0; i < m.num_nodes(); ++i) {
    if (m.positions[i].x() <= 2) {
      EXPECT_EQ(r.rest_positions[i], m.positions[i]);
    } else {
      EXPECT_GT(r.rest_positions[i].x(), m.positions[i].x());
      EXPECT_LT(r.rest_positions[i].x(), x[i].x());
    }
  }
}

TEST(Plasticity, RestTetsStayPositive) {
  TetMesh m = make_box_mesh({.max = Vec3(1, 1, 1), .cells = {3, 3, 3}, .jitter = 0.2});
  Material mat = soft_metal();
  // A wild deformed state (some tets inverted) with full creep.
  Random rng(3);
  std::vector<Vec3> x = m.positions;
  for (Vec3& p : x) p += rng.uniform_vec3(-0.4, 0.4);
  const auto stress = compute_stresses(make_fem_model(m, mat, ModelKind::stvk), x);
  const PlasticResult r = apply_plasticity(make_fem_model(m, mat, ModelKind::linear), m.positions, x, stress, {},
                                           {.creep = 1.0, .min_volume_fraction = 0.2});
  EXPECT_FALSE(r.moved_nodes.empty());
  for (Index e = 0; e < m.num_tets(); ++e) {
    const TetIndices& t = m.tets[e];
    const double v =
        signed_volume(r.rest_positions[t[0]], r.rest_positions[t[1]], r.rest_positions[t[2]], r.rest_positions[t[3]]);
    EXPECT_GE(v, 0.2 * signed_volume(m, e));
  }
}

}  // namespace
}  // namespace shatter
