// Collision and rigid integration costs: the broad phase on the scenes the rigid-body targets name
// (1,000 pieces resting on a ground slab spread over 10 x 10 m, 100 bodies in a pile in a 1 m cube),
// the narrow phases (hull against hull and plane, tet mesh against tet mesh), convex hulls, the
// convex decomposition of bodies and shards, and the integration step of 1,000 tumbling bodies.
#include <benchmark/benchmark.h>

#include "bench_main.h"

#include <cmath>
#include <numbers>

#include "collide/collide_shapes.h"
#include "shatter/collide/broad_phase.h"
#include "shatter/collide/contact.h"
#include "shatter/collide/convex_decomposition.h"
#include "shatter/collide/convex_hull.h"
#include "shatter/collide/tet_contact.h"
#include "shatter/core/random.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/topology.h"
#include "shatter/rigid/integrate.h"

namespace shatter {
namespace {

using shapes::arc_mesh;
using shapes::random_ball;

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

// Braces draw left to right; a parenthesised call leaves the order of its arguments to the compiler.
// `n` pieces of 2-10 cm resting on the ground over 10 x 10 m.
std::vector<Aabb> resting(int n) {
  return scene(n, 6, 1, 0.01, 0.05,
               [](Random& rng, double half) { return Vec3{rng.uniform(-5, 5), half, rng.uniform(-5, 5)}; });
}

// `n` bodies of 10-20 cm packed in a 1 m cube above the ground.
std::vector<Aabb> pile(int n) {
  return scene(n, 3, 2, 0.05, 0.1, [](Random& rng, double) {
    return Vec3{rng.uniform(-0.5, 0.5), rng.uniform(0.0, 1.0), rng.uniform(-0.5, 0.5)};
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

void BM_ConvexHull(benchmark::State& state) {
  Random rng(99);
  const std::vector<Vec3> points = random_ball(rng, static_cast<int>(state.range(0)), 1.0);
  std::size_t vertices = 0;
  for (auto _ : state) {
    auto hull = build_convex_hull(points);
    if (!hull.ok()) {
      state.SkipWithError(hull.error().message.c_str());
      break;
    }
    vertices = hull->vertices.size();
  }
  state.counters["vertices"] = static_cast<double>(vertices);
}
BENCHMARK(BM_ConvexHull)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The hull of a box of half-extents `half` about the origin.
ConvexHull box_hull(const Vec3& half) {
  std::vector<Vec3> corners;
  for (int i = 0; i < 8; ++i)
    corners.emplace_back((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(),
                         (i & 4) ? half.z() : -half.z());
  return build_convex_hull(corners).value();
}

Transform at(const Vec3& translation, const Mat3& rotation = Mat3::Identity()) { return {rotation, translation}; }
Mat3 turn(double angle, const Vec3& axis) { return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix(); }

// Hull contacts: 0 a unit box resting on another (turned 0.3 rad), 1 two boxes apart with the
// separating-axis cache, 2 two 32-vertex hulls touching, 3 a box on a plane.
void BM_HullContact(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const ConvexHull box = box_hull(Vec3::Constant(0.5));
  Random rng(8);
  std::vector<Vec3> sphere_points;
  for (int i = 0; i < 32; ++i) sphere_points.push_back(rng.unit_vec3());
  const ConvexHull round = build_convex_hull(sphere_points).value();
  const double tumble_angle = rng.uniform(0, 2 * std::numbers::pi);
  const Mat3 tumble = Eigen::AngleAxisd(tumble_angle, rng.unit_vec3()).toRotationMatrix();
  SatCache cache;
  int points = 0;
  for (auto _ : state) {
    ContactManifold m;
    switch (which) {
      case 0:
        m = collide_hulls(box, at(Vec3::Zero()), box, at(Vec3(0.1, 1 - 1e-4, 0.05), turn(0.3, Vec3::UnitY())), 0.01);
        break;
      case 1: m = collide_hulls(box, at(Vec3::Zero()), box, at(Vec3(3, 0, 0)), 0.01, &cache); break;
      case 2: m = collide_hulls(round, at(Vec3::Zero()), round, at(Vec3(0, 1.9, 0), tumble), 0.01); break;
      default: m = collide_hull_plane(box, at(Vec3(0, 0.5, 0)), Plane{}, 0.01); break;
    }
    points = m.count;
    benchmark::DoNotOptimize(m);
  }
  state.counters["points"] = points;
}
BENCHMARK(BM_HullContact)->ArgName("case")->DenseRange(0, 3)->Unit(benchmark::kNanosecond);

// Tet-mesh contact: two ~1,000-tet jittered boxes in shallow contact (1 mm), one turned 0.2 rad;
// 5 mm speculative distance.
void BM_TetContact(benchmark::State& state) {
  auto shape = [](std::uint64_t seed) {
    const TetMesh m =
        make_box_mesh({.min = Vec3::Zero(), .max = Vec3(1, 0.5, 1), .cells = {7, 3, 8}, .jitter = 0.2, .seed = seed});
    return make_tet_contact_shape(m, compute_faces(m));
  };
  const TetContactShape a = shape(1), b = shape(2);
  const Transform ta = at(Vec3::Zero());
  const Transform tb = at(Vec3(0.3, 0.499, 0.2), turn(0.2, Vec3::UnitY()));
  std::vector<PointContact> out;
  for (auto _ : state) {
    out.clear();
    collide_tet_shapes(a, ta, b, tb, 5e-3, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["contacts"] = static_cast<double>(out.size());
}
BENCHMARK(BM_TetContact)->Unit(benchmark::kMicrosecond);

// Convex decomposition: 0 a jittered 3^3-cell shard, 1 a bent plate, 2 a 5,000-tet jittered box,
// 3 a thick half ring.
void BM_ConvexDecomposition(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const TetMesh mesh = which == 0   ? make_box_mesh({.cells = {3, 3, 3}, .jitter = 0.2})
                       : which == 1 ? arc_mesh({12, 2, 2}, 0.8 * std::numbers::pi, 0.1)
                       : which == 2
                           ? make_box_mesh({.cells = cells_for_tet_count(Vec3(1, 0.5, 2), 5000), .jitter = 0.2})
                           : arc_mesh({60, 5, 3}, std::numbers::pi, 0.25);
  const TetFaces faces = compute_faces(mesh);
  std::size_t pieces = 0;
  for (auto _ : state) {
    auto r = decompose_convex(mesh, faces);
    if (!r.ok()) {
      state.SkipWithError(r.error().message.c_str());
      break;
    }
    pieces = r->size();
  }
  state.counters["tets"] = mesh.num_tets();
  state.counters["pieces"] = static_cast<double>(pieces);
}
BENCHMARK(BM_ConvexDecomposition)->ArgName("case")->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace shatter

SHATTER_BENCHMARK_MAIN()
