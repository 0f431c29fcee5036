// Cross-check of static linear analysis against CalculiX (an independent FEM code) on the same
// C3D4 meshes, anchors and nodal loads: a cantilever, a bar in tension, a block under a load patch.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "shatter/fem/fem_model.h"
#include "shatter/mesh/generate.h"
#include "shatter/scene/static_case.h"
#include "shatter/scene/static_results.h"
#include "shatter/solve/static_solver.h"
#include "solve/solve_test_util.h"
#include "support/test_support.h"
#include "tools/calculix.h"

namespace shatter {
namespace {

struct Comparison {
  double max_u = 0;             // largest |u| of the reference, m
  double max_u_difference = 0;  // largest |u_shatter - u_ccx|, m
  double max_stress = 0;        // largest |sigma_ij| of the reference, Pa
  double max_stress_difference = 0;
  StaticResults results;
  StaticReport report;           // shatter's solve
  calculix::Solution reference;  // CalculiX's
};

// Solve `case_json` on `mesh` with shatter and with CalculiX; compare. The linear model is solved
// with a direct solver to 1e-8; StVK (`nlgeom`, CalculiX's NLGEOM) with the solver's defaults, and
// CalculiX with tight field controls so that both are converged well below the comparison.
Comparison compare_with_calculix(const TetMesh& mesh, const std::string& case_json, const test::TempDir& dir,
                                 bool nlgeom = false) {
  Comparison out;
  auto c = parse_static_case(case_json, "calculix_case.json");
  EXPECT_OK(c);
  if (!c.ok()) return out;
  EXPECT_EQ(c->model, nlgeom ? ModelKind::stvk : ModelKind::linear);
  auto resolved = resolve_static_case(*c, mesh);
  EXPECT_OK(resolved);
  if (!resolved.ok()) return out;

  const FemModel model = make_fem_model(mesh, c->material, c->model);
  std::vector<Vec3> x = mesh.positions;
  StaticSolverOptions options = make_solver_options(c->solver);
  if (!nlgeom) {
    options.relative_residual_tolerance = 1e-8;
    options.linear.kind = LinearSolverKind::direct_ldlt;  // exact linear solves: Newton converges in one step
  }
  auto report = solve_static(model, make_static_problem(*c, *resolved), x, options);
  EXPECT_OK(report);
  if (!report.ok()) return out;
  EXPECT_TRUE(report->converged) << report->message;
  out.report = *report;
  out.results = compute_static_results(model, mesh, x);

  calculix::Deck deck{.mesh = &mesh,
                      .youngs_modulus = c->material.youngs_modulus,
                      .poisson_ratio = c->material.poisson_ratio,
                      .held = resolved->held,
                      .prescribed_displacement = {},
                      .forces = resolved->forces,
                      .nlgeom = nlgeom,
                      .initial_increment = 0.1,
                      .residual_control = nlgeom ? 1e-9 : 0.0};
  deck.prescribed_displacement.resize(mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    deck.prescribed_displacement[i] = resolved->prescribed[i] - mesh.positions[i];
  const calculix::Solution ref = calculix::run(deck, dir.path().string());
  EXPECT_EQ(ref.error, "");
  if (!ref.error.empty()) return out;
  out.reference = ref;

  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    out.max_u = std::max(out.max_u, ref.displacement[i].norm());
    out.max_u_difference = std::max(out.max_u_difference, (out.results.displacement[i] - ref.displacement[i]).norm());
  }
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    out.max_stress = std::max(out.max_stress, ref.stress[e].cwiseAbs().maxCoeff());
    out.max_stress_difference =
        std::max(out.max_stress_difference, (out.results.stress[e] - ref.stress[e]).cwiseAbs().maxCoeff());
  }
  return out;
}

// The .dat file prints 7 significant digits: agreement to a few parts in 1e7 of the largest value
// is what the comparison can resolve.
constexpr double kDisplacementTolerance = 2e-6;
constexpr double kStressTolerance = 2e-5;

TEST(CalculiX, CantileverUnderTipLoad) {
  SHATTER_REQUIRE_TOOL(calculix::available(), "ccx (CalculiX) is not installed");
  test::TempDir dir;
  const TetMesh mesh = make_box_mesh(BoxMeshDef{.min = Vec3::Zero(), .max = Vec3(1.0, 0.1, 0.1), .cells = {12, 2, 2}});
  const Comparison c = compare_with_calculix(mesh, R"({
    "material": "steel", "model": "linear",
    "anchors": [{"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}}],
    "loads": [{"box": {"min": [1, 0, 0], "max": [1, 0.1, 0.1]}, "total_force": [0, -1000, 0]}]
  })",
                                             dir);
  ASSERT_GT(c.max_u, 0.0);
  EXPECT_LE(c.max_u_difference, kDisplacementTolerance * c.max_u) << c.max_u_difference << " of " << c.max_u;
  EXPECT_LE(c.max_stress_difference, kStressTolerance * c.max_stress)
      << c.max_stress_difference << " of " << c.max_stress;
}

TEST(CalculiX, BarInTensionWithSymmetryRollers) {
  SHATTER_REQUIRE_TOOL(calculix::available(), "ccx (CalculiX) is not installed");
  test::TempDir dir;
  const double length = 0.2, side = 0.02, force = 2000.0;
  const TetMesh mesh =
      make_box_mesh(BoxMeshDef{.min = Vec3::Zero(), .max = Vec3(length, side, side), .cells = {8, 2, 2}});
  const Comparison c = compare_with_calculix(mesh, R"({
    "material": "glass", "model": "linear",
    "anchors": [
      {"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}, "components": "x"},
      {"plane": {"point": [0, 0, 0], "normal": [0, 1, 0]}, "components": "y"},
      {"plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}, "components": "z"}],
    "loads": [{"plane": {"point": [0.2, 0, 0], "normal": [1, 0, 0]}, "total_force": [2000, 0, 0],
               "distribution": "area"}]
  })",
                                             dir);
  ASSERT_GT(c.max_u, 0.0);
  EXPECT_LE(c.max_u_difference, kDisplacementTolerance * c.max_u) << c.max_u_difference << " of " << c.max_u;
  EXPECT_LE(c.max_stress_difference, kStressTolerance * c.max_stress);
  // Uniform tension (patch test): sigma_xx = F / A everywhere, end displacement F L / (E A).
  auto glass = material_preset("glass");
  ASSERT_OK(glass);
  const double area = side * side;
  for (const Mat3& s : c.results.stress) EXPECT_NEAR(s(0, 0), force / area, 1e-6 * force / area);
  const double expected = force * length / (glass->youngs_modulus * area);
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    if (mesh.positions[i].x() == length) {
      EXPECT_NEAR(c.results.displacement[i].x(), expected, 1e-9 * expected);
    }
}

TEST(CalculiX, JitteredBlockUnderLoadPatch) {
  SHATTER_REQUIRE_TOOL(calculix::available(), "ccx (CalculiX) is not installed");
  test::TempDir dir;
  const TetMesh mesh = make_box_mesh(BoxMeshDef{.min = Vec3::Zero(),
                                                .max = Vec3::Ones(),
                                                .cells = {4, 4, 4},
                                                .pattern = BoxMeshDef::Pattern::five,
                                                .jitter = 0.15,
                                                .seed = 7});
  const Comparison c = compare_with_calculix(mesh, R"({
    "material": "concrete", "model": "linear",
    "anchors": [{"plane": {"point": [0, 0, 0], "normal": [0, 1, 0]}}],
    "loads": [{"box": {"min": [0.2, 1, 0.2], "max": [0.8, 1, 0.8]}, "total_force": [2e4, -1e5, 0]},
              {"nodes": [125], "force": [0, 0, 5e3]}]
  })",
                                             dir);
  ASSERT_GT(c.max_u, 0.0);
  EXPECT_LE(c.max_u_difference, kDisplacementTolerance * c.max_u) << c.max_u_difference << " of " << c.max_u;
  EXPECT_LE(c.max_stress_difference, kStressTolerance * c.max_stress);
}

// Geometrically non-linear: shatter's StVK against CalculiX's NLGEOM (its *ELASTIC is St.
// Venant-Kirchhoff there) on the same meshes, with shatter's default solver settings. Newton must
// end quadratically: each of the last iterations squares the residual (to within a factor).
void expect_nonlinear_agreement(const Comparison& c, const char* name) {
  ASSERT_GT(c.max_u, 0.0);
  std::printf(
      "%s: max |u| %.6g m, difference %.3g (%.2g of max); shatter %d load steps, %d Newton iterations "
      "(%d projected), %.1f ms; CalculiX %d increments, %d iterations, %.0f ms\n",
      name, c.max_u, c.max_u_difference, c.max_u_difference / c.max_u, c.report.load_steps, c.report.newton_iterations,
      c.report.projected_iterations, c.report.total_ms, c.reference.increments, c.reference.iterations,
      1e3 * c.reference.seconds);
  EXPECT_LE(c.max_u_difference, 1e-6 * c.max_u) << c.max_u_difference << " of " << c.max_u;
  EXPECT_LE(c.max_stress_difference, 1e-5 * c.max_stress) << c.max_stress_difference << " of " << c.max_stress;
  // Residual history: from below 1e-2 on, each residual is at most ~ the square of the one before
  // (times a constant), the mark of quadratic convergence. Residuals within 10x of the tolerance
  // are left out: there the inexact linear solve (a tolerance loosened to what Newton needs) sets them.
  const std::vector<NewtonIteration>& h = c.report.history;
  ASSERT_GE(h.size(), 3u);
  const std::string trace = test::residual_trace(h);
  std::printf("%s: residual history%s\n", name, trace.c_str());
  const double tolerance = StaticSolverOptions{}.relative_residual_tolerance;
  EXPECT_LE(h.back().relative_residual, tolerance);
  int quadratic_steps = 0;
  for (std::size_t k = 1; k < h.size(); ++k) {
    const double before = h[k - 1].relative_residual, after = h[k].relative_residual;
    if (before >= 1e-2 || after <= 10 * tolerance) continue;
    EXPECT_LE(after, 1e3 * before * before) << "iteration " << k << ":" << trace;
    ++quadratic_steps;
  }
  EXPECT_GE(quadratic_steps, 1) << trace;
  EXPECT_LE(c.report.newton_iterations, 40);
}

TEST(CalculiX, NonlinearCantileverUnderTipLoad) {
  // E = 10 MPa, 120 N: PL^2/EI = 1.44, a tip deflection of a quarter of the length.
  // On 480 and 3840 tets.
  SHATTER_REQUIRE_TOOL(calculix::available(), "ccx (CalculiX) is not installed");
  for (const Index cells : {20, 40}) {
    test::TempDir dir;
    const TetMesh mesh = make_box_mesh(
        BoxMeshDef{.min = Vec3::Zero(), .max = Vec3(1.0, 0.1, 0.1), .cells = {cells, cells / 10, cells / 10}});
    const Comparison c = compare_with_calculix(mesh, R"({
      "material": {"youngs_modulus": 1e7, "poisson_ratio": 0.3, "density": 1000}, "model": "stvk",
      "anchors": [{"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}}],
      "loads": [{"plane": {"point": [1, 0, 0], "normal": [1, 0, 0]}, "total_force": [0, 0, -120],
                 "distribution": "area"}]
    })",
                                               dir, true);
    expect_nonlinear_agreement(c, ("cantilever, " + std::to_string(mesh.num_tets()) + " tets").c_str());
    EXPECT_GT(c.max_u, 0.2);
  }
}

TEST(CalculiX, NonlinearTwistedBar) {
  // The end face of a clamped bar turned by 60 degrees about the bar's axis (prescribed positions).
  SHATTER_REQUIRE_TOOL(calculix::available(), "ccx (CalculiX) is not installed");
  test::TempDir dir;
  const TetMesh mesh =
      make_box_mesh(BoxMeshDef{.min = Vec3(0, -0.05, -0.05), .max = Vec3(0.5, 0.05, 0.05), .cells = {10, 2, 2}});
  std::string anchors;
  const double angle = 60.0 * 3.14159265358979323846 / 180.0;
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    const Vec3& p = mesh.positions[i];
    if (p.x() != 0.5) continue;
    const Vec3 q(p.x(), std::cos(angle) * p.y() - std::sin(angle) * p.z(),
                 std::sin(angle) * p.y() + std::cos(angle) * p.z());
    const Vec3 d = q - p;
    char buf[200];
    std::snprintf(buf, sizeof buf, R"(, {"nodes": [%d], "displacement": [0, %.17g, %.17g]})", static_cast<int>(i),
                  d.y(), d.z());
    anchors += buf;
  }
  const Comparison c = compare_with_calculix(mesh,
                                             R"({
    "material": {"youngs_modulus": 1e7, "poisson_ratio": 0.3, "density": 1000}, "model": "stvk",
    "anchors": [{"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}})" +
                                                 anchors + R"(]
  })",
                                             dir, true);
  expect_nonlinear_agreement(c, "twisted bar");
}

TEST(CalculiX, NonlinearCompressedColumnNearBuckling) {
  // A clamped column 1 m x 0.1 m x 0.1 m pushed down its axis at about 0.8 of this mesh's buckling
  // load (about 440 N: the sideways deflection under a 2.5 N push grows 2.35 times from 10 to 250 N),
  // with a 1 % sideways push: the stiffness is close to singular and the column bows.
  SHATTER_REQUIRE_TOOL(calculix::available(), "ccx (CalculiX) is not installed");
  test::TempDir dir;
  const TetMesh mesh = make_box_mesh(BoxMeshDef{.min = Vec3::Zero(), .max = Vec3(0.1, 1.0, 0.1), .cells = {2, 16, 2}});
  const Comparison c = compare_with_calculix(mesh, R"({
    "material": {"youngs_modulus": 1e7, "poisson_ratio": 0.3, "density": 1000}, "model": "stvk",
    "anchors": [{"plane": {"point": [0, 0, 0], "normal": [0, 1, 0]}}],
    "loads": [{"plane": {"point": [0, 1, 0], "normal": [0, 1, 0]}, "total_force": [3.5, -350, 0],
               "distribution": "area"}]
  })",
                                             dir, true);
  expect_nonlinear_agreement(c, "column");
}

}  // namespace
}  // namespace shatter
