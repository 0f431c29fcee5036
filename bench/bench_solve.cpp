// Static solver benchmarks: stiffness refill, and the anchored impact solve of the simulator (a
// glass slab, every node farther than r from the contact point held, a force at the contact point)
// with each linear solver. Results and the command line: docs/solver.md.
#include <benchmark/benchmark.h>

#include "bench_main.h"

#include <cmath>

#include "shatter/fem/fem_model.h"
#include "shatter/mesh/generate.h"
#include "shatter/solve/block_ldlt.h"
#include "shatter/solve/dynamic_solver.h"
#include "shatter/solve/static_solver.h"

namespace shatter {
namespace {

Material glass() {
  // Soda-lime glass: E 70 GPa, nu 0.22, 2500 kg/m^3.
  return Material{.name = "glass",
                  .youngs_modulus = 70e9,
                  .poisson_ratio = 0.22,
                  .density = 2500,
                  .tensile_strength = 50e6,
                  .yield_stress = kInfinity};
}

// Slab 0.5 x 0.1 x 0.5 m of about `tets` tets.
TetMesh slab(std::int64_t tets) {
  BoxMeshDef def;
  def.max = Vec3(0.5, 0.1, 0.5);
  def.cells = cells_for_tet_count(def.max, tets);
  def.jitter = 0.1;
  return make_box_mesh(def);
}

// Impact at the middle of the top face: nodes farther than r = 0.1 m held, 10 kN downward spread
// over the nodes within 0.03 m of the contact point.
StaticProblem impact(const TetMesh& mesh) {
  const Vec3 contact(0.25, 0.1, 0.25);
  const double r = 0.1, spread = 0.03;
  StaticProblem p;
  p.anchors.assign(mesh.positions.size(), anchor_none);
  p.external_forces.assign(mesh.positions.size(), Vec3::Zero());
  double weight = 0;
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const double d = (mesh.positions[v] - contact).norm();
    if (d > r) p.anchors[v] = anchor_all;
    if (d < spread) weight += spread - d;
  }
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const double d = (mesh.positions[v] - contact).norm();
    if (d < spread) p.external_forces[v] = Vec3(0, -1e4 * (spread - d) / weight, 0);
  }
  return p;
}

// Args: tets, projected, corotated. Projected: the impact solves' StVK tangent (the negative part
// of each tet's S removed), or the corotated one with its twist modes clamped, at a deformed state,
// a smooth wave of 1e-4 strain, so that S takes both signs. Corotated: the model of ductile bodies
// (the clay teddy), unprojected as impacts first try it.
void BM_StiffnessRefill(benchmark::State& state) {
  const TetMesh mesh = slab(state.range(0));
  const bool projected = state.range(1) != 0;
  const FemModel model = make_fem_model(mesh, glass(), state.range(2) != 0 ? ModelKind::corotated : ModelKind::stvk);
  std::vector<AnchorMask> anchors(mesh.positions.size(), anchor_none);
  for (std::size_t v = 0; v < anchors.size(); ++v)
    if (mesh.positions[v].y() == 0.0) anchors[v] = anchor_all;
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, anchors);
  std::vector<Vec3> x = mesh.positions;
  if (projected)
    for (Vec3& p : x) p += 1e-5 * Vec3(std::sin(20 * p.y()), std::sin(20 * p.z()), std::sin(20 * p.x()));
  for (auto _ : state) {
    assemble_stiffness(model, x, {.project_psd = projected}, m);
    benchmark::DoNotOptimize(m.values());
  }
  state.counters["tets"] = mesh.num_tets();
  state.counters["dofs"] = m.size();
  state.counters["colors"] = m.num_colors();
}
BENCHMARK(BM_StiffnessRefill)
    ->ArgNames({"tets", "projected", "corotated"})
    ->ArgsProduct({{1000, 2000, 4000, 40000}, {0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

void BM_BuildPattern(benchmark::State& state) {
  const TetMesh mesh = slab(state.range(0));
  const StaticProblem p = impact(mesh);
  for (auto _ : state) {
    BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, p.anchors);
    benchmark::DoNotOptimize(m.values());
  }
  BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, p.anchors);
  state.counters["free_dofs"] = m.size();
}
BENCHMARK(BM_BuildPattern)->Arg(4000)->Arg(40000)->Unit(benchmark::kMillisecond);

// The direct solver's symbolic analysis (fill-reducing ordering, elimination tree, L's pattern) of
// the impact's free nodes: once per new pattern, so once per impact on a new body or fragment.
void BM_BlockLdltAnalyze(benchmark::State& state) {
  const TetMesh mesh = slab(state.range(0));
  const StaticProblem p = impact(mesh);
  const BlockSparseMatrix m(mesh.num_nodes(), mesh.tets, p.anchors);
  BlockLdlt ldlt;
  for (auto _ : state) {
    ldlt.analyze(m);
    benchmark::DoNotOptimize(ldlt.factor_nonzeros());
  }
  state.counters["block_rows"] = m.num_active();
  state.counters["factor_nonzeros"] = ldlt.factor_nonzeros();
}
BENCHMARK(BM_BlockLdltAnalyze)->Arg(4000)->Arg(40000)->Arg(200000)->Unit(benchmark::kMillisecond);

// One impact solve, two Newton iterations at most, relative residual 1e-6, StVK, glass. The
// StaticSolver is kept across iterations (same mesh and anchors: pattern and symbolic analysis
// reused), as the simulator does.
void BM_ImpactSolve(benchmark::State& state) {
  const auto kind = static_cast<LinearSolverKind>(state.range(0));
  const TetMesh mesh = slab(state.range(1));
  const FemModel model = make_fem_model(mesh, glass(), ModelKind::stvk);
  const StaticProblem problem = impact(mesh);
  StaticSolverOptions options;
  options.max_newton_iterations = 2;
  options.relative_residual_tolerance = 1e-6;
  options.max_load_halvings = 0;
  options.warm_start = false;  // every iteration repeats one impact: a warm start would be exact
  options.linear.kind = kind;
  options.linear.relative_tolerance = 1e-8;
  StaticSolver solver(options);
  std::vector<Vec3> x = mesh.positions;
  (void)solver.solve(model, problem, x);  // builds the pattern and the symbolic factorization
  StaticReport last;
  double assembly = 0, linear = 0, force = 0;
  for (auto _ : state) {
    x = mesh.positions;
    const Result<StaticReport> r = solver.solve(model, problem, x);
    last = *r;
    assembly += last.assembly_ms;
    linear += last.linear_solve_ms;
    force += last.force_ms;
  }
  const double n = static_cast<double>(state.iterations());
  state.SetLabel(to_string(kind));
  state.counters["tets"] = mesh.num_tets();
  state.counters["active_tets"] = static_cast<double>(solver.matrix().active_tets().size());
  state.counters["free_dofs"] = solver.matrix().size();
  state.counters["converged"] = last.converged;
  state.counters["newton"] = last.newton_iterations;
  state.counters["lin_it"] = last.linear_iterations_total;
  state.counters["rel_res"] = last.relative_residual;
  state.counters["asm_ms"] = assembly / n;
  state.counters["lin_ms"] = linear / n;
  state.counters["force_ms"] = force / n;
}
BENCHMARK(BM_ImpactSolve)
    ->ArgsProduct({{static_cast<int>(LinearSolverKind::direct_ldlt),
                    static_cast<int>(LinearSolverKind::pcg_block_jacobi),
                    static_cast<int>(LinearSolverKind::pcg_block_gauss_seidel)},
                   {4000, 10000, 40000}})
    ->Unit(benchmark::kMillisecond);

// The first impact on a new mesh: pattern and symbolic analysis included.
void BM_ImpactSolveCold(benchmark::State& state) {
  const TetMesh mesh = slab(state.range(0));
  const FemModel model = make_fem_model(mesh, glass(), ModelKind::stvk);
  const StaticProblem problem = impact(mesh);
  StaticSolverOptions options;
  options.max_newton_iterations = 2;
  for (auto _ : state) {
    StaticSolver solver(options);
    std::vector<Vec3> x = mesh.positions;
    benchmark::DoNotOptimize(solver.solve(model, problem, x));
  }
}
BENCHMARK(BM_ImpactSolveCold)->Arg(4000)->Arg(40000)->Unit(benchmark::kMillisecond);

// Large deformation (docs/performance.md, against CalculiX NLGEOM on the same meshes): the soft
// cantilever 1 m x 0.1 m x 0.1 m, E = 10 MPa, nu = 0.3, clamped at x = 0, 120 N down on the tip face
// (PL^2/EI = 1.44). Arg 0: cells along the length (4 per 0.1 m across: 20 -> 480 tets, 40 -> 3840);
// arg 1: the linear solver (0 PCG Gauss-Seidel, 1 direct). Default settings otherwise.
void BM_NewtonLargeDeflection(benchmark::State& state) {
  const Index n = static_cast<Index>(state.range(0));
  const TetMesh mesh =
      make_box_mesh(BoxMeshDef{.min = Vec3::Zero(), .max = Vec3(1.0, 0.1, 0.1), .cells = {n, n / 10, n / 10}});
  const Material soft{.name = "soft",
                      .youngs_modulus = 1e7,
                      .poisson_ratio = 0.3,
                      .density = 1000,
                      .tensile_strength = kInfinity,
                      .yield_stress = kInfinity};
  const FemModel model = make_fem_model(mesh, soft, ModelKind::stvk);
  StaticProblem p;
  p.anchors.assign(mesh.positions.size(), anchor_none);
  p.external_forces.assign(mesh.positions.size(), Vec3::Zero());
  // Consistent load of a uniform traction on the tip face: each boundary triangle gives a third of
  // its area to each corner.
  double tip_area = 0;
  std::vector<double> area(mesh.positions.size(), 0.0);
  for (const TetIndices& t : mesh.tets)
    for (int f = 0; f < 4; ++f) {
      const Index a = t[(f + 1) % 4], b = t[(f + 2) % 4], c = t[(f + 3) % 4];
      if (mesh.positions[a].x() != 1.0 || mesh.positions[b].x() != 1.0 || mesh.positions[c].x() != 1.0) continue;
      const double face =
          0.5 * (mesh.positions[b] - mesh.positions[a]).cross(mesh.positions[c] - mesh.positions[a]).norm();
      for (Index v : {a, b, c}) area[v] += face / 3;
      tip_area += face;
    }
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    if (mesh.positions[v].x() == 0.0) p.anchors[v] = anchor_all;
    p.external_forces[v] = Vec3(0, 0, -120.0 * area[v] / tip_area);
  }
  StaticSolverOptions options;
  options.linear.kind = state.range(1) == 0 ? LinearSolverKind::pcg_block_gauss_seidel : LinearSolverKind::direct_ldlt;
  StaticReport last;
  for (auto _ : state) {
    std::vector<Vec3> x = mesh.positions;
    StaticSolver solver(options);
    Result<StaticReport> r = solver.solve(model, p, x);
    if (!r.ok() || !r->converged) {
      state.SkipWithError("the cantilever did not converge");
      return;
    }
    last = *r;
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["tets"] = mesh.num_tets();
  state.counters["newton"] = last.newton_iterations;
  state.counters["load_steps"] = last.load_steps;
  state.counters["projected"] = last.projected_iterations;
}
BENCHMARK(BM_NewtonLargeDeflection)
    ->ArgsProduct({{20, 40}, {0, 1}})
    ->ArgNames({"cells", "direct"})
    ->Unit(benchmark::kMillisecond);

// Full dynamics (docs/dynamics.md): one 1/60 s implicit-Euler step of a soft cube (E = 0.1 MPa,
// 0.2 m) of n^3 cells x 6 tets bouncing on the ground, averaged over its first 60 steps (falling,
// landing, rebounding): the time shown is for the 60 steps.
void BM_DynamicStep(benchmark::State& state) {
  const auto cells = static_cast<Index>(state.range(0));
  TetMesh mesh = make_box_mesh({.min = Vec3(0, 0.05, 0), .max = Vec3(0.2, 0.25, 0.2), .cells = {cells, cells, cells}});
  Material soft = glass();
  soft.youngs_modulus = 1e5, soft.poisson_ratio = 0.3, soft.density = 1000;
  const FemModel model = make_fem_model(mesh, soft, ModelKind::stvk);
  const DynamicObstacles ground{.planes = {ContactPlane{.normal = Vec3::UnitY(), .offset = 0, .friction = 0.5}}};
  int iterations = 0, steps = 0;
  for (auto _ : state) {
    state.PauseTiming();
    DynamicSolver solver;
    DynamicState s{mesh.positions, std::vector<Vec3>(mesh.positions.size(), Vec3::Zero())};
    state.ResumeTiming();
    for (int k = 0; k < 60; ++k) {
      auto r = solver.step(model, ground, s);
      if (!r.ok() || !r->converged) {
        state.SkipWithError("the step failed");
        return;
      }
      iterations += r->newton_iterations;
      ++steps;
    }
  }
  state.counters["tets"] = model.num_tets();
  state.counters["newton_per_step"] = static_cast<double>(iterations) / steps;
}
BENCHMARK(BM_DynamicStep)->Arg(4)->Arg(8)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace shatter

SHATTER_BENCHMARK_MAIN()
