// Crack planning + cutting + fragment extraction for a given stress field (the cost of fracture
// beyond the static solve), at 4k and 40k tets; and the face table every new body builds.
#include <benchmark/benchmark.h>

#include "bench_main.h"

#include <cmath>
#include <map>

#include "shatter/fem/fem_model.h"
#include "shatter/fem/material.h"
#include "shatter/fracture/fracture.h"
#include "shatter/fracture/stress.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/topology.h"

namespace shatter {
namespace {

struct Setup {
  TetMesh mesh;
  std::vector<Vec3> deformed;
  std::vector<TetStress> stress;
  Material material;
  FemModel model;
  TetFaces faces;  // as a body keeps them
};

/// A bar of about `tets` tets with a bending-like stress field peaking at mid-span on the bottom.
const Setup& setup(std::int64_t tets) {
  static std::map<std::int64_t, Setup> cache;
  auto it = cache.find(tets);
  if (it != cache.end()) return it->second;
  Setup s;
  const Vec3 extent(1.0, 0.25, 0.25);
  s.mesh = make_box_mesh({.max = extent, .cells = cells_for_tet_count(extent, tets), .jitter = 0.15});
  s.deformed = s.mesh.positions;
  s.material = material_preset("glass").value();
  s.model = make_fem_model(s.mesh, s.material, ModelKind::stvk);
  s.faces = compute_faces(s.mesh);
  std::vector<Mat3> sigma;
  for (Index e = 0; e < s.mesh.num_tets(); ++e) {
    const Vec3 c = s.mesh.corners(e).rowwise().mean();
    const double bend = 1.3 * s.material.tensile_strength * (1 - 2 * std::abs(c.x() - 0.5)) * (1 - 8 * c.y());
    sigma.push_back(bend * Vec3::UnitX() * Vec3::UnitX().transpose());
  }
  s.stress = analyze_stresses(sigma);
  return cache.emplace(tets, std::move(s)).first->second;
}

void BM_FractureGivenStress(benchmark::State& state) {
  const Setup& s = setup(state.range(0));
  FractureOptions options;
  options.crack.max_cracks = static_cast<int>(state.range(1));
  options.crack.radius_fraction = 0.2;
  if (state.range(2) != 0) options.faces = &s.faces;
  std::size_t fragments = 0;
  for (auto _ : state) {
    const FractureResult r = fracture_with_stress(s.mesh, s.model, s.deformed, s.stress, options);
    fragments = r.fragments.size();
    benchmark::DoNotOptimize(r.mesh.positions.data());
  }
  state.counters["tets"] = static_cast<double>(s.mesh.num_tets());
  state.counters["fragments"] = static_cast<double>(fragments);
}
// Args: tets, cracks, whether the body's faces are given (as a world's body keeps them).
BENCHMARK(BM_FractureGivenStress)
    ->Args({4000, 1, 0})
    ->Args({40000, 1, 0})
    ->Args({40000, 4, 0})
    ->Args({40000, 1, 1})
    ->Args({40000, 4, 1})
    ->Unit(benchmark::kMillisecond);

// The stresses of every tet (Cauchy stress, principal stresses and directions, von Mises), as every
// impact analysis computes them before it looks for cracks: the bar twisted and bent, so that each
// tet's stress has all six components.
void BM_ComputeStresses(benchmark::State& state) {
  const Setup& s = setup(state.range(0));
  std::vector<Vec3> deformed = s.mesh.positions;
  for (Vec3& p : deformed) {
    const double angle = 0.01 * p.x();
    const double y = p.y() - 0.125, z = p.z() - 0.125;
    p = Vec3(p.x() + 0.002 * y, 0.125 + std::cos(angle) * y - std::sin(angle) * z + 0.003 * p.x() * p.x(),
             0.125 + std::sin(angle) * y + std::cos(angle) * z);
  }
  for (auto _ : state) benchmark::DoNotOptimize(compute_stresses(s.model, deformed).data());
  state.counters["tets"] = static_cast<double>(s.mesh.num_tets());
  state.counters["time_per_tet"] =
      benchmark::Counter(static_cast<double>(s.mesh.num_tets()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
// Real time: the work runs on the thread pool, and the main thread waits for it.
BENCHMARK(BM_ComputeStresses)->Arg(4000)->Arg(40000)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_PlanCracks(benchmark::State& state) {
  const Setup& s = setup(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(
        plan_cracks(s.mesh, s.stress, s.material, {.radius_fraction = 0.2, .max_cracks = 1}).size());
}
BENCHMARK(BM_PlanCracks)->Arg(4000)->Arg(40000)->Unit(benchmark::kMillisecond);

void BM_CutMesh(benchmark::State& state) {
  const Setup& s = setup(state.range(0));
  const auto plans = plan_cracks(s.mesh, s.stress, s.material, {.radius_fraction = 0.2, .max_cracks = 1});
  for (auto _ : state) {
    const CutResult r = cut_mesh(s.mesh, {.point = plans[0].origin, .normal = plans[0].normal}, plans[0].tets);
    benchmark::DoNotOptimize(r.mesh.tets.data());
  }
  state.counters["region"] = static_cast<double>(plans[0].tets.size());
}
BENCHMARK(BM_CutMesh)->Arg(4000)->Arg(40000)->Unit(benchmark::kMillisecond);

void BM_ExtractFragments(benchmark::State& state) {
  const Setup& s = setup(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(extract_fragments(s.mesh, 2500.0).size());
}
BENCHMARK(BM_ExtractFragments)->Arg(4000)->Arg(40000)->Unit(benchmark::kMillisecond);

// The face table (compute_faces) a body keeps and each fragment's model rebuilds.
void BM_ComputeFaces(benchmark::State& state) {
  const Setup& s = setup(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(compute_faces(s.mesh).faces.data());
}
BENCHMARK(BM_ComputeFaces)->Arg(4000)->Arg(40000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace shatter

SHATTER_BENCHMARK_MAIN()
