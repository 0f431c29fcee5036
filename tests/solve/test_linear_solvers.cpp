// Block pattern, refill, Dirichlet elimination and the three linear solvers against dense references.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>

#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/core/simd.h"
#include "shatter/fem/assembly.h"
#include "shatter/fem/fem_model.h"
#include "shatter/solve/block_ldlt.h"
#include "shatter/solve/linear_solvers.h"
#include "solve_test_util.h"
#include "support/test_support.h"

namespace shatter {
namespace {

// Anchors: x = 0 face held, a few nodes partly held (rollers), one node free of all.
std::vector<AnchorMask> mixed_anchors(const TetMesh& mesh) {
  std::vector<AnchorMask> a(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < a.size(); ++v) {
    if (mesh.positions[v].x() == 0.0)
      a[v] = anchor_all;
    else if (v % 7 == 3)
      a[v] = 2;  // y held
    else if (v % 11 == 5)
      a[v] = 1 | 4;  // x and z held
  }
  return a;
}

// The x = 0 face held, the rest free.
std::vector<AnchorMask> held_at_x0(const TetMesh& mesh) {
  std::vector<AnchorMask> anchors(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < anchors.size(); ++v)
    if (mesh.positions[v].x() == 0.0) anchors[v] = anchor_all;
  return anchors;
}

// Dense 3N x 3N stiffness from triplets over all tets (no anchors).
Eigen::MatrixXd dense_full(Index num_nodes, const std::vector<TetIndices>& tets, const std::vector<Mat12>& ke) {
  std::vector<Eigen::Triplet<double>> trip;
  for (std::size_t e = 0; e < tets.size(); ++e)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c)
            trip.emplace_back(3 * tets[e][i] + r, 3 * tets[e][j] + c, ke[e](3 * i + r, 3 * j + c));
  Eigen::SparseMatrix<double> k(3 * num_nodes, 3 * num_nodes);
  k.setFromTriplets(trip.begin(), trip.end());
  return Eigen::MatrixXd(k);
}

// Global DOF (3 v + c) of each reduced row, -1 for an identity row of a held component.
std::vector<Index> reduced_to_global(const BlockSparseMatrix& m) {
  std::vector<Index> g(static_cast<std::size_t>(m.size()));
  for (Index a = 0; a < m.num_active(); ++a) {
    const Index v = m.node_of_active()[a];
    for (int c = 0; c < 3; ++c) g[3 * a + c] = (m.anchors()[v] & (1u << c)) ? -1 : 3 * v + c;
  }
  return g;
}

std::vector<Mat12> random_spd_elements(std::size_t count, std::uint64_t seed) {
  Random rng(seed);
  std::vector<Mat12> ke(count);
  for (Mat12& k : ke) {
    Mat12 g;
    for (int i = 0; i < 12; ++i)
      for (int j = 0; j < 12; ++j) g(i, j) = rng.uniform(-1.0, 1.0);
    k = g * g.transpose() + 0.05 * Mat12::Identity();
  }
  return ke;
}

// Greedy colours beyond one 64-bit word: 150 tets round one hub node need 150 colours, each
// tet the next one; a second fan beside it, sharing no node with the first, reuses them; and the
// block pattern still matches a triplet assembly.
TEST(Assembly, ColoursBeyondSixtyFourAndTheirPattern) {
  TetMesh mesh;
  constexpr int kFan = 150;
  for (int fan = 0; fan < 2; ++fan) {
    const auto hub = static_cast<Index>(mesh.positions.size());
    const Vec3 centre(3.0 * fan, 0, 0);
    mesh.positions.push_back(centre);
    mesh.positions.push_back(centre + Vec3(0, 0, 1));
    const auto ring = static_cast<Index>(mesh.positions.size());
    for (int k = 0; k < kFan; ++k) {
      const double angle = 2 * std::numbers::pi * k / kFan;
      mesh.positions.push_back(centre + Vec3(std::cos(angle), std::sin(angle), 0));
    }
    for (int k = 0; k < kFan; ++k) mesh.tets.push_back({hub, ring + k, ring + (k + 1) % kFan, hub + 1});
  }
  const std::vector<AnchorMask> anchors(mesh.positions.size(), anchor_none);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  ASSERT_EQ(m.num_colors(), kFan);
  for (Index c = 0; c < m.num_colors(); ++c) {
    ASSERT_EQ(m.color_ptr()[c + 1] - m.color_ptr()[c], 2);
    EXPECT_EQ(m.active_tets()[m.color_ptr()[c]], c);             // fan 0: tet c takes colour c
    EXPECT_EQ(m.active_tets()[m.color_ptr()[c] + 1], kFan + c);  // fan 1 reuses them
  }
  const std::vector<Mat12> ke = random_spd_elements(mesh.tets.size(), 5);
  m.refill([&](Index e) { return ke[e]; });
  const Eigen::MatrixXd full = dense_full(mesh.num_nodes(), mesh.tets, ke);
  const Eigen::MatrixXd reduced = Eigen::MatrixXd(m.matrix());
  ASSERT_EQ(reduced.rows(), full.rows());  // nothing held: every node active, in node order
  EXPECT_LE((reduced - full).cwiseAbs().maxCoeff(), 1e-12 * full.cwiseAbs().maxCoeff());
}

TEST(Assembly, PatternRefillEqualsTripletAssembly) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.5, 0.4), {4, 3, 2}, 0.2);
  const std::vector<AnchorMask> anchors = mixed_anchors(mesh);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  ASSERT_GT(m.num_active(), 0);
  EXPECT_TRUE(m.has_partial_anchors());
  // Colours: no two tets of one colour share a node.
  for (Index c = 0; c < m.num_colors(); ++c) {
    std::vector<int> seen(mesh.positions.size(), 0);
    for (Index s = m.color_ptr()[c]; s < m.color_ptr()[c + 1]; ++s)
      for (Index v : mesh.tets[m.active_tets()[s]]) EXPECT_EQ(seen[v]++, 0);
  }
  const std::vector<Mat12> ke = random_spd_elements(mesh.tets.size(), 3);
  for (int round = 0; round < 2; ++round) {  // the second refill must not accumulate
    m.refill([&](Index e) { return ke[e]; });
  }
  const Eigen::MatrixXd full = dense_full(mesh.num_nodes(), mesh.tets, ke);
  const std::vector<Index> g = reduced_to_global(m);
  const Eigen::MatrixXd reduced = Eigen::MatrixXd(m.matrix());
  double max_err = 0, scale = full.cwiseAbs().maxCoeff();
  for (Index i = 0; i < m.size(); ++i)
    for (Index j = 0; j < m.size(); ++j) {
      double expect;
      if (g[i] < 0 || g[j] < 0)
        expect = (i == j) ? 1.0 : 0.0;
      else
        expect = full(g[i], g[j]);
      max_err = std::max(max_err, std::abs(reduced(i, j) - expect));
    }
  EXPECT_LE(max_err, 1e-14 * scale);
  // The block view reads the same values.
  for (Index a = 0; a < m.num_active(); ++a)
    for (Index k = m.block_ptr()[a]; k < m.block_ptr()[a + 1]; ++k) {
      const Index b = m.block_col()[k];
      EXPECT_EQ((m.block(a, k) - reduced.block(3 * a, 3 * b, 3, 3)).norm(), 0.0);
    }
  // multiply() equals the dense product.
  Random rng(5);
  Eigen::VectorXd x(m.size());
  for (Index i = 0; i < m.size(); ++i) x[i] = rng.uniform(-1.0, 1.0);
  Eigen::VectorXd y;
  m.multiply(x, y);
  EXPECT_LE((y - reduced * x).norm(), 1e-12 * (reduced * x).norm());
}

TEST(Assembly, StiffnessRefillEqualsElementTriplets) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.3, 0.3), {5, 2, 2}, 0.15);
  const FemModel model = make_fem_model(mesh, test::test_material(), ModelKind::stvk);
  Random rng(9);
  std::vector<Vec3> x = mesh.positions;
  for (Vec3& p : x) {
    // Named draws fix the order (constructor arguments are evaluated in an unspecified order).
    const double dz = rng.uniform(-1.0, 1.0), dy = rng.uniform(-1.0, 1.0), dx = rng.uniform(-1.0, 1.0);
    p += 0.02 * Vec3(dx, dy, dz);
  }
  const std::vector<AnchorMask> anchors = mixed_anchors(mesh);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  // Exact stiffness: equals the triplet assembly of tet_stiffness.
  {
    assemble_stiffness(model, x, AssemblyOptions{.project_psd = false}, m);
    std::vector<Mat12> ke(mesh.tets.size());
    for (std::size_t e = 0; e < ke.size(); ++e) {
      Mat34 xe;
      for (int q = 0; q < 4; ++q) xe.col(q) = x[mesh.tets[e][q]];
      const Mat12 k = tet_stiffness(model.model, model.lame, model.rest[e], xe);
      ke[e] = 0.5 * (k + k.transpose());
    }
    const Eigen::MatrixXd full = dense_full(mesh.num_nodes(), mesh.tets, ke);
    const std::vector<Index> g = reduced_to_global(m);
    const Eigen::MatrixXd reduced = Eigen::MatrixXd(m.matrix());
    const double scale = full.cwiseAbs().maxCoeff();
    for (Index i = 0; i < m.size(); ++i)
      for (Index j = 0; j < m.size(); ++j) {
        const double expect = (g[i] < 0 || g[j] < 0) ? (i == j ? 1.0 : 0.0) : full(g[i], g[j]);
        ASSERT_NEAR(reduced(i, j), expect, 1e-13 * scale) << i << "," << j;
      }
  }
  // PSD option: every element matrix is PSD (the random state compresses some tets), and equal to
  // the exact one where the tet is stretched only.
  int modified = 0;
  for (std::size_t e = 0; e < mesh.tets.size(); ++e) {
    Mat34 xe;
    for (int q = 0; q < 4; ++q) xe.col(q) = x[mesh.tets[e][q]];
    const Mat12 exact = element_stiffness(model, static_cast<Index>(e), xe, false);
    const Mat12 psd = element_stiffness(model, static_cast<Index>(e), xe, true);
    const Eigen::SelfAdjointEigenSolver<Mat12> eig(psd);
    EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-9 * exact.norm());
    if ((psd - exact).norm() > 0) ++modified;
  }
  EXPECT_GT(modified, 0);
  const Mat34 rest_corners = mesh.corners(0);
  const Mat34 stretched = (Mat3() << 1.01, 0, 0, 0, 1.005, 0, 0, 0, 1.002).finished() * rest_corners;
  EXPECT_EQ((element_stiffness(model, 0, stretched, true) - element_stiffness(model, 0, stretched, false)).norm(), 0.0);
}

// The solvers agree with a dense solve of the full system with the held rows/columns removed.
TEST(LinearSolvers, AgreeWithDenseEliminationOnRandomSpdSystems) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.6, 0.4), {5, 3, 3}, 0.2);
  const std::vector<AnchorMask> anchors = mixed_anchors(mesh);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  const std::vector<Mat12> ke = random_spd_elements(mesh.tets.size(), 17);
  m.refill([&](Index e) { return ke[e]; });

  // Dense reference: keep only free global DOFs.
  const Eigen::MatrixXd full = dense_full(mesh.num_nodes(), mesh.tets, ke);
  std::vector<Index> free_dofs;
  for (Index v = 0; v < mesh.num_nodes(); ++v)
    for (int c = 0; c < 3; ++c)
      if (!(anchors[v] & (1u << c))) free_dofs.push_back(3 * v + c);
  const Index nf = static_cast<Index>(free_dofs.size());
  Eigen::MatrixXd kf(nf, nf);
  for (Index i = 0; i < nf; ++i)
    for (Index j = 0; j < nf; ++j) kf(i, j) = full(free_dofs[i], free_dofs[j]);
  Random rng(23);
  Eigen::VectorXd bf(nf);
  for (Index i = 0; i < nf; ++i) bf[i] = rng.uniform(-1.0, 1.0);
  const Eigen::VectorXd xf = kf.ldlt().solve(bf);

  // Same right-hand side in the reduced layout (held components: 0).
  const std::vector<Index> g = reduced_to_global(m);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(m.size());
  std::vector<Index> pos_of_global(3 * mesh.positions.size(), -1);
  for (Index i = 0; i < nf; ++i) pos_of_global[free_dofs[i]] = i;
  for (Index i = 0; i < m.size(); ++i)
    if (g[i] >= 0) b[i] = bf[pos_of_global[g[i]]];

  for (LinearSolverKind kind : {LinearSolverKind::direct_ldlt, LinearSolverKind::pcg_block_jacobi,
                                LinearSolverKind::pcg_block_gauss_seidel, LinearSolverKind::pcg_two_level}) {
    // Small aggregates, so that this small mesh has several; the two-level solver turns them about
    // the mesh's nodes.
    LinearSolver solver(LinearSolverOptions{.kind = kind,
                                            .relative_tolerance = 1e-12,
                                            .max_iterations = 5000,
                                            .max_aggregates = 6,
                                            .min_aggregate_nodes = 8});
    solver.set_node_positions(mesh.positions);
    Eigen::VectorXd x;
    const LinearSolveReport rep = solver.solve(m, b, x);
    ASSERT_TRUE(rep.converged) << to_string(kind) << ": " << rep.message;
    EXPECT_LE(rep.relative_residual, 1e-11) << to_string(kind);
    double err = 0;
    for (Index i = 0; i < m.size(); ++i) {
      if (g[i] < 0) {
        EXPECT_EQ(x[i], 0.0);
      } else {
        err = std::max(err, std::abs(x[i] - xf[pos_of_global[g[i]]]));
      }
    }
    EXPECT_LE(err, 1e-8 * xf.cwiseAbs().maxCoeff()) << to_string(kind);
    if (kind != LinearSolverKind::direct_ldlt) {
      EXPECT_GT(rep.iterations, 0);
    }
  }
}

TEST(LinearSolvers, GaussSeidelNeedsFewerIterationsThanJacobi) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.2, 0.2), {20, 4, 4});
  const FemModel model = make_fem_model(mesh, test::test_material(), ModelKind::linear);
  std::vector<AnchorMask> anchors(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < anchors.size(); ++v)
    if (mesh.positions[v].x() == 0.0) anchors[v] = anchor_all;
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  assemble_stiffness(model, mesh.positions, {}, m);
  Eigen::VectorXd b = Eigen::VectorXd::Ones(m.size());
  int iterations[2] = {0, 0};
  int i = 0;
  for (LinearSolverKind kind : {LinearSolverKind::pcg_block_jacobi, LinearSolverKind::pcg_block_gauss_seidel}) {
    LinearSolver solver(LinearSolverOptions{.kind = kind, .relative_tolerance = 1e-8});
    Eigen::VectorXd x;
    const LinearSolveReport rep = solver.solve(m, b, x);
    ASSERT_TRUE(rep.converged) << rep.message;
    iterations[i++] = rep.iterations;
  }
  EXPECT_LT(iterations[1], iterations[0]);
}

// A bar held only where its rigid motions need it (one node fully, one in y and z, one in z), as
// inertia relief holds a body: Gauss-Seidel's sweeps barely reach its long-wavelength bending and
// twisting, which the two-level cycle's coarse rigid motions of node aggregates take out.
TEST(LinearSolvers, TwoLevelSolvesAFloatingBarInFewIterations) {
  const TetMesh mesh = test::box(Vec3(2.0, 0.2, 0.2), {40, 4, 4});
  const FemModel model = make_fem_model(mesh, test::test_material(), ModelKind::linear);
  std::vector<AnchorMask> anchors(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < anchors.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    if (p.isZero()) anchors[v] = anchor_all;
    if (p == Vec3(2.0, 0, 0)) anchors[v] = 2 | 4;
    if (p == Vec3(0, 0.2, 0)) anchors[v] = 4;
  }
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  assemble_stiffness(model, mesh.positions, {}, m);
  // A load that bends and twists it: a z pull growing along the bar, and a twist at the far end.
  Eigen::VectorXd b = Eigen::VectorXd::Zero(m.size());
  for (Index a = 0; a < m.num_active(); ++a) {
    const Vec3& p = mesh.positions[m.node_of_active()[a]];
    b[3 * a + 2] = p.x() - 1.0;
    if (p.x() == 2.0) b[3 * a + 1] = p.z() - 0.1;
  }
  Eigen::VectorXd exact;
  LinearSolver direct(LinearSolverOptions{.kind = LinearSolverKind::direct_ldlt});
  ASSERT_TRUE(direct.solve(m, b, exact).converged);

  int iterations[3] = {0, 0, 0};
  Eigen::VectorXd solutions[3];
  int i = 0;
  for (const bool with_positions : {false, true}) {
    LinearSolver two_level(LinearSolverOptions{.kind = LinearSolverKind::pcg_two_level, .relative_tolerance = 1e-10});
    if (with_positions) two_level.set_node_positions(mesh.positions);
    const LinearSolveReport rep = two_level.solve(m, b, solutions[i]);
    ASSERT_TRUE(rep.converged) << rep.message;
    iterations[i++] = rep.iterations;
  }
  LinearSolver gauss_seidel(
      LinearSolverOptions{.kind = LinearSolverKind::pcg_block_gauss_seidel, .relative_tolerance = 1e-10});
  const LinearSolveReport rep = gauss_seidel.solve(m, b, solutions[2]);
  ASSERT_TRUE(rep.converged) << rep.message;
  iterations[2] = rep.iterations;
  for (const Eigen::VectorXd& x : solutions) EXPECT_LE((x - exact).norm(), 1e-8 * exact.norm());
  std::printf("floating bar, %d unknowns: PCG iterations, two-level %d (aggregates only moving: %d), Gauss-Seidel %d\n",
              static_cast<int>(m.size()), iterations[1], iterations[0], iterations[2]);
  // Rotations of the aggregates are what the bending needs; moves alone help less.
  EXPECT_LT(3 * iterations[1], iterations[2]) << "two-level " << iterations[1] << ", Gauss-Seidel " << iterations[2];
  EXPECT_LT(iterations[1], iterations[0]);
  EXPECT_LT(iterations[0], iterations[2]);

  // Any aggregate budget gives the solution, and is kept: pieces squeezed between aggregates are
  // paired up with their neighbours (with 36, growth leaves 37 on this bar).
  for (const int max_aggregates : {1, 2, 3, 7, 36, 100}) {
    LinearSolver two_level(LinearSolverOptions{.kind = LinearSolverKind::pcg_two_level,
                                               .relative_tolerance = 1e-10,
                                               .max_aggregates = max_aggregates,
                                               .min_aggregate_nodes = 1});
    two_level.set_node_positions(mesh.positions);
    Eigen::VectorXd x;
    ASSERT_TRUE(two_level.solve(m, b, x).converged) << max_aggregates;
    EXPECT_LE((x - exact).norm(), 1e-8 * exact.norm()) << max_aggregates;
    EXPECT_GE(two_level.num_aggregates(), 1);
    EXPECT_LE(two_level.num_aggregates(), max_aggregates);
  }

  // The same bits on one thread as on two (the products run in parallel, each row in order).
  const int threads = num_threads();
  Eigen::VectorXd one, two;
  for (const int n : {1, 2}) {
    set_num_threads(n);
    LinearSolver two_level(LinearSolverOptions{.kind = LinearSolverKind::pcg_two_level, .relative_tolerance = 1e-10});
    two_level.set_node_positions(mesh.positions);
    ASSERT_TRUE(two_level.solve(m, b, n == 1 ? one : two).converged);
  }
  set_num_threads(threads);
  EXPECT_EQ(std::memcmp(one.data(), two.data(), sizeof(double) * static_cast<std::size_t>(one.size())), 0);
}

// The coarse rotations turn about the positions given, which need not be the matrix's mesh. With
// every node (all but round-off) on one line, a rotation about it moves no node: such aggregates
// only move, and the solve is as exact and about as quick as with the mesh's positions.
TEST(LinearSolvers, TwoLevelWithNodesOnALine) {
  const TetMesh mesh = test::box(Vec3(2.0, 0.2, 0.2), {20, 2, 2});
  const FemModel model = make_fem_model(mesh, test::test_material(), ModelKind::linear);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, held_at_x0(mesh));
  assemble_stiffness(model, mesh.positions, {}, m);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(m.size(), -1.0, 1.0);
  Eigen::VectorXd exact;
  LinearSolver direct(LinearSolverOptions{.kind = LinearSolverKind::direct_ldlt});
  ASSERT_TRUE(direct.solve(m, b, exact).converged);
  // On the x axis but for round-off-sized offsets, so that the rotation about it is nearly, not
  // exactly, still.
  std::vector<Vec3> on_a_line = mesh.positions;
  for (std::size_t v = 0; v < on_a_line.size(); ++v)
    on_a_line[v] = Vec3(on_a_line[v].x(), 1e-12 * static_cast<double>(v % 3), 1e-12 * static_cast<double>(v % 5));
  const std::vector<Vec3>& as_meshed = mesh.positions;
  for (const std::vector<Vec3>* positions : {&as_meshed, static_cast<const std::vector<Vec3>*>(&on_a_line)}) {
    LinearSolver two_level(LinearSolverOptions{.kind = LinearSolverKind::pcg_two_level, .relative_tolerance = 1e-10});
    two_level.set_node_positions(*positions);
    Eigen::VectorXd x;
    const LinearSolveReport rep = two_level.solve(m, b, x);
    ASSERT_TRUE(rep.converged) << rep.message;
    EXPECT_LE((x - exact).norm(), 1e-8 * exact.norm());
    EXPECT_LT(rep.iterations, 200);
  }
}

TEST(LinearSolvers, DirectReusesSymbolicAnalysisAndWarmStartHelps) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.5, 0.5), {4, 2, 2});
  const std::vector<AnchorMask> anchors = held_at_x0(mesh);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  LinearSolver direct(LinearSolverOptions{.kind = LinearSolverKind::direct_ldlt});
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(m.size(), -1.0, 2.0), x;
  for (int round = 0; round < 3; ++round) {
    const std::vector<Mat12> ke = random_spd_elements(mesh.tets.size(), 40 + round);
    m.refill([&](Index e) { return ke[e]; });
    const LinearSolveReport rep = direct.solve(m, b, x);
    ASSERT_TRUE(rep.converged);
    EXPECT_EQ(rep.analyzed, round == 0);
    EXPECT_LE(rep.relative_residual, 1e-12);
  }
  EXPECT_EQ(direct.symbolic_analyses(), 1);
  BlockSparseMatrix other(mesh.num_nodes(), mesh.tets, anchors);  // a new pattern: analyse again
  other.refill([&](Index e) { return random_spd_elements(1, e)[0]; });
  ASSERT_TRUE(direct.solve(other, b, x).converged);
  EXPECT_EQ(direct.symbolic_analyses(), 2);

  // Warm start from the exact solution: no iteration needed.
  LinearSolver pcg(LinearSolverOptions{.kind = LinearSolverKind::pcg_block_jacobi, .warm_start = true});
  const LinearSolveReport warm = pcg.solve(other, b, x);
  ASSERT_TRUE(warm.converged);
  EXPECT_LE(warm.iterations, 1);
}

// reuse_factorization: a nearby matrix on the same pattern is solved by CG preconditioned by the
// kept factor, to the tolerance, without factorizing; a distant one, an indefinite one's factor, or
// a pattern analysed in between (which drops the numbers) makes it factorize.
TEST(LinearSolvers, DirectReusesItsFactorizationForNearbyMatrices) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.5, 0.5), {4, 2, 2});
  const std::vector<AnchorMask> anchors = held_at_x0(mesh);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  LinearSolver direct(LinearSolverOptions{
      .kind = LinearSolverKind::direct_ldlt, .relative_tolerance = 1e-6, .reuse_factorization = true});
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(m.size(), -1.0, 2.0);
  Eigen::VectorXd x;
  const std::vector<Mat12> ke = random_spd_elements(mesh.tets.size(), 40);
  m.refill([&](Index e) { return ke[e]; });
  LinearSolveReport rep = direct.solve(m, b, x);
  ASSERT_TRUE(rep.converged);
  EXPECT_TRUE(rep.factorized);
  // 1 % away: the kept factor preconditions CG.
  m.refill([&](Index e) { return Mat12(1.01 * ke[e] + 1e-4 * Mat12::Identity()); });
  rep = direct.solve(m, b, x);
  ASSERT_TRUE(rep.converged);
  EXPECT_FALSE(rep.factorized);
  EXPECT_GT(rep.iterations, 0);
  EXPECT_LE(rep.relative_residual, 1e-6);
  // Another matrix altogether: CG does not converge within its budget, so it factorizes.
  const std::vector<Mat12> far = random_spd_elements(mesh.tets.size(), 99);
  m.refill([&](Index e) { return far[e]; });
  rep = direct.solve(m, b, x);
  ASSERT_TRUE(rep.converged);
  EXPECT_TRUE(rep.factorized);
  EXPECT_LE(rep.relative_residual, 1e-12);
  // Another pattern analysed in between drops the numeric factor.
  BlockSparseMatrix other(mesh.num_nodes(), mesh.tets, anchors);
  other.refill([&](Index e) { return far[e]; });
  (void)direct.direct_cost(other);
  rep = direct.solve(m, b, x);
  ASSERT_TRUE(rep.converged);
  EXPECT_TRUE(rep.factorized);
  EXPECT_LE(rep.relative_residual, 1e-12);
  // The factor of an indefinite matrix is never kept.
  m.refill([&](Index e) { return Mat12(far[e] - 3.0 * Mat12::Identity()); });
  rep = direct.solve(m, b, x);
  EXPECT_TRUE(rep.factorized);
  EXPECT_TRUE(rep.indefinite);
  m.refill([&](Index e) { return far[e]; });
  rep = direct.solve(m, b, x);
  EXPECT_TRUE(rep.factorized);
  EXPECT_LE(rep.relative_residual, 1e-12);
}

// The block LDL^T needs no positive definiteness: an indefinite, non-singular system is solved to
// round-off, and the factorization says it is not positive definite.
TEST(BlockLdlt, SolvesIndefiniteSystemsAndSaysSo) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.6, 0.4), {4, 3, 3}, 0.2);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, mixed_anchors(mesh));
  std::vector<Mat12> ke = random_spd_elements(mesh.tets.size(), 5);
  for (Mat12& k : ke) k -= 3.0 * Mat12::Identity();  // some directions of the sum now negative
  m.refill([&](Index e) { return ke[e]; });
  const Eigen::MatrixXd dense(m.matrix());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(dense);
  ASSERT_LT(eig.eigenvalues().minCoeff(), 0.0);
  ASSERT_GT(eig.eigenvalues().cwiseAbs().minCoeff(), 1e-6);
  BlockLdlt ldlt;
  ldlt.analyze(m);
  ASSERT_TRUE(ldlt.factorize(m));
  EXPECT_FALSE(ldlt.positive_definite());
  Random rng(3);
  Eigen::VectorXd b(m.size()), x;
  for (Index i = 0; i < m.size(); ++i) b[i] = rng.uniform(-1.0, 1.0);
  ldlt.solve(b, x);
  const Eigen::VectorXd reference = dense.fullPivLu().solve(b);
  EXPECT_LE((x - reference).norm(), 1e-9 * reference.norm());
  // The scalar fill it reports: 3 per block column's diagonal block and 9 per block below it,
  // and at least as many blocks below the diagonal as the matrix has above it (fill only adds).
  const double n = static_cast<double>(m.num_active());
  const double below = (ldlt.factor_nonzeros() - 3.0 * n) / 9.0;
  EXPECT_EQ(below, std::round(below));
  EXPECT_GE(below, 0.5 * static_cast<double>(m.num_blocks() - m.num_active()));
  EXPECT_GT(ldlt.factor_flops(), ldlt.factor_nonzeros());
}

// A factorization leaves nothing behind: refactorizing after another matrix gives the bits of a
// fresh solver, and a positive definite matrix is reported as one.
TEST(BlockLdlt, RefactorizingGivesTheBitsOfAFreshFactorization) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.6, 0.4), {5, 3, 3}, 0.2);
  BlockSparseMatrix first(mesh.num_nodes(), mesh.tets, held_at_x0(mesh));
  BlockSparseMatrix second(mesh.num_nodes(), mesh.tets, held_at_x0(mesh));
  const std::vector<Mat12> k1 = random_spd_elements(mesh.tets.size(), 7);
  const std::vector<Mat12> k2 = random_spd_elements(mesh.tets.size(), 8);
  first.refill([&](Index e) { return k1[e]; });
  second.refill([&](Index e) { return k2[e]; });
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(second.size(), -1.0, 2.0);
  BlockLdlt reused, fresh;
  reused.analyze(first);
  ASSERT_TRUE(reused.factorize(first));
  EXPECT_TRUE(reused.positive_definite());
  ASSERT_TRUE(reused.factorize(second));
  fresh.analyze(second);
  ASSERT_TRUE(fresh.factorize(second));
  Eigen::VectorXd x1, x2;
  reused.solve(b, x1);
  fresh.solve(b, x2);
  ASSERT_EQ(x1.size(), x2.size());
  EXPECT_EQ(std::memcmp(x1.data(), x2.data(), sizeof(double) * static_cast<std::size_t>(x1.size())), 0);
  Eigen::VectorXd ax;
  second.multiply(x1, ax);
  EXPECT_LE((ax - b).norm(), 1e-12 * b.norm());
}

// The analysis hands the block pattern to the minimum-degree ordering as it stands: the ordering
// is the one Eigen's AMDOrdering gives on the node graph built from triplets.
TEST(BlockLdlt, OrderingIsEigensAmdOfTheNodeGraph) {
  for (const std::array<Index, 3> cells : {std::array<Index, 3>{4, 3, 3}, {7, 5, 4}, {12, 6, 5}}) {
    const TetMesh mesh = test::box(Vec3(1.0, 0.6, 0.4), cells, 0.2);
    for (const bool mixed : {false, true}) {
      const BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, mixed ? mixed_anchors(mesh) : held_at_x0(mesh));
      std::vector<Eigen::Triplet<double>> entries;
      for (Index r = 0; r < m.num_active(); ++r)
        for (Index k = m.block_ptr()[r]; k < m.block_ptr()[r + 1]; ++k) entries.emplace_back(r, m.block_col()[k], 1.0);
      Eigen::SparseMatrix<double> graph(m.num_active(), m.num_active());
      graph.setFromTriplets(entries.begin(), entries.end());
      Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> reference;
      Eigen::AMDOrdering<int>()(graph, reference);
      BlockLdlt ldlt;
      ldlt.analyze(m);
      const std::vector<Index> expected(reference.indices().data(), reference.indices().data() + m.num_active());
      EXPECT_EQ(ldlt.ordering(), expected)
          << cells[0] << "x" << cells[1] << "x" << cells[2] << (mixed ? " mixed anchors" : " held at x = 0");
      // A permutation, and not the identity (the ordering does something on these meshes).
      std::vector<Index> sorted = ldlt.ordering();
      std::sort(sorted.begin(), sorted.end());
      for (Index k = 0; k < m.num_active(); ++k) ASSERT_EQ(sorted[k], k);
      EXPECT_NE(sorted, ldlt.ordering());
    }
  }
}

// The factorization's block products run four-wide with AVX2 and two-wide otherwise, with the
// same operations in the same order: the same bits either way.
TEST(BlockLdlt, BaselineAndAvx2GiveTheSameBits) {
  const TetMesh mesh = test::box(Vec3(1.0, 0.6, 0.4), {6, 4, 3}, 0.2);
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, mixed_anchors(mesh));
  const std::vector<Mat12> ke = random_spd_elements(mesh.tets.size(), 9);
  m.refill([&](Index e) { return ke[e]; });
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(m.size(), -1.0, 2.0);
  const SimdIsa saved = simd_isa();
  std::vector<Eigen::VectorXd> x(2);
  for (int k = 0; k < 2; ++k) {
    set_simd_isa(k == 0 ? SimdIsa::baseline : SimdIsa::avx2);
    BlockLdlt ldlt;
    ldlt.analyze(m);
    ASSERT_TRUE(ldlt.factorize(m));
    ldlt.solve(b, x[static_cast<std::size_t>(k)]);
  }
  set_simd_isa(saved);
  ASSERT_EQ(x[0].size(), x[1].size());
  EXPECT_EQ(std::memcmp(x[0].data(), x[1].data(), sizeof(double) * static_cast<std::size_t>(x[0].size())), 0);
  Eigen::VectorXd ax;
  m.multiply(x[0], ax);
  EXPECT_LE((ax - b).norm(), 1e-12 * b.norm());
}

TEST(LinearSolvers, BadInputGivesReportNotNaN) {
  const TetMesh mesh = test::box(Vec3(1.0, 1.0, 1.0), {2, 2, 2});
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, {});  // nothing held: the zero matrix is singular
  for (LinearSolverKind kind :
       {LinearSolverKind::direct_ldlt, LinearSolverKind::pcg_block_jacobi, LinearSolverKind::pcg_block_gauss_seidel}) {
    LinearSolver solver(LinearSolverOptions{.kind = kind});
    Eigen::VectorXd b = Eigen::VectorXd::Ones(m.size()), x;
    LinearSolveReport rep = solver.solve(m, b, x);
    EXPECT_FALSE(rep.converged) << to_string(kind);
    EXPECT_FALSE(rep.message.empty());
    EXPECT_TRUE(x.allFinite());
    b[0] = std::numeric_limits<double>::quiet_NaN();
    rep = solver.solve(m, b, x);
    EXPECT_FALSE(rep.converged);
    EXPECT_TRUE(x.allFinite());
  }
  EXPECT_TRUE(parse_linear_solver_kind("pcg-gauss-seidel").ok());
  EXPECT_FALSE(parse_linear_solver_kind("cholmod").ok());
}

}  // namespace
}  // namespace shatter
