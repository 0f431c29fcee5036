// Cost of steps with impacts (docs/performance.md): the paper's drops, step by step, and one impact
// analysis on a large body.
//   vase:  the porcelain vase (1.4k tets) dropped 1 m, tilted, shatters;
//   teddy: the modelling-clay teddy (3.6k tets) dropped 0.5 m, dents;
//   block: a concrete cinder block (0.8k tets) dropped 1 m onto another, breaks it;
// with --refine-like x10 meshes (arg refine = 10). Each iteration runs the whole drop (1 s of
// simulated time); counters give per-step median and worst, steps per second, and the worst step
// of a typical drop (the median over the drops of each drop's worst step) with its parts:
// collision (broad + narrow phase), rigid (the contact solver), impact (analyses and
// replacements), and of its slowest analysis the static solve and the fracture (stresses,
// plasticity, cracks, children).
//   impact_40k: one impact analysis (solve and fracture) of a 40k-tet glass bar.
#include <benchmark/benchmark.h>

#include "bench_main.h"

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/meshing/mesh_shape.h"
#include "shatter/meshing/shape_json.h"
#include "shatter/rigid/body.h"
#include "shatter/rigid/impact.h"
#include "shatter/world/world.h"

namespace shatter {
namespace {

std::string asset(const std::string& dir, const std::string& file) {
  return std::string(SHATTER_SOURCE_DIR) + "/assets/" + dir + "/" + file;
}

// The asset's mesh, or (refine > 1) its shape meshed with `refine` times the tets.
std::shared_ptr<const BodyModel> model_of(const std::string& name, const std::string& material, int refine,
                                          ModelKind kind = ModelKind::stvk) {
  TetMesh mesh;
  if (refine <= 1) {
    mesh = read_mesh(asset("meshes", name + ".msh"))->mesh;
  } else {
    auto shape = read_shape_json(asset("shapes", name + ".json"));
    MeshShapeDef def;
    def.stuffing.target_tets = shape->target_tets * refine;
    mesh = mesh_shape(shape->sdf, def, name)->mesh;
  }
  return std::make_shared<const BodyModel>(std::move(*make_body_model(mesh, *material_preset(material), kind)));
}

RigidState above_ground(const BodyModel& m, double height, const Quat& turn) {
  double lowest = 0;
  for (const Vec3& p : m.mesh.positions) lowest = std::min(lowest, (turn * p).y());
  RigidState r;
  r.orientation = turn;
  r.position = Vec3(0, height - lowest, 0);
  return r;
}

void BM_Drop(benchmark::State& state) {
  const int scene = static_cast<int>(state.range(0));
  const int refine = static_cast<int>(state.range(1));
  static std::shared_ptr<const BodyModel> models[3][2];
  const int slot = refine > 1 ? 1 : 0;
  auto& model = models[scene][slot];
  if (!model)
    model = scene == 0   ? model_of("vase", "porcelain", refine)
            : scene == 1 ? model_of("teddy", "modelling_clay", refine, ModelKind::corotated)
                         : model_of("cinder_block", "concrete", refine);
  auto clay = std::make_shared<ImpactSettings>();
  clay->fracture.plasticity.max_plastic_strain = 1.0;
  std::vector<double> step_ms;
  // Each drop's worst step, in parts: collision detection (broad and narrow phase), the contact
  // solver, the impact step (analyses and the world's changes), and the static solve and fracture
  // of its slowest analysis (the analyses of one step run side by side).
  struct Parts {
    double total = 0, collision = 0, rigid = 0, impact = 0, solve = 0, fracture = 0;
  };
  std::vector<Parts> drop_worst;
  for (auto _ : state) {
    state.PauseTiming();
    World w;
    w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
    if (scene == 0) {
      (void)w.add_body(model,
                       {.rigid = above_ground(*model, 1.0, Quat(Eigen::AngleAxisd(0.6, Vec3(1, 0, 1).normalized())))});
    } else if (scene == 1) {
      (void)w.add_body(model, {.rigid = above_ground(*model, 0.5, Quat::Identity()), .impact = clay});
    } else {
      const RigidState lower = above_ground(*model, 0.0005, Quat::Identity());
      RigidState upper = lower;
      upper.position.y() += 1.0 + 0.19;
      upper.orientation = Quat(Eigen::AngleAxisd(1.5707963, Vec3::UnitY()));
      (void)w.add_body(model, {.rigid = lower});
      (void)w.add_body(model, {.rigid = upper});
    }
    state.ResumeTiming();
    drop_worst.emplace_back();
    for (int i = 0; i < 60; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      w.step();
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      step_ms.push_back(ms);
      if (ms < drop_worst.back().total) continue;
      const StepStats& s = w.stats();
      Parts p{
          .total = ms, .collision = s.broad_phase_ms + s.narrow_phase_ms, .rigid = s.solver_ms, .impact = s.impact_ms};
      for (const ImpactRecord& r : w.events().impacts)
        if (r.solve_ms + r.fracture_ms > p.solve + p.fracture) {
          p.solve = r.solve_ms;
          p.fracture = r.fracture_ms;
        }
      drop_worst.back() = p;
    }
  }
  std::sort(step_ms.begin(), step_ms.end());
  state.counters["median_ms"] = step_ms[step_ms.size() / 2];
  state.counters["worst_ms"] = step_ms.back();
  // The worst step of a typical drop: the drop whose worst step is the median over the drops (the
  // first drop in the process also pays for memory and code touched for the first time).
  std::sort(drop_worst.begin(), drop_worst.end(), [](const Parts& a, const Parts& b) { return a.total < b.total; });
  const Parts& typical = drop_worst[drop_worst.size() / 2];
  state.counters["drop_worst_ms"] = typical.total;
  state.counters["drop_worst_collision_ms"] = typical.collision;
  state.counters["drop_worst_rigid_ms"] = typical.rigid;
  state.counters["drop_worst_impact_ms"] = typical.impact;
  state.counters["drop_worst_solve_ms"] = typical.solve;
  state.counters["drop_worst_fracture_ms"] = typical.fracture;
  double total = 0;
  for (const double ms : step_ms) total += ms;
  state.counters["steps_per_s"] = 1000.0 * static_cast<double>(step_ms.size()) / total;
  state.SetLabel(std::string(scene == 0 ? "vase" : scene == 1 ? "teddy" : "block") + (refine > 1 ? " x10" : ""));
}
BENCHMARK(BM_Drop)
    ->ArgNames({"scene", "refine"})
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({2, 1})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(9);
BENCHMARK(BM_Drop)
    ->ArgNames({"scene", "refine"})
    ->Args({0, 10})
    ->Args({1, 10})
    ->Args({2, 10})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

// One impact on a 40k-tet glass bar: the static solve and the fracture (plasticity, cracks,
// children) after it. crack 0: the blow splits the bar in four (every crack runs through it);
// crack 1: one crack whose region is a twentieth of the bar's size (radius_fraction 0.05), which
// leaves it whole: what the fracture costs beyond the crack region itself (stresses, the passes
// over the whole mesh, the child's model).
void BM_Impact40k(benchmark::State& state) {
  static const BodyModel bar = [] {
    const TetMesh m = make_box_mesh(
        {.min = Vec3(-0.5, -0.05, -0.05), .max = Vec3(0.5, 0.05, 0.05), .cells = {80, 9, 9}, .jitter = 0.0});
    return std::move(*make_body_model(m, *material_preset("glass")));
  }();
  BodyState body = make_body_state(bar);
  const ImpactContact blow{
      .point = Vec3(0, -0.05, 0), .normal = Vec3::UnitY(), .normal_impulse = 60, .approach_speed = 10};
  double solve = 0, fracture = 0;  // summed over the iterations
  std::size_t children = 0, cracks = 0;
  Index region = 0;  // tets in the crack regions, summed over the cracks
  StaticReport report;
  ImpactSettings settings;
  if (state.range(0) == 1) {
    settings.fracture.crack.radius_fraction = 0.05;
    settings.fracture.crack.max_cracks = 1;
  }
  for (auto _ : state) {
    auto r = analyze_impact(bar, body, std::span(&blow, 1), settings);
    solve += r->solve_ms;
    fracture += r->fracture_ms;
    children = r->children.size();
    cracks = r->cracks.size();
    region = 0;
    for (const CrackEvent& c : r->cracks) region += c.tets_marked;
    report = r->solve;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["tets"] = static_cast<double>(bar.mesh.num_tets());
  state.counters["solve_ms"] = solve / n;  // means over the iterations
  // The solve's Newton iterations, PCG iterations (all of them) and direct solves, and its time in
  // linear solves.
  state.counters["newton"] = report.newton_iterations;
  state.counters["pcg"] = report.linear_iterations_total;
  state.counters["direct"] = report.direct_iterations;
  state.counters["linear_ms"] = report.linear_solve_ms;
  state.counters["fracture_ms"] = fracture / n;
  state.counters["children"] = static_cast<double>(children);
  state.counters["cracks"] = static_cast<double>(cracks);
  state.counters["region"] = static_cast<double>(region);
}
BENCHMARK(BM_Impact40k)->ArgName("crack")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(1.0);

}  // namespace
}  // namespace shatter

SHATTER_BENCHMARK_MAIN()
