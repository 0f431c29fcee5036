// Broad phase and rigid integration costs of the scenes the rigid-body targets name: 1,000 pieces
// resting on a ground slab (spread over 10 x 10 m), and 100 bodies in a pile (a 1 m cube), and the
// integration step of 1,000 tumbling bodies.
#include <benchmark/benchmark.h>

#include "shatter/collide/broad_phase.h"
#include "shatter/core/random.h"
#include "shatter/mesh/generate.h"
#include "shatter/rigid/integrate.h"

namespace shatter {
namespace {

Aabb cube(const Vec3& c, double half) {
  Aabb b;
  b.extend(c - Vec3::Constant(half));
  b.extend(c + Vec3::Constant(half));
  return b;
}

// A ground slab (half-width `ground`, top at y = 0) under `n` cubes of half-size in [lo, hi],
// centred by place(rng, half).
template <class Place>
std::vector<Aabb> scene(int n, double ground, std::uint64_t seed, double lo, double hi, Place&& place) {
  Random rng(seed);
  std::vector<Aabb> boxes;
  Aabb slab;
  slab.extend(Vec3(-ground, -0.5, -ground));
  slab.extend(Vec3(ground, 0, ground));
  boxes.push_back(slab);
  for (int i = 0; i < n; ++i) {
    const double half = rng.uniform(lo, hi);
    boxes.push_back(cube(place(rng, half), half));
  }
  return boxes;
}

// `n` pieces of 2-10 cm resting on the ground over 10 x 10 m.
std::vector<Aabb> resting(int n) {
  return scene(n, 6, 1, 0.01, 0.05,
               [](Random& rng, double half) { return Vec3(rng.uniform(-5, 5), half, rng.uniform(-5, 5)); });
}

// `n` bodies of 10-20 cm packed in a 1 m cube above the ground.
std::vector<Aabb> pile(int n) {
  return scene(n, 3, 2, 0.05, 0.1, [](Random& rng, double) {
    return Vec3(rng.uniform(-0.5, 0.5), rng.uniform(0.0, 1.0), rng.uniform(-0.5, 0.5));
  });
}

// One broad-phase query per iteration; the grid keeps its buffers between steps, as in a simulation.
void run_broad_phase(benchmark::State& state, const std::vector<Aabb>& boxes) {
  BroadPhase grid;
  std::size_t pairs = 0;
  for (auto _ : state) {
    pairs = grid.find_pairs(boxes).size();
    benchmark::DoNotOptimize(pairs);
  }
  state.counters["pairs"] = static_cast<double>(pairs);
}

void BM_BroadPhaseResting(benchmark::State& state) {
  run_broad_phase(state, resting(static_cast<int>(state.range(0))));
}
BENCHMARK(BM_BroadPhaseResting)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

void BM_BroadPhasePile(benchmark::State& state) { run_broad_phase(state, pile(static_cast<int>(state.range(0)))); }
BENCHMARK(BM_BroadPhasePile)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);

void BM_RigidIntegrate(benchmark::State& state) {
  const TetMesh m =
      make_box_mesh({.min = Vec3(-0.15, -0.05, -0.025), .max = Vec3(0.15, 0.05, 0.025), .cells = {6, 2, 1}});
  const RigidInertia inertia = rigid_inertia(mass_properties(m, 2400));
  Random rng(3);
  std::vector<RigidState> bodies(static_cast<std::size_t>(state.range(0)));
  for (RigidState& s : bodies) {
    s.linear_velocity = rng.uniform_vec3(-1, 1);
    s.angular_velocity = rng.uniform_vec3(-10, 10);
  }
  const Vec3 gravity = Vec3(0, -9.81, 0) / inertia.inverse_mass;
  for (auto _ : state) {
    for (RigidState& s : bodies) {
      integrate_velocity(inertia, s, gravity, Vec3::Zero(), 1.0 / 240);
      integrate_position(inertia, s, 1.0 / 240);
    }
    benchmark::DoNotOptimize(bodies.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_RigidIntegrate)->Arg(1000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace shatter

BENCHMARK_MAIN();
