// Isosurface stuffing throughput: tets per second for a smooth shape (sphere) and a CSG shape
// (cinder block) at about 10k, 100k and 1M tets, and the sphere with grading.
#include <benchmark/benchmark.h>

#include "bench_main.h"

#include <cmath>
#include <numbers>

#include "shatter/meshing/stuffing.h"

namespace shatter {
namespace {

Sdf cinder_block() {
  return Sdf::subtract({Sdf::box(Vec3(0.195, 0.095, 0.095)),
                        Sdf::box(Vec3(0.065, 0.15, 0.055)).translated(Vec3(-0.0925, 0, 0)),
                        Sdf::box(Vec3(0.065, 0.15, 0.055)).translated(Vec3(0.0925, 0, 0))});
}

// h for about `tets` tets of a shape of volume v: a BCC lattice has 12 tets per h^3.
double edge_for(double v, double tets) { return std::cbrt(12.0 * v / tets); }

void run(benchmark::State& state, const Sdf& sdf, double volume, double grading = 0) {
  const double h = edge_for(volume, static_cast<double>(state.range(0)));
  std::int64_t tets = 0;
  for (auto _ : state) {
    auto m = stuff_tets(sdf, {.edge_length = h, .grading = grading});
    if (!m) {
      state.SkipWithError(m.error().to_string().c_str());
      return;
    }
    tets = m->num_tets();
    benchmark::DoNotOptimize(m->tets.data());
  }
  state.counters["tets"] = static_cast<double>(tets);
  state.counters["tets_per_s"] = benchmark::Counter(static_cast<double>(tets) * static_cast<double>(state.iterations()),
                                                    benchmark::Counter::kIsRate);
}

void BM_StuffSphere(benchmark::State& state) { run(state, Sdf::sphere(0.1), 4.0 / 3.0 * std::numbers::pi * 1e-3); }
void BM_StuffCinderBlock(benchmark::State& state) {
  run(state, cinder_block(), 0.39 * 0.19 * 0.19 - 2 * 0.13 * 0.19 * 0.11);
}

// Grading 1 on the sphere: the lattice is sized for the uniform count (range), the output is
// the coarsened mesh; tets_per_s counts output tets.
void BM_StuffSphereGraded(benchmark::State& state) {
  run(state, Sdf::sphere(0.1), 4.0 / 3.0 * std::numbers::pi * 1e-3, 1.0);
}

BENCHMARK(BM_StuffSphereGraded)->Arg(100'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_StuffSphereGraded)->Arg(1'000'000)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_StuffSphere)->Arg(10'000)->Arg(100'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_StuffSphere)->Arg(1'000'000)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_StuffCinderBlock)->Arg(10'000)->Arg(100'000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_StuffCinderBlock)->Arg(1'000'000)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace shatter

SHATTER_BENCHMARK_MAIN()
