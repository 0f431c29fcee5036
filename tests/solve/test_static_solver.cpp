// Static equilibrium: Hooke's law on a bar, cantilever convergence to beam theory, Newton
// convergence, load stepping, determinism across thread counts, and no NaN on bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "shatter/core/parallel.h"
#include "shatter/solve/static_solver.h"
#include "solve_test_util.h"
#include "support/test_support.h"

namespace shatter {
namespace {

constexpr double kE = 70e9;
constexpr double kNu = 0.3;

// Bar [0,L] x [0,a] x [0,a]: the x = 0 face held in x only (rollers), the origin held, node
// (0,a,0) held in x and z: no rigid motion, free lateral contraction. Force P along +x on x = L.
struct Bar {
  double length = 1.0, side = 0.2;
  TetMesh mesh;
  StaticProblem problem;
};

Bar make_bar(double total_force, std::array<Index, 3> cells, double jitter = 0.0) {
  Bar bar;
  bar.mesh = test::box(Vec3(bar.length, bar.side, bar.side), cells, jitter);
  const std::size_t n = bar.mesh.positions.size();
  bar.problem.anchors.assign(n, anchor_none);
  for (std::size_t v = 0; v < n; ++v) {
    const Vec3& p = bar.mesh.positions[v];
    if (p.x() != 0.0) continue;
    bar.problem.anchors[v] = 1;  // x
    if (p.y() == 0.0 && p.z() == 0.0) bar.problem.anchors[v] = anchor_all;
    if (p.y() == bar.side && p.z() == 0.0) bar.problem.anchors[v] = 1 | 4;
  }
  const double area = bar.side * bar.side;
  bar.problem.external_forces =
      test::face_load(bar.mesh, [&](const Vec3& p) { return p.x() == bar.length; }, Vec3(total_force / area, 0, 0));
  return bar;
}

TEST(StaticSolver, UniaxialBarFollowsHookesLaw) {
  const double sigma = 7e6;  // Pa: strain 1e-4 in glass-like material
  for (ModelKind kind : {ModelKind::linear, ModelKind::stvk}) {
    Bar bar = make_bar(sigma * 0.2 * 0.2, {6, 2, 2}, 0.15);
    const FemModel model = make_fem_model(bar.mesh, test::test_material(kE, kNu), kind);
    std::vector<Vec3> x = bar.mesh.positions;
    const Result<StaticReport> r = solve_static(model, bar.problem, x);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    EXPECT_LE(r->relative_residual, 1e-6);
    const double strain = sigma / kE;
    const double tol = kind == ModelKind::linear ? 1e-6 : 2e-4;  // StVK: O(strain) from Green strain
    for (std::size_t v = 0; v < x.size(); ++v) {
      const Vec3& p = bar.mesh.positions[v];
      const Vec3 u = x[v] - p;
      // Every node follows the homogeneous field u = (eps x, -nu eps y, -nu eps z).
      EXPECT_NEAR(u.x(), strain * p.x(), tol * strain * bar.length) << v;
      EXPECT_NEAR(u.y(), -kNu * strain * p.y(), tol * strain * bar.length) << v;
      EXPECT_NEAR(u.z(), -kNu * strain * p.z(), tol * strain * bar.length) << v;
    }
    const double end = (x[x.size() - 1] - bar.mesh.positions.back()).x();
    EXPECT_NEAR(end / (strain * bar.length), 1.0, tol) << to_string(kind);
  }
}

// Cantilever L x h x h clamped at x = 0, tip load P (-y) spread over x = L. Euler-Bernoulli:
// d = P L^3 / (3 E I), I = h^4 / 12; Timoshenko adds P L / (kappa G A) with kappa = 5/6.
TEST(StaticSolver, CantileverConvergesTowardBeamTheory) {
  const double L = 1.0, h = 0.1, P = 1000.0;
  const double I = h * h * h * h / 12.0;
  const double euler_bernoulli = P * L * L * L / (3 * kE * I);
  const double shear = P * L / ((5.0 / 6.0) * (kE / (2 * (1 + kNu))) * h * h);
  std::printf(
      "cantilever L=%.1f m, h=%.2f m, E=%.0f GPa, nu=%.2f, P=%.0f N: Euler-Bernoulli %.4e m, "
      "Timoshenko %.4e m (ratio %.4f)\n",
      L, h, kE / 1e9, kNu, P, euler_bernoulli, euler_bernoulli + shear, (euler_bernoulli + shear) / euler_bernoulli);
  std::printf("%-12s %8s %14s %10s\n", "cells", "tets", "tip defl. m", "ratio EB");
  double previous = 0;
  double last_ratio = 0;
  for (Index k : {1, 2, 4, 8}) {
    const TetMesh mesh = test::box(Vec3(L, h, h), {10 * k, k, k});
    const FemModel model = make_fem_model(mesh, test::test_material(kE, kNu), ModelKind::linear);
    StaticProblem problem;
    problem.anchors.assign(mesh.positions.size(), anchor_none);
    for (std::size_t v = 0; v < mesh.positions.size(); ++v)
      if (mesh.positions[v].x() == 0.0) problem.anchors[v] = anchor_all;
    problem.external_forces =
        test::face_load(mesh, [&](const Vec3& p) { return p.x() == L; }, Vec3(0, -P / (h * h), 0));
    std::vector<Vec3> x = mesh.positions;
    const Result<StaticReport> r = solve_static(model, problem, x);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    // Mean vertical deflection of the loaded face.
    double sum = 0;
    int count = 0;
    for (std::size_t v = 0; v < x.size(); ++v)
      if (mesh.positions[v].x() == L) {
        sum += mesh.positions[v].y() - x[v].y();
        ++count;
      }
    const double tip = sum / count;
    const double ratio = tip / euler_bernoulli;
    std::printf("%3dx%dx%-6d %8d %14.4e %10.4f\n", 10 * k, k, k, mesh.num_tets(), tip, ratio);
    EXPECT_GT(tip, previous);  // softens monotonically under refinement (linear tets are stiff)
    previous = tip;
    last_ratio = ratio;
  }
  EXPECT_GT(last_ratio, 0.85);
  EXPECT_LT(last_ratio, 1.02);
}

TEST(StaticSolver, NewtonConvergesInFewIterationsOnStiffProblem) {
  for (LinearSolverKind kind :
       {LinearSolverKind::direct_ldlt, LinearSolverKind::pcg_block_jacobi, LinearSolverKind::pcg_block_gauss_seidel}) {
    Bar bar = make_bar(2e5, {8, 2, 2});
    // Bend it too: a transverse load on the end.
    for (std::size_t v = 0; v < bar.mesh.positions.size(); ++v)
      if (bar.mesh.positions[v].x() == bar.length) bar.problem.external_forces[v].y() += 50.0;
    const FemModel model = make_fem_model(bar.mesh, test::test_material(kE, kNu), ModelKind::stvk);
    std::vector<Vec3> x = bar.mesh.positions;
    StaticSolverOptions options;
    options.linear.kind = kind;
    const Result<StaticReport> r = solve_static(model, bar.problem, x, options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    EXPECT_LE(r->newton_iterations, 3) << to_string(kind);
    EXPECT_LE(r->relative_residual, 1e-6);
    EXPECT_EQ(r->load_steps, 1);
    if (kind != LinearSolverKind::direct_ldlt) {
      EXPECT_GT(r->linear_iterations_total, 0);
    }
  }
}

TEST(StaticSolver, LoadIncrementsRescueLargeLoad) {
  // A soft StVK cantilever under a tip load that bends it far: the full Newton step fails.
  const double L = 1.0, h = 0.1;
  const TetMesh mesh = test::box(Vec3(L, h, h), {10, 1, 1});
  const FemModel model = make_fem_model(mesh, test::test_material(1e6, 0.3), ModelKind::stvk);
  StaticProblem problem;
  problem.anchors.assign(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v)
    if (mesh.positions[v].x() == 0.0) problem.anchors[v] = anchor_all;
  problem.external_forces =
      test::face_load(mesh, [&](const Vec3& p) { return p.x() == L; }, Vec3(0, -60.0 / (h * h), 0));
  StaticSolverOptions options;
  options.max_newton_iterations = 8;
  options.max_load_halvings = 0;
  options.tangent = TangentKind::exact;  // the exact Hessian: quadratic convergence once close
  std::vector<Vec3> x = mesh.positions;
  Result<StaticReport> r = solve_static(model, problem, x, options);
  ASSERT_OK(r);
  EXPECT_FALSE(r->converged);
  EXPECT_FALSE(r->message.empty());
  for (const Vec3& p : x) EXPECT_TRUE(p.allFinite());

  options.max_load_halvings = 8;
  x = mesh.positions;
  r = solve_static(model, problem, x, options);
  ASSERT_OK(r);
  ASSERT_TRUE(r->converged) << r->message;
  std::printf("large load: %d load steps, %d Newton iterations, %d line-search cuts\n", r->load_steps,
              r->newton_iterations, r->line_search_cuts);
  EXPECT_GT(r->load_steps, 1);
  EXPECT_LE(r->relative_residual, 1e-6);
  double tip = 0;
  for (std::size_t v = 0; v < x.size(); ++v) tip = std::max(tip, mesh.positions[v].y() - x[v].y());
  EXPECT_GT(tip, 0.1 * L);  // a large deflection
}

// The soft cantilever 1 m x 0.1 m x 0.1 m (E = 10 MPa), clamped at x = 0, 120 N down on the tip
// face: PL^2/EI = 1.44, a tip deflection of about a quarter of its length.
struct SoftCantilever {
  TetMesh mesh = test::box(Vec3(1.0, 0.1, 0.1), {20, 2, 2});
  FemModel model = make_fem_model(mesh, test::test_material(1e7, 0.3), ModelKind::stvk);
  StaticProblem problem;
  SoftCantilever() {
    problem.anchors.assign(mesh.positions.size(), anchor_none);
    for (std::size_t v = 0; v < mesh.positions.size(); ++v)
      if (mesh.positions[v].x() == 0.0) problem.anchors[v] = anchor_all;
    problem.external_forces =
        test::face_load(mesh, [&](const Vec3& p) { return p.x() == 1.0; }, Vec3(0, 0, -120.0 / 0.01));
  }
};

TEST(StaticSolver, LargeDeflectionConvergesWithDefaultSettings) {
  const SoftCantilever c;
  for (LinearSolverKind kind : {LinearSolverKind::pcg_block_gauss_seidel, LinearSolverKind::direct_ldlt}) {
    StaticSolverOptions options;
    options.linear.kind = kind;
    std::vector<Vec3> x = c.mesh.positions;
    const Result<StaticReport> r = solve_static(c.model, c.problem, x, options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    std::printf("soft cantilever, %s: %d load steps, %d Newton iterations (%d projected), %.1f ms\n", to_string(kind),
                r->load_steps, r->newton_iterations, r->projected_iterations, r->total_ms);
    EXPECT_LE(r->newton_iterations, 15);
    EXPECT_LE(r->relative_residual, options.relative_residual_tolerance);
    // One history entry per iteration and the final residual.
    ASSERT_EQ(r->history.size(), static_cast<std::size_t>(r->newton_iterations) + 1);
    EXPECT_EQ(r->history.back().relative_residual, r->relative_residual);
    double tip = 0;
    for (std::size_t v = 0; v < x.size(); ++v) tip = std::max(tip, c.mesh.positions[v].z() - x[v].z());
    EXPECT_GT(tip, 0.2);
    const std::string trace = test::residual_trace(r->history);
    std::printf("  residual history%s\n", trace.c_str());
    if (kind != LinearSolverKind::direct_ldlt) continue;
    // Exact linear solves (the factorization), so Newton's own rate shows: from a relative residual
    // of 1e-2 on, each is at most 10 times the square of the one before (a linear rate of 0.1
    // would break this from the first such step: 10 x (2.5e-3)^2 is 2.5e-3 / 40), down to
    // round-off.
    int quadratic_steps = 0;
    for (std::size_t k = 1; k < r->history.size(); ++k) {
      const double before = r->history[k - 1].relative_residual, after = r->history[k].relative_residual;
      if (before >= 1e-2 || after <= 1e-14) continue;
      EXPECT_LE(after, 10 * before * before) << "iteration " << k << ":" << trace;
      ++quadratic_steps;
    }
    EXPECT_GE(quadratic_steps, 2) << trace;
  }
}

TEST(StaticSolver, DirectSolverTakesOverWhereCheaper) {
  // The slender soft cantilever is ill-conditioned: PCG stalls in its first 50 iterations and its
  // banded factorization is cheap, so the direct solver takes over, with the same answer to the
  // tolerance. The bulky, anchored impact system converges in few PCG iterations: it stays PCG.
  const SoftCantilever c;
  std::vector<Vec3> results[2];
  for (bool direct_when_cheaper : {true, false}) {
    StaticSolverOptions options;
    options.direct_when_cheaper = direct_when_cheaper;
    std::vector<Vec3>& x = results[direct_when_cheaper ? 0 : 1];
    x = c.mesh.positions;
    const Result<StaticReport> r = solve_static(c.model, c.problem, x, options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    if (direct_when_cheaper) {
      EXPECT_EQ(r->direct_iterations, r->newton_iterations);
      for (const NewtonIteration& it : r->history) {
        if (it.step_length > 0) {
          EXPECT_TRUE(it.direct);
        }
      }
    } else {
      EXPECT_EQ(r->direct_iterations, 0);
    }
  }
  double max_u = 0, diff = 0;
  for (std::size_t v = 0; v < results[0].size(); ++v) {
    max_u = std::max(max_u, (results[0][v] - c.mesh.positions[v]).norm());
    diff = std::max(diff, (results[0][v] - results[1][v]).norm());
  }
  EXPECT_LT(diff, 1e-6 * max_u);

  // An impact on a glass slab 0.5 x 0.1 x 0.5 m: nodes farther than 0.1 m from the contact held,
  // 10 kN spread over the nodes within 3 cm of it.
  BoxMeshDef def;
  def.max = Vec3(0.5, 0.1, 0.5);
  def.cells = cells_for_tet_count(def.max, 4000);
  def.jitter = 0.1;
  const TetMesh slab = make_box_mesh(def);
  const FemModel glass = make_fem_model(slab, test::test_material(70e9, 0.22), ModelKind::stvk);
  const Vec3 contact(0.25, 0.1, 0.25);
  StaticProblem impact;
  impact.anchors.assign(slab.positions.size(), anchor_none);
  impact.external_forces.assign(slab.positions.size(), Vec3::Zero());
  double weight = 0;
  for (const Vec3& p : slab.positions) weight += std::max(0.0, 0.03 - (p - contact).norm());
  for (std::size_t v = 0; v < slab.positions.size(); ++v) {
    const double d = (slab.positions[v] - contact).norm();
    if (d > 0.1) impact.anchors[v] = anchor_all;
    if (d < 0.03) impact.external_forces[v] = Vec3(0, -1e4 * (0.03 - d) / weight, 0);
  }
  std::vector<Vec3> x = slab.positions;
  const Result<StaticReport> r = solve_static(glass, impact, x);
  ASSERT_OK(r);
  ASSERT_TRUE(r->converged) << r->message;
  EXPECT_EQ(r->direct_iterations, 0);
  EXPECT_GT(r->linear_iterations_total, 0);
}

// A caller that knows its system is ill-conditioned (ill_conditioned: a body held at three nodes)
// skips the 50 probing PCG iterations; the cantilever's factorization is chosen at once, and the
// answer has the same bits (the factorization never reads the probe's iterate).
TEST(StaticSolver, IllConditionedSystemsChooseWithoutProbing) {
  const SoftCantilever c;
  std::vector<Vec3> results[2];
  int linear_iterations[2] = {0, 0};
  for (int known = 0; known < 2; ++known) {
    StaticSolverOptions options;
    options.ill_conditioned = known == 1;
    std::vector<Vec3>& x = results[known];
    x = c.mesh.positions;
    const Result<StaticReport> r = solve_static(c.model, c.problem, x, options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    EXPECT_EQ(r->direct_iterations, r->newton_iterations);
    linear_iterations[known] = r->linear_iterations_total;
  }
  EXPECT_GE(linear_iterations[0], kMinIterationsForDirect);
  EXPECT_LT(linear_iterations[1], kMinIterationsForDirect);
  EXPECT_EQ(std::memcmp(results[0].data(), results[1].data(), sizeof(Vec3) * results[0].size()), 0);
}

// Chord steps near the solution (chord_tolerance) reuse the last tangent and its factorization:
// the soft cantilever converges to the same tolerance, to the same answer, with fewer assemblies.
TEST(StaticSolver, ChordStepsNearTheSolutionReachTheSameAnswer) {
  const SoftCantilever c;
  std::vector<Vec3> results[2];
  int chords[2] = {0, 0};
  double assemblies[2] = {0, 0};
  for (int chord = 0; chord < 2; ++chord) {
    StaticSolverOptions options;
    options.chord_tolerance = chord == 1 ? 1e-2 : 0.0;
    std::vector<Vec3>& x = results[chord];
    x = c.mesh.positions;
    const Result<StaticReport> r = solve_static(c.model, c.problem, x, options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    EXPECT_LE(r->relative_residual, options.relative_residual_tolerance);
    chords[chord] = r->chord_iterations;
    assemblies[chord] = static_cast<double>(r->newton_iterations - r->chord_iterations);
  }
  EXPECT_EQ(chords[0], 0);
  EXPECT_GT(chords[1], 0);
  EXPECT_LT(assemblies[1], assemblies[0]);
  double max_u = 0, diff = 0;
  for (std::size_t v = 0; v < results[0].size(); ++v) {
    max_u = std::max(max_u, (results[0][v] - c.mesh.positions[v]).norm());
    diff = std::max(diff, (results[0][v] - results[1][v]).norm());
  }
  EXPECT_LT(diff, 1e-6 * max_u);
}

// Where assembled steps converge only linearly (the projected tangent of a StVK block dented by a
// pressure of 0.4 E), chord steps take over far from the solution too, with the direct solver,
// while they cut the residual about as fast per unit of cost: the same answer with fewer
// assemblies.
TEST(StaticSolver, ChordStepsWhereNewtonConvergesLinearlyReachTheSameAnswer) {
  const double side = 0.1, pressure = 4e5;  // Pa: 0.4 E
  const TetMesh mesh = test::box(Vec3(side, side, side), {4, 4, 4}, 0.1);
  const FemModel model = make_fem_model(mesh, test::test_material(1e6, 0.3), ModelKind::stvk);
  StaticProblem problem;
  problem.anchors.assign(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v)
    if (mesh.positions[v].y() == 0.0) problem.anchors[v] = anchor_all;
  // The load on a patch of the top face: a dent, not a uniform squeeze.
  problem.external_forces = test::face_load(
      mesh, [&](const Vec3& p) { return p.y() == side && (p - Vec3(side / 2, side, side / 2)).norm() < 0.3 * side; },
      Vec3(0, -pressure, 0));
  std::vector<Vec3> results[2];
  int chords[2] = {0, 0};
  int assemblies[2] = {0, 0};
  for (int chord = 0; chord < 2; ++chord) {
    StaticSolverOptions options;
    options.tangent = TangentKind::projected;
    options.linear.kind = LinearSolverKind::direct_ldlt;
    // Far below any residual the solve sees: only the linear-regime rule makes chord steps.
    options.chord_tolerance = chord == 1 ? 1e-12 : 0.0;
    options.load_increments = 2;
    std::vector<Vec3>& x = results[chord];
    x = mesh.positions;
    const Result<StaticReport> r = solve_static(model, problem, x, options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    EXPECT_LE(r->relative_residual, options.relative_residual_tolerance);
    chords[chord] = r->chord_iterations;
    assemblies[chord] = r->newton_iterations - r->chord_iterations;
  }
  EXPECT_EQ(chords[0], 0);
  EXPECT_GT(chords[1], 0);
  EXPECT_LT(assemblies[1], assemblies[0]);
  double max_u = 0, diff = 0;
  for (std::size_t v = 0; v < results[0].size(); ++v) {
    max_u = std::max(max_u, (results[0][v] - mesh.positions[v]).norm());
    diff = std::max(diff, (results[0][v] - results[1][v]).norm());
  }
  EXPECT_GT(max_u, 0.05 * side);  // a large deformation
  EXPECT_LT(diff, 1e-6 * max_u);
}

// by-model resolves to what impacts need per model; every kind round-trips through its name.
TEST(StaticSolver, TangentByModel) {
  EXPECT_EQ(resolve_tangent(TangentKind::by_model, ModelKind::stvk), TangentKind::projected);
  EXPECT_EQ(resolve_tangent(TangentKind::by_model, ModelKind::corotated), TangentKind::on_demand);
  EXPECT_EQ(resolve_tangent(TangentKind::by_model, ModelKind::linear), TangentKind::on_demand);
  for (const TangentKind k :
       {TangentKind::on_demand, TangentKind::projected, TangentKind::exact, TangentKind::by_model}) {
    EXPECT_EQ(resolve_tangent(k, ModelKind::corotated), k == TangentKind::by_model ? TangentKind::on_demand : k);
    const auto parsed = parse_tangent_kind(to_string(k));
    ASSERT_OK(parsed);
    EXPECT_EQ(*parsed, k);
  }
}

TEST(StaticSolver, ProjectionOnDemandBeatsAlwaysProjecting) {
  // The always-projected stiffness drops the compressive part of the geometric stiffness of every
  // bent element: Newton converges only linearly and needs many more iterations.
  const SoftCantilever c;
  int iterations[2] = {0, 0};
  for (TangentKind tangent : {TangentKind::on_demand, TangentKind::projected}) {
    StaticSolverOptions options;
    options.tangent = tangent;
    options.max_newton_iterations = 100;
    std::vector<Vec3> x = c.mesh.positions;
    const Result<StaticReport> r = solve_static(c.model, c.problem, x, options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << to_string(tangent) << ": " << r->message;
    iterations[tangent == TangentKind::projected] = r->newton_iterations;
    if (tangent == TangentKind::projected) {
      EXPECT_EQ(r->projected_iterations, r->newton_iterations);
    }
  }
  std::printf("soft cantilever: %d Newton iterations on demand, %d always projected\n", iterations[0], iterations[1]);
  EXPECT_LT(2 * iterations[0], iterations[1]);
}

// With the projected stiffness Newton converges only linearly on the bent cantilever, and its full
// load step cannot meet the impact solves' tolerance (1e-6) in 20 iterations. abandon_slow_load_steps gives such a step
// up as soon as its rate says so, instead of at the limit: fewer iterations, the same equilibrium.
TEST(StaticSolver, HopelessLoadStepsAreGivenUpEarly) {
  const SoftCantilever c;
  StaticReport reports[2];
  std::vector<Vec3> solutions[2];
  for (const bool abandon : {false, true}) {
    StaticSolverOptions options;
    options.tangent = TangentKind::projected;
    options.relative_residual_tolerance = 1e-6;
    options.max_newton_iterations = 20;
    options.abandon_slow_load_steps = abandon;
    solutions[abandon] = c.mesh.positions;
    const Result<StaticReport> r = solve_static(c.model, c.problem, solutions[abandon], options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << "abandon " << abandon << ": " << r->message;
    reports[abandon] = *r;
  }
  std::printf("projected, soft cantilever: %d Newton iterations in %d load steps, %d when hopeless steps end early\n",
              reports[0].newton_iterations, reports[0].load_steps, reports[1].newton_iterations);
  ASSERT_GT(reports[0].load_step_failures, 0);  // the full step failed at the limit
  EXPECT_LT(reports[1].newton_iterations, reports[0].newton_iterations);
  // Some load step ended before the limit: the history goes to a smaller load fraction after fewer
  // than 20 iterations at one fraction.
  bool early = false;
  const std::vector<NewtonIteration>& h = reports[1].history;
  for (std::size_t i = 0, run = 1; i + 1 < h.size(); ++i) {
    if (h[i + 1].load_fraction == h[i].load_fraction) {
      ++run;
      continue;
    }
    early |= h[i + 1].load_fraction < h[i].load_fraction && run < 20;
    run = 1;
  }
  EXPECT_TRUE(early);
  double tip = 0, difference = 0;
  for (std::size_t v = 0; v < c.mesh.positions.size(); ++v) {
    tip = std::max(tip, (solutions[0][v] - c.mesh.positions[v]).norm());
    difference = std::max(difference, (solutions[1][v] - solutions[0][v]).norm());
  }
  EXPECT_LE(difference, 1e-4 * tip);
}

// A StVK bar (nu = 0) pushed end-on carries at most E / (3 sqrt 3) of compressive stress: its first
// Piola stress E lambda (lambda^2 - 1) / 2 is least at the stretch lambda = 1 / sqrt 3. Pushed with
// 0.4 E, it has no equilibrium past the load fraction 0.481. limit_resolution ends the search for it
// once it is bracketed to 1/8, in fewer iterations, and never past the limit; where an equilibrium
// exists at the full load (the cantilever bent far, which needs smaller load steps) it still reaches
// the full load, at the same equilibrium.
TEST(StaticSolver, LimitResolutionBracketsALimitLoadAndStillReachesTheFullLoad) {
  const double E = 1e6, L = 0.1;
  const TetMesh mesh = test::box(Vec3(L, L, L), {2, 2, 2});
  const FemModel model = make_fem_model(mesh, test::test_material(E, 0.0), ModelKind::stvk);
  StaticProblem problem;
  problem.anchors.assign(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v)
    if (mesh.positions[v].x() == 0.0) problem.anchors[v] = anchor_all;
  problem.external_forces = test::face_load(mesh, [&](const Vec3& p) { return p.x() == L; }, Vec3(-0.4 * E, 0, 0));
  const double limit = 1.0 / (3.0 * std::sqrt(3.0)) / 0.4;
  StaticReport reports[2];
  for (const int bracket : {0, 1}) {
    StaticSolverOptions options;
    options.tangent = TangentKind::projected;
    options.max_newton_iterations = 12;
    options.abandon_slow_load_steps = true;
    options.limit_resolution = bracket ? 0.125 : 0.0;
    std::vector<Vec3> x = mesh.positions;
    const Result<StaticReport> r = solve_static(model, problem, x, options);
    ASSERT_OK(r);
    EXPECT_FALSE(r->converged);
    EXPECT_LE(r->load_fraction, limit) << "bracket " << bracket;
    for (const Vec3& p : x) ASSERT_TRUE(p.allFinite());
    // The bar in equilibrium at the fraction reached: shortened, not inverted.
    for (std::size_t v = 0; v < x.size(); ++v)
      if (mesh.positions[v].x() == L) {
        EXPECT_LT(x[v].x(), L);
        EXPECT_GT(x[v].x(), 0.0);
      }
    reports[bracket] = *r;
  }
  std::printf("StVK bar past its limit (%.3f of the load): %.3f in %d Newton iterations, %.3f in %d bracketed\n", limit,
              reports[0].load_fraction, reports[0].newton_iterations, reports[1].load_fraction,
              reports[1].newton_iterations);
  EXPECT_GE(reports[1].load_fraction, limit - 0.125 - 0.0625);
  EXPECT_LT(reports[1].newton_iterations, reports[0].newton_iterations);
  EXPECT_NE(reports[1].message.find("bracketed"), std::string::npos) << reports[1].message;

  const SoftCantilever c;
  std::vector<Vec3> solutions[2];
  for (const int bracket : {0, 1}) {
    StaticSolverOptions options;
    options.tangent = TangentKind::projected;
    options.relative_residual_tolerance = 1e-6;
    options.max_newton_iterations = 20;
    options.abandon_slow_load_steps = true;
    options.limit_resolution = bracket ? 0.125 : 0.0;
    solutions[bracket] = c.mesh.positions;
    const Result<StaticReport> r = solve_static(c.model, c.problem, solutions[bracket], options);
    ASSERT_OK(r);
    // Bracketed, a full-load step that fails only on the final tolerance ends the solve there.
    if (bracket) {
      EXPECT_EQ(r->load_fraction, 1.0) << r->message;
      EXPECT_LE(r->relative_residual, options.intermediate_tolerance);
    } else {
      ASSERT_TRUE(r->converged) << r->message;
    }
    EXPECT_GT(r->load_step_failures, 0);  // the full step failed: the bracket was in play
  }
  double tip = 0, difference = 0;
  for (std::size_t v = 0; v < c.mesh.positions.size(); ++v) {
    tip = std::max(tip, (solutions[0][v] - c.mesh.positions[v]).norm());
    difference = std::max(difference, (solutions[1][v] - solutions[0][v]).norm());
  }
  std::printf("soft cantilever: bracketed solution within %.3g of the tip deflection\n", difference / tip);
  EXPECT_LE(difference, 1e-4 * tip);
}

TEST(StaticSolver, LinearModelSolvesInOneIteration) {
  // A linear problem is one linear solve, whichever linear solver, down to the default tolerance.
  const SoftCantilever soft;
  const FemModel model = make_fem_model(soft.mesh, test::test_material(1e7, 0.3), ModelKind::linear);
  for (LinearSolverKind kind :
       {LinearSolverKind::direct_ldlt, LinearSolverKind::pcg_block_jacobi, LinearSolverKind::pcg_block_gauss_seidel}) {
    StaticSolverOptions options;
    options.linear.kind = kind;
    std::vector<Vec3> x = soft.mesh.positions;
    const Result<StaticReport> r = solve_static(model, soft.problem, x, options);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged) << r->message;
    EXPECT_EQ(r->newton_iterations, 1) << to_string(kind);
    EXPECT_LE(r->relative_residual, options.relative_residual_tolerance) << to_string(kind);
  }
}

// The soft cantilever on 1, 2 and 4 threads, as it solves by default (the factorization takes
// over) and with PCG only (threaded sweeps and products): the same bits.
TEST(StaticSolver, LargeDeflectionBitIdenticalOnAnyThreadCount) {
  const SoftCantilever c;
  const int saved = num_threads();
  for (bool direct_when_cheaper : {true, false}) {
    std::vector<Vec3> results[3];
    for (int k = 0; k < 3; ++k) {
      set_num_threads(1 << k);
      StaticSolverOptions options;
      options.direct_when_cheaper = direct_when_cheaper;
      results[k] = c.mesh.positions;
      const Result<StaticReport> r = solve_static(c.model, c.problem, results[k], options);
      ASSERT_OK(r);
      ASSERT_TRUE(r->converged) << r->message;
    }
    for (int k = 1; k < 3; ++k)
      EXPECT_EQ(std::memcmp(results[0].data(), results[k].data(), results[0].size() * sizeof(Vec3)), 0)
          << (1 << k) << " threads, direct_when_cheaper " << direct_when_cheaper;
  }
  set_num_threads(saved);
}

TEST(StaticSolver, BitIdenticalOnAnyThreadCount) {
  const TetMesh mesh = test::box(Vec3(2.0, 1.0, 1.0), {16, 8, 8}, 0.1);
  const FemModel model = make_fem_model(mesh, test::test_material(kE, kNu), ModelKind::stvk);
  StaticProblem problem;
  problem.anchors.assign(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v)
    if (mesh.positions[v].x() == 0.0) problem.anchors[v] = anchor_all;
  problem.external_forces = test::face_load(mesh, [&](const Vec3& p) { return p.x() == 2.0; }, Vec3(1e6, -1e5, 0));
  problem.gravity = true;
  const int saved = num_threads();
  for (LinearSolverKind kind :
       {LinearSolverKind::pcg_block_jacobi, LinearSolverKind::pcg_block_gauss_seidel, LinearSolverKind::direct_ldlt}) {
    std::vector<Vec3> results[3];
    for (int k = 0; k < 3; ++k) {
      set_num_threads(1 << k);
      StaticSolverOptions options;
      options.linear.kind = kind;
      results[k] = mesh.positions;
      const Result<StaticReport> r = solve_static(model, problem, results[k], options);
      ASSERT_OK(r);
      ASSERT_TRUE(r->converged) << r->message;
    }
    for (int k = 1; k < 3; ++k)
      EXPECT_EQ(std::memcmp(results[0].data(), results[k].data(), results[0].size() * sizeof(Vec3)), 0)
          << to_string(kind) << ", " << (1 << k) << " threads";
  }
  set_num_threads(saved);
}

TEST(StaticSolver, ReusesPatternAcrossSolves) {
  Bar bar = make_bar(1e5, {4, 2, 2});
  const FemModel model = make_fem_model(bar.mesh, test::test_material(), ModelKind::stvk);
  StaticSolverOptions options;
  options.linear.kind = LinearSolverKind::direct_ldlt;
  StaticSolver solver(options);
  for (int round = 0; round < 3; ++round) {
    std::vector<Vec3> x = bar.mesh.positions;
    const Result<StaticReport> r = solver.solve(model, bar.problem, x);
    ASSERT_OK(r);
    ASSERT_TRUE(r->converged);
  }
  EXPECT_EQ(solver.pattern_builds(), 1);
  EXPECT_EQ(solver.linear_solver().symbolic_analyses(), 1);
  bar.problem.anchors[5] = anchor_all;
  std::vector<Vec3> x = bar.mesh.positions;
  ASSERT_OK(solver.solve(model, bar.problem, x));
  EXPECT_EQ(solver.pattern_builds(), 2);
}

TEST(StaticSolver, WarmStartCutsIterationsOfRepeatedImpacts) {
  Bar bar = make_bar(1e5, {12, 3, 3});
  for (std::size_t v = 0; v < bar.mesh.positions.size(); ++v)
    if (bar.mesh.positions[v].x() == bar.length) bar.problem.external_forces[v].y() += 20.0;
  const FemModel model = make_fem_model(bar.mesh, test::test_material(), ModelKind::stvk);
  int iterations[2][3] = {};
  for (bool warm : {false, true}) {
    StaticSolverOptions options;
    options.warm_start = warm;
    options.direct_when_cheaper = false;  // PCG throughout: its warm start is what is measured
    StaticSolver solver(options);
    StaticProblem p = bar.problem;
    for (int round = 0; round < 3; ++round) {
      std::vector<Vec3> x = bar.mesh.positions;
      const Result<StaticReport> r = solver.solve(model, p, x);
      ASSERT_OK(r);
      ASSERT_TRUE(r->converged) << r->message;
      iterations[warm][round] = r->linear_iterations_total;
      for (Vec3& f : p.external_forces) f *= 1.5;  // the next impact is harder
    }
  }
  std::printf("PCG iterations per impact, cold: %d %d %d, warm: %d %d %d\n", iterations[0][0], iterations[0][1],
              iterations[0][2], iterations[1][0], iterations[1][1], iterations[1][2]);
  EXPECT_EQ(iterations[1][0], iterations[0][0]);  // nothing to start from yet
  EXPECT_LT(iterations[1][1], iterations[0][1]);
  EXPECT_LT(iterations[1][2], iterations[0][2]);
}

TEST(StaticSolver, PrescribedAnchorDisplacement) {
  // Stretch the bar by moving its x = L face: the reaction follows Hooke's law, no external load.
  Bar bar = make_bar(0.0, {6, 2, 2});
  bar.problem.external_forces.clear();
  bar.problem.anchor_positions = bar.mesh.positions;
  const double stretch = 1e-4;
  for (std::size_t v = 0; v < bar.mesh.positions.size(); ++v)
    if (bar.mesh.positions[v].x() == bar.length) {
      bar.problem.anchors[v] |= 1;
      bar.problem.anchor_positions[v].x() += stretch;
    }
  const FemModel model = make_fem_model(bar.mesh, test::test_material(), ModelKind::linear);
  std::vector<Vec3> x = bar.mesh.positions;
  const Result<StaticReport> r = solve_static(model, bar.problem, x);
  ASSERT_OK(r);
  ASSERT_TRUE(r->converged) << r->message;
  for (std::size_t v = 0; v < x.size(); ++v)
    EXPECT_NEAR(x[v].x() - bar.mesh.positions[v].x(), stretch * bar.mesh.positions[v].x(), 1e-6 * stretch);
}

// A stiff linear cantilever (steel, 1 m x 0.1 m x 0.1 m, tip load) solved to a tight tolerance with
// the direct solver: one Newton step is exact, after which the residual sits at its round-off
// level (the positions carry the small displacements only to ~1e-16 m, and stresses of ~1e11 Pa
// moduli amplify that). The solver must recognise that, not iterate on noise until it gives up.
TEST(StaticSolver, StiffLinearCantileverConvergesAtRoundOffLevel) {
  const double L = 1.0, h = 0.1;
  const TetMesh mesh = test::box(Vec3(L, h, h), {12, 2, 2});
  const FemModel model = make_fem_model(mesh, test::test_material(200e9, 0.3), ModelKind::linear);
  StaticProblem problem;
  problem.anchors.assign(mesh.positions.size(), anchor_none);
  int loaded = 0;
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    if (mesh.positions[v].x() == 0.0) problem.anchors[v] = anchor_all;
    if (mesh.positions[v].x() == L) ++loaded;
  }
  // Reference: the linear system K u = f solved once by the factorization.
  BlockSparseMatrix k(mesh.num_nodes(), mesh.tets, problem.anchors);
  assemble_stiffness(model, mesh.positions, AssemblyOptions{}, k);
  for (double total : {1000.0, 1.0}) {  // N, along -y, spread over the loaded face's nodes
    problem.external_forces.assign(mesh.positions.size(), Vec3::Zero());
    for (std::size_t v = 0; v < mesh.positions.size(); ++v)
      if (mesh.positions[v].x() == L) problem.external_forces[v].y() = -total / loaded;
    Eigen::VectorXd f(k.size()), u;
    for (Index a = 0; a < k.num_active(); ++a) f.segment<3>(3 * a) = problem.external_forces[k.node_of_active()[a]];
    LinearSolver direct(LinearSolverOptions{.kind = LinearSolverKind::direct_ldlt});
    ASSERT_TRUE(direct.solve(k, f, u).converged);
    for (double tolerance : {1e-8, 1e-12}) {
      StaticSolverOptions options;
      options.relative_residual_tolerance = tolerance;
      options.linear.kind = LinearSolverKind::direct_ldlt;
      std::vector<Vec3> x = mesh.positions;
      const Result<StaticReport> r = solve_static(model, problem, x, options);
      ASSERT_OK(r);
      ASSERT_TRUE(r->converged) << total << " N, tolerance " << tolerance << ": " << r->message;
      EXPECT_EQ(r->load_steps, 1);
      EXPECT_EQ(r->newton_iterations, 1);  // a linear problem: one linear solve
      double max_u = 0, max_difference = 0;
      for (Index a = 0; a < k.num_active(); ++a) {
        const Index v = k.node_of_active()[a];
        max_u = std::max(max_u, u.segment<3>(3 * a).norm());
        max_difference = std::max(max_difference, (x[v] - mesh.positions[v] - u.segment<3>(3 * a)).norm());
      }
      // Positions near x = L hold a displacement only to a few ulps of L.
      const double representable = 16 * std::numeric_limits<double>::epsilon() * L;
      EXPECT_LE(max_difference, 1e-9 * max_u + representable) << total << " N, tolerance " << tolerance;
    }
  }
}

TEST(StaticSolver, NaNNeverEscapes) {
  Bar bar = make_bar(1e5, {3, 1, 1});
  const FemModel model = make_fem_model(bar.mesh, test::test_material(), ModelKind::stvk);
  const std::vector<Vec3> rest = bar.mesh.positions;
  auto expect_clean_failure = [&](const FemModel& m, const StaticProblem& p, const char* what) {
    std::vector<Vec3> x = rest;
    const Result<StaticReport> r = solve_static(m, p, x);
    ASSERT_OK(r);
    EXPECT_FALSE(r->converged) << what;
    EXPECT_FALSE(r->message.empty()) << what;
    for (const Vec3& q : x) EXPECT_TRUE(q.allFinite()) << what;
  };
  StaticProblem p = bar.problem;
  p.external_forces[3].y() = std::numeric_limits<double>::quiet_NaN();
  expect_clean_failure(model, p, "NaN force");
  p = bar.problem;
  p.external_forces[3].x() = std::numeric_limits<double>::infinity();
  expect_clean_failure(model, p, "infinite force");
  FemModel bad = model;
  bad.lame.mu = std::numeric_limits<double>::quiet_NaN();
  expect_clean_failure(bad, bar.problem, "NaN material");
  // Not anchored at all with a net force: no equilibrium exists.
  p = bar.problem;
  p.anchors.clear();
  expect_clean_failure(model, p, "no anchors");
  // Wrong sizes are errors.
  std::vector<Vec3> x(3, Vec3::Zero());
  EXPECT_FALSE(solve_static(model, bar.problem, x).ok());
}

// Every way a solve ends has its own status, converged == (status == converged), and a message
// exactly when it did not converge.
TEST(StaticSolver, StatusNamesTheOutcome) {
  Bar bar = make_bar(1e5, {3, 1, 1});
  const FemModel model = make_fem_model(bar.mesh, test::test_material(), ModelKind::stvk);
  auto expect_status = [&](const FemModel& m, const StaticProblem& p, const StaticSolverOptions& options,
                           SolveStatus expected) {
    std::vector<Vec3> x = bar.mesh.positions;
    const Result<StaticReport> r = solve_static(m, p, x, options);
    EXPECT_TRUE(r.ok());
    if (!r.ok()) return StaticReport{};
    EXPECT_STREQ(to_string(r->status), to_string(expected)) << r->message;
    EXPECT_EQ(r->converged, r->status == SolveStatus::converged) << r->message;
    EXPECT_EQ(r->converged, r->message.empty()) << r->message;
    for (const Vec3& q : x) EXPECT_TRUE(q.allFinite()) << r->message;
    return *r;
  };
  const StaticSolverOptions defaults;
  expect_status(model, bar.problem, defaults, SolveStatus::converged);
  StaticProblem unloaded = bar.problem;  // already in equilibrium
  unloaded.external_forces.clear();
  expect_status(model, unloaded, defaults, SolveStatus::converged);

  StaticProblem p = bar.problem;
  p.external_forces[3].y() = std::numeric_limits<double>::quiet_NaN();
  expect_status(model, p, defaults, SolveStatus::invalid_input);
  FemModel bad = model;
  bad.lame.mu = std::numeric_limits<double>::quiet_NaN();
  expect_status(bad, bar.problem, defaults, SolveStatus::invalid_input);
  // Finite forces whose squares overflow: the load as a whole is not finite.
  p = bar.problem;
  for (Vec3& f : p.external_forces) f *= 1e200;
  expect_status(model, p, defaults, SolveStatus::invalid_input);

  // Prescribed anchor positions so far away that the internal forces overflow.
  p = unloaded;
  p.anchor_positions = bar.mesh.positions;
  for (std::size_t v = 0; v < p.anchors.size(); ++v)
    if (p.anchors[v] != anchor_none) p.anchor_positions[v].x() += 1e300;
  expect_status(model, p, defaults, SolveStatus::not_finite);

  // A failed load step reports the reason it failed for.
  StaticSolverOptions options = defaults;
  options.max_newton_iterations = 0;
  options.max_load_halvings = 0;
  const StaticReport stuck = expect_status(model, bar.problem, options, SolveStatus::no_convergence);
  EXPECT_EQ(stuck.load_fraction, 0.0);
  EXPECT_NE(stuck.message.find("load step failed"), std::string::npos) << stuck.message;

  // PCG allowed no iteration: a zero step.
  options = defaults;
  options.linear.max_iterations = 0;
  options.max_load_halvings = 0;
  expect_status(model, bar.problem, options, SolveStatus::linear_solve_failed);

  // Without PSD projection and line search, a hard compression: the full step raises the energy.
  options = defaults;
  options.line_search = false;
  options.tangent = TangentKind::exact;
  options.max_load_halvings = 0;
  p = bar.problem;
  for (Vec3& f : p.external_forces) f *= -1e4;
  expect_status(model, p, options, SolveStatus::line_search_failed);

  std::vector<std::string> names;
  for (SolveStatus status :
       {SolveStatus::converged, SolveStatus::invalid_input, SolveStatus::not_finite, SolveStatus::no_convergence,
        SolveStatus::line_search_failed, SolveStatus::linear_solve_failed}) {
    const std::string name = to_string(status);
    EXPECT_NE(name, "?");
    EXPECT_EQ(std::count(names.begin(), names.end(), name), 0) << name;
    names.push_back(name);
  }
}
}  // namespace
}  // namespace shatter
