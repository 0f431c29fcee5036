// FEM kernel costs: global internal force (reference vs accelerated, 1 and 2 threads) and the
// element stiffness, on jittered box meshes with a small random deformation. Counter: time per tet.
#include <benchmark/benchmark.h>

#include "bench_main.h"

#include <map>
#include <memory>
#include <utility>

#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/fem/fem_model.h"
#include "shatter/mesh/generate.h"

namespace shatter {
namespace {

struct Case {
  TetMesh mesh;
  FemModel model;
  std::vector<Vec3> x;  // deformed positions, m
};

const Case& get_case(std::int64_t target_tets, ModelKind kind) {
  static std::map<std::pair<std::int64_t, int>, std::unique_ptr<Case>> cache;
  auto& slot = cache[{target_tets, static_cast<int>(kind)}];
  if (!slot) {
    slot = std::make_unique<Case>();
    const Vec3 extent(1, 1, 1);
    slot->mesh = make_box_mesh({.max = extent, .cells = cells_for_tet_count(extent, target_tets), .jitter = 0.1});
    slot->model = make_fem_model(slot->mesh, *material_preset("glass"), kind);
    Random rng(42);
    slot->x = slot->mesh.positions;
    for (Vec3& p : slot->x) p += rng.uniform_vec3(-1e-3, 1e-3) / std::cbrt(static_cast<double>(target_tets));
  }
  return *slot;
}

void set_per_tet(benchmark::State& state, std::int64_t n_tets) {
  state.counters["tets"] = static_cast<double>(n_tets);
  state.counters["time_per_tet"] = benchmark::Counter(
      static_cast<double>(n_tets), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void BM_ForcesReference(benchmark::State& state) {
  const Case& c = get_case(state.range(0), static_cast<ModelKind>(state.range(1)));
  std::vector<Vec3> f;
  for (auto _ : state) {
    internal_forces_reference(c.model, c.x, f);
    benchmark::DoNotOptimize(f.data());
  }
  set_per_tet(state, c.model.num_tets());
}

void BM_ForcesAccelerated(benchmark::State& state) {
  const Case& c = get_case(state.range(0), static_cast<ModelKind>(state.range(1)));
  const int saved = num_threads();
  set_num_threads(static_cast<int>(state.range(2)));
  std::vector<Vec3> f;
  ForceWorkspace workspace;
  for (auto _ : state) {
    internal_forces(c.model, c.x, f, workspace);
    benchmark::DoNotOptimize(f.data());
  }
  set_num_threads(saved);
  set_per_tet(state, c.model.num_tets());
}

void BM_TotalEnergy(benchmark::State& state) {
  const Case& c = get_case(state.range(0), static_cast<ModelKind>(state.range(1)));
  const int saved = num_threads();
  set_num_threads(static_cast<int>(state.range(2)));
  for (auto _ : state) benchmark::DoNotOptimize(total_energy(c.model, c.x));
  set_num_threads(saved);
  set_per_tet(state, c.model.num_tets());
}

void BM_TetStiffness(benchmark::State& state) {
  const ModelKind kind = static_cast<ModelKind>(state.range(0));
  const Case& c = get_case(4000, kind);
  const std::int64_t n = c.model.num_tets();
  std::int64_t e = 0;
  for (auto _ : state) {
    const TetIndices& t = c.model.tets[static_cast<std::size_t>(e)];
    Mat34 xe;
    for (int k = 0; k < 4; ++k) xe.col(k) = c.x[static_cast<std::size_t>(t[k])];
    Mat12 K = tet_stiffness(kind, c.model.lame, c.model.rest[static_cast<std::size_t>(e)], xe);
    benchmark::DoNotOptimize(K.data());
    if (++e == n) e = 0;
  }
  set_per_tet(state, 1);
}

constexpr int kStvk = static_cast<int>(ModelKind::stvk);
constexpr int kLinear = static_cast<int>(ModelKind::linear);
constexpr int kCorotated = static_cast<int>(ModelKind::corotated);

BENCHMARK(BM_ForcesReference)
    ->ArgNames({"tets", "model"})
    ->Args({4000, kStvk})
    ->Args({40000, kStvk})
    ->Args({400000, kStvk})
    ->Args({40000, kLinear})
    ->Args({40000, kCorotated})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ForcesAccelerated)
    ->ArgNames({"tets", "model", "threads"})
    ->Args({4000, kStvk, 1})
    ->Args({4000, kStvk, 2})
    ->Args({40000, kStvk, 1})
    ->Args({40000, kStvk, 2})
    ->Args({400000, kStvk, 1})
    ->Args({400000, kStvk, 2})
    ->Args({40000, kLinear, 1})
    ->Args({40000, kLinear, 2})
    ->Args({40000, kCorotated, 1})
    ->Args({40000, kCorotated, 2})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();
BENCHMARK(BM_TotalEnergy)
    ->ArgNames({"tets", "model", "threads"})
    ->Args({40000, kStvk, 1})
    ->Args({40000, kStvk, 2})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();
BENCHMARK(BM_TetStiffness)->ArgNames({"model"})->Arg(kStvk)->Arg(kLinear)->Arg(kCorotated);

}  // namespace
}  // namespace shatter
SHATTER_BENCHMARK_MAIN()
