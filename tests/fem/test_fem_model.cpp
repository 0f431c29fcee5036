#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "fem_test_util.h"
#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/core/simd.h"
#include "shatter/fem/fem_model.h"
#include "shatter/mesh/generate.h"
#include "support/test_support.h"

namespace shatter {
namespace {

using test::kAllModels;

Material test_material() { return *material_preset("granite"); }

std::vector<Vec3> affine(const std::vector<Vec3>& p, const Mat3& A, const Vec3& t) {
  std::vector<Vec3> x(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) x[i] = A * p[i] + t;
  return x;
}

double max_norm(const std::vector<Vec3>& v) {
  double m = 0;
  for (const Vec3& a : v) m = std::max(m, a.norm());
  return m;
}

double max_diff(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).norm());
  return m;
}

TEST(FemModel, LumpedMassAndRestData) {
  const TetMesh mesh = make_box_mesh({.max = Vec3(2, 1, 0.5), .cells = {4, 3, 2}, .jitter = 0.2});
  const Material mat = test_material();
  const FemModel model = make_fem_model(mesh, mat, ModelKind::stvk);
  EXPECT_EQ(model.num_tets(), mesh.num_tets());
  EXPECT_EQ(model.num_nodes, mesh.num_nodes());
  double mass = 0;
  for (double m : model.node_mass) {
    EXPECT_GT(m, 0);
    mass += m;
  }
  EXPECT_NEAR(mass, mat.density * 1.0, 1e-12 * mat.density);
  EXPECT_EQ(model.lame.mu, lame_parameters(mat).mu);
}

// Patch test: a jittered box under an affine map x = A m + t has the same F in every tet, and every
// interior node's net force is zero to round-off (the boundary nodes carry the traction).
TEST(FemModel, PatchTest) {
  Random rng(21);
  const TetMesh mesh = make_box_mesh({.cells = {4, 4, 4}, .jitter = 0.2, .seed = 3});
  for (ModelKind kind : kAllModels) {
    const FemModel model = make_fem_model(mesh, test_material(), kind);
    Mat3 A = Mat3::Identity();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) A(i, j) += rng.uniform(-0.01, 0.01);
    const std::vector<Vec3> x = affine(mesh.positions, A, rng.uniform_vec3(-1, 1));
    for (std::size_t e = 0; e < model.tets.size(); ++e) {
      Mat34 xe;
      for (int k = 0; k < 4; ++k) xe.col(k) = x[static_cast<std::size_t>(model.tets[e][k])];
      EXPECT_LT((deformation_gradient(model.rest[e], xe) - A).norm(), 1e-13);
    }
    std::vector<Vec3> f_ref, f_fast;
    internal_forces_reference(model, x, f_ref);
    internal_forces(model, x, f_fast);
    const double scale = max_norm(f_ref);
    ASSERT_GT(scale, 0);
    int interior = 0;
    for (Index n = 0; n < model.num_nodes; ++n) {
      const Vec3& p = mesh.positions[static_cast<std::size_t>(n)];
      if ((p.array() <= 1e-12).any() || (p.array() >= 1 - 1e-12).any()) continue;
      ++interior;
      EXPECT_LT(f_ref[static_cast<std::size_t>(n)].norm(), 1e-12 * scale) << to_string(kind) << " node " << n;
      EXPECT_LT(f_fast[static_cast<std::size_t>(n)].norm(), 1e-12 * scale) << to_string(kind) << " node " << n;
    }
    EXPECT_EQ(interior, 27);
  }
}

TEST(FemModel, AcceleratedMatchesReferenceOnAnyThreadCount) {
  Random rng(22);
  for (auto pattern : {BoxMeshDef::Pattern::six, BoxMeshDef::Pattern::five}) {
    // Large enough for several blocks and a parallel gather.
    const TetMesh mesh =
        make_box_mesh({.max = Vec3(1, 0.6, 0.4), .cells = {16, 10, 7}, .pattern = pattern, .jitter = 0.2, .seed = 9});
    for (ModelKind kind : kAllModels) {
      const FemModel model = make_fem_model(mesh, test_material(), kind);
      std::vector<Vec3> x = affine(mesh.positions, test::random_deformation(rng, 0.01), Vec3(1, 2, 3));
      for (Vec3& p : x) p += rng.uniform_vec3(-1e-3, 1e-3);
      std::vector<Vec3> f_ref, f1, f2, f3;
      internal_forces_reference(model, x, f_ref);
      const int saved = num_threads();
      set_num_threads(1);
      internal_forces(model, x, f1);
      const double energy1 = total_energy(model, x);
      set_num_threads(2);
      internal_forces(model, x, f2);
      const double energy2 = total_energy(model, x);
      set_num_threads(3);
      internal_forces(model, x, f3);
      set_num_threads(saved);
      EXPECT_EQ(energy1, energy2) << to_string(kind);
      double energy_ref = 0;
      for (std::size_t e = 0; e < model.tets.size(); ++e) {
        Mat34 xe;
        for (int k = 0; k < 4; ++k) xe.col(k) = x[static_cast<std::size_t>(model.tets[e][k])];
        energy_ref += tet_energy(kind, model.lame, model.rest[e], xe);
      }
      EXPECT_NEAR(energy1, energy_ref, 1e-12 * energy_ref) << to_string(kind);
      const double scale = max_norm(f_ref);
      EXPECT_LT(max_diff(f1, f_ref), 1e-12 * scale) << to_string(kind);
      // Bitwise the same on every thread count.
      EXPECT_EQ(f1, f2) << to_string(kind);
      EXPECT_EQ(f1, f3) << to_string(kind);
      // Net force of a free body in equilibrium with nothing: zero.
      Vec3 total = Vec3::Zero();
      for (const Vec3& f : f1) total += f;
      EXPECT_LT(total.norm(), 1e-12 * scale * std::sqrt(static_cast<double>(f1.size())));
    }
  }
}

// The baseline (SSE) and AVX2 kernels do the same operations in the same order: the same bits for
// every model, from small strains to the corotated model's inverted and degenerate tets (where
// its lanes fall back to the SVD). Where the CPU has no AVX2 both runs take the baseline.
TEST(FemModel, BaselineAndAvx2KernelsGiveTheSameBits) {
  Random rng(25);
  const TetMesh mesh = make_box_mesh({.max = Vec3(1, 0.6, 0.4), .cells = {9, 6, 5}, .jitter = 0.2, .seed = 5});
  const SimdIsa saved = simd_isa();
  for (ModelKind kind : kAllModels) {
    const FemModel model = make_fem_model(mesh, test_material(), kind);
    for (double amount : {0.001, 0.5}) {
      SCOPED_TRACE(std::string(to_string(kind)) + " " + std::to_string(amount));
      std::vector<Vec3> x = affine(mesh.positions, test::random_deformation(rng, amount), Vec3(1, 2, 3));
      for (Vec3& p : x) p += rng.uniform_vec3(-0.05, 0.05) * amount;
      for (std::size_t i = 5; i < x.size(); i += 41) x[i] += Vec3(0.3, -0.2, 0.25) * amount;  // inverts some
      std::vector<Vec3> f_baseline, f_avx2, f_ref;
      set_simd_isa(SimdIsa::baseline);
      EXPECT_EQ(simd_isa(), SimdIsa::baseline);
      internal_forces(model, x, f_baseline);
      set_simd_isa(SimdIsa::avx2);
      internal_forces(model, x, f_avx2);
      set_simd_isa(saved);
      EXPECT_EQ(f_baseline, f_avx2);
      internal_forces_reference(model, x, f_ref);
      EXPECT_LT(max_diff(f_baseline, f_ref), 1e-10 * max_norm(f_ref));
    }
  }
}

// A plastic update of some rest shapes keeps both force paths in agreement and makes the new rest
// shape stress free (StVK's rotated frames and the linear model's Dm^-1 both follow).
void set_tet_rest_check(ModelKind kind) {
  SCOPED_TRACE(to_string(kind));
  Random rng(24);
  const TetMesh mesh = make_box_mesh({.cells = {3, 3, 3}, .jitter = 0.2});
  FemModel model = make_fem_model(mesh, test_material(), kind);
  const std::vector<double> mass = model.node_mass;
  std::vector<Vec3> x = mesh.positions;
  for (Vec3& p : x) p += rng.uniform_vec3(-0.02, 0.02);
  for (Index e = 0; e < model.num_tets(); e += 3) {
    Mat34 xe;
    for (int k = 0; k < 4; ++k) xe.col(k) = x[static_cast<std::size_t>(model.tets[static_cast<std::size_t>(e)][k])];
    set_tet_rest(model, e, xe);
    EXPECT_LT((deformation_gradient(model.rest[static_cast<std::size_t>(e)], xe) - Mat3::Identity()).norm(), 1e-12);
  }
  EXPECT_EQ(model.node_mass, mass);
  std::vector<Vec3> f_ref, f_fast;
  internal_forces_reference(model, x, f_ref);
  internal_forces(model, x, f_fast);
  EXPECT_LT(max_diff(f_fast, f_ref), 1e-12 * max_norm(f_ref));
  // Rest shape = current shape everywhere: no force at all.
  for (Index e = 0; e < model.num_tets(); ++e) {
    Mat34 xe;
    for (int k = 0; k < 4; ++k) xe.col(k) = x[static_cast<std::size_t>(model.tets[static_cast<std::size_t>(e)][k])];
    set_tet_rest(model, e, xe);
  }
  internal_forces(model, x, f_fast);
  EXPECT_LT(max_norm(f_fast), 1e-12 * max_norm(f_ref));
  EXPECT_LT(total_energy(model, x), 1e-20);
}

// The corotated fast path (four-lane polar decomposition) against the reference where its Newton
// iteration works hardest or cannot work: large rotations, stretches of 3x, squashed tets and
// inverted ones (those lanes fall back to the SVD), and per-tet deformations that differ within a
// group of four.
TEST(FemModel, CorotatedFastPathUnderLargeDeformationAndInversion) {
  Random rng(31);
  const TetMesh mesh = make_box_mesh({.max = Vec3(1, 0.5, 0.5), .cells = {12, 6, 6}, .jitter = 0.2, .seed = 4});
  const FemModel model = make_fem_model(mesh, test_material(), ModelKind::corotated);
  for (double amount : {0.0, 0.3, 2.0}) {
    SCOPED_TRACE(amount);
    std::vector<Vec3> x = affine(mesh.positions, test::random_deformation(rng, amount), Vec3(-3, 1, 2));
    for (Vec3& p : x) p += rng.uniform_vec3(-0.05, 0.05);
    // Flatten a few nodes onto their neighbours and push others through: degenerate and inverted tets.
    for (std::size_t i = 0; i < x.size(); i += 37) x[i] = x[(i + 1) % x.size()];
    for (std::size_t i = 5; i < x.size(); i += 41) x[i] += Vec3(0.3, -0.2, 0.25);
    std::vector<Vec3> f_ref, f1, f2;
    internal_forces_reference(model, x, f_ref);
    const int saved = num_threads();
    set_num_threads(1);
    internal_forces(model, x, f1);
    set_num_threads(2);
    internal_forces(model, x, f2);
    set_num_threads(saved);
    EXPECT_LT(max_diff(f1, f_ref), 1e-10 * max_norm(f_ref));
    EXPECT_EQ(f1, f2);
    for (const Vec3& f : f1) ASSERT_TRUE(f.allFinite());
  }
}

TEST(FemModel, SetTetRest) {
  for (ModelKind kind : {ModelKind::stvk, ModelKind::linear, ModelKind::corotated}) set_tet_rest_check(kind);
}

// A model that takes the rest data of the tets of another (a fragment from its parent) equals one
// built from its own mesh to round-off: the same masses, rest data and forces. The source mesh is
// the target moved and with its tets reversed, so that lanes of the packed data move between
// groups of four.
TEST(FemModel, RestDataTakenFromAMovedModel) {
  Random rng(5);
  const TetMesh mesh = make_box_mesh({.max = Vec3(0.5, 0.3, 0.2), .cells = {5, 3, 2}, .jitter = 0.2});
  TetMesh moved = mesh;
  const Vec3 shift(0.7, -2.5, 11.0);
  for (Vec3& p : moved.positions) p += shift;
  std::reverse(moved.tets.begin(), moved.tets.end());
  const auto nt = static_cast<Index>(mesh.tets.size());
  for (ModelKind kind : kAllModels) {
    const FemModel source = make_fem_model(moved, test_material(), kind);
    std::vector<Index> from(static_cast<std::size_t>(nt));
    for (Index e = 0; e < nt; ++e) from[e] = e % 3 == 0 ? -1 : nt - 1 - e;  // every third computed
    const FemModel taken = make_fem_model(mesh, test_material(), kind, {.model = &source, .tet = from});
    const FemModel built = make_fem_model(mesh, test_material(), kind);
    for (Index e = 0; e < nt; ++e) {
      EXPECT_NEAR(taken.rest[e].volume, built.rest[e].volume, 1e-12 * built.rest[e].volume);
      EXPECT_LT((taken.rest[e].Dm_inv - built.rest[e].Dm_inv).norm(), 1e-10 * built.rest[e].Dm_inv.norm());
      if (from[e] >= 0) {
        EXPECT_EQ(taken.rest[e].Dm_inv, source.rest[from[e]].Dm_inv);
      } else {
        EXPECT_EQ(taken.rest[e].Dm_inv, built.rest[e].Dm_inv);
      }
    }
    for (std::size_t i = 0; i < built.node_mass.size(); ++i)
      EXPECT_NEAR(taken.node_mass[i], built.node_mass[i], 1e-12 * built.node_mass[i]);
    std::vector<Vec3> x = affine(mesh.positions, test::random_deformation(rng, 0.01), Vec3(0.1, 0.2, 0.3));
    std::vector<Vec3> f_taken, f_built;
    internal_forces(taken, x, f_taken);
    internal_forces(built, x, f_built);
    EXPECT_LT(max_diff(f_taken, f_built), 1e-9 * max_norm(f_built)) << to_string(kind);
  }
}

// The global force is the gradient of the total energy (central differences on a few nodes).
TEST(FemModel, ForceIsGradientOfTotalEnergy) {
  Random rng(23);
  const TetMesh mesh = make_box_mesh({.cells = {3, 3, 2}, .jitter = 0.2});
  for (ModelKind kind : kAllModels) {
    const FemModel model = make_fem_model(mesh, test_material(), kind);
    std::vector<Vec3> x = mesh.positions;
    for (Vec3& p : x) p += rng.uniform_vec3(-0.05, 0.05);
    std::vector<Vec3> f;
    internal_forces(model, x, f);
    const double h = 1e-6;
    for (int trial = 0; trial < 10; ++trial) {
      const std::size_t n = rng.below(x.size());
      for (int a = 0; a < 3; ++a) {
        std::vector<Vec3> xp = x, xm = x;
        xp[n][a] += h;
        xm[n][a] -= h;
        const double fd = (total_energy(model, xp) - total_energy(model, xm)) / (2 * h);
        EXPECT_NEAR(f[n][a], fd, 1e-6 * max_norm(f)) << to_string(kind);
      }
    }
    double sum = 0;
    for (std::size_t e = 0; e < model.tets.size(); ++e) {
      Mat34 xe;
      for (int k = 0; k < 4; ++k) xe.col(k) = x[static_cast<std::size_t>(model.tets[e][k])];
      sum += tet_energy(kind, model.lame, model.rest[e], xe);
    }
    EXPECT_NEAR(total_energy(model, x), sum, 1e-12 * sum);
    const int saved = num_threads();
    set_num_threads(1);
    const double e1 = total_energy(model, x);
    set_num_threads(2);
    const double e2 = total_energy(model, x);
    set_num_threads(saved);
    EXPECT_EQ(e1, e2);
  }
}

}  // namespace
}  // namespace shatter
