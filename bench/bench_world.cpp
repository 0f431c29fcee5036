// Cost of a world step on the rigid-body scenes of docs/performance.md, split into broad phase,
// narrow phase and solver, and the same scenes in Bullet (convex hulls of the same pieces, the same
// step, substeps and solver passes) when Bullet is installed:
//   resting: 1,000 box pieces of 50-200 tets resting on the ground, awake (sleeping off);
//   asleep:  the same after they fell asleep;
//   pyramid: Box2D's pyramid of 20 levels (210 cubes);
//   pile:    100 pieces dropped into a pile, the first 2 s.
#include <benchmark/benchmark.h>

#include "bench_main.h"

#include <chrono>

#include "world/world_scenes.h"

#ifdef SHATTER_HAVE_BULLET
#include <btBulletDynamicsCommon.h>
#endif

namespace shatter {
namespace {

// A scene as a list of bodies, so the same bodies go into shatter and Bullet.
struct SceneBody {
  std::shared_ptr<const BodyModel> model;
  RigidState rigid;
};

std::vector<SceneBody> resting_scene() {
  Random rng(3);
  std::vector<SceneBody> out;
  for (int i = 0; i < 1000; ++i) {
    const Vec3 extent = rng.uniform_vec3(0.04, 0.12);
    const int tets = 50 + static_cast<int>(rng.below(151));
    SceneBody b;
    b.model = scenes::box_model(0.5 * extent, {}, cells_for_tet_count(extent, tets));
    const int gx = i % 32, gz = i / 32;
    b.rigid.position = Vec3(0.2 * (gx - 16), 0.5 * extent.y(), 0.2 * (gz - 16));
    b.rigid.orientation = Quat(Eigen::AngleAxisd(rng.uniform(0, 3), Vec3::UnitY()));
    out.push_back(b);
  }
  return out;
}

std::vector<SceneBody> pyramid_scene() {
  std::vector<SceneBody> out;
  auto model = scenes::box_model(Vec3::Constant(0.25));
  const int levels = 20;
  for (int row = 0; row < levels; ++row)
    for (int k = 0; k < levels - row; ++k) {
      SceneBody b;
      b.model = model;
      b.rigid.position = Vec3((k - 0.5 * (levels - row - 1)) * 0.5, (row + 0.5) * 0.5, 0);
      out.push_back(b);
    }
  return out;
}

std::vector<SceneBody> pile_scene() {
  Random rng(9);
  std::vector<SceneBody> out;
  for (int i = 0; i < 100; ++i) {
    const Vec3 extent = rng.uniform_vec3(0.05, 0.2);
    SceneBody b;
    b.model = scenes::box_model(0.5 * extent, {}, cells_for_tet_count(extent, 100));
    // Braces draw left to right (a parenthesised call leaves its arguments' order to the compiler).
    b.rigid.position = Vec3{rng.uniform(-0.3, 0.3), 0.3 + 0.25 * (i / 10), rng.uniform(-0.3, 0.3)};
    b.rigid.orientation = Quat(Eigen::AngleAxisd{rng.uniform(0, 3), rng.uniform_vec3(-1, 1).normalized()});
    out.push_back(b);
  }
  return out;
}

std::vector<SceneBody> scene(int which) {
  return which == 2 ? pyramid_scene() : which == 3 ? pile_scene() : resting_scene();
}

std::unique_ptr<World> make_world(const std::vector<SceneBody>& bodies, bool sleep, bool reuse = true) {
  WorldSettings settings = scenes::settings(sleep);
  if (!reuse) settings.contact_reuse_distance = 0;
  auto w = std::make_unique<World>(settings);
  scenes::add_ground(*w);
  for (const SceneBody& b : bodies) {
    BodyDef def;
    def.rigid = b.rigid;
    (void)*w->add_body(b.model, def);
  }
  return w;
}

// which: 0 resting awake, 1 resting asleep, 2 pyramid, 3 pile (first 2 s from the drop); reuse:
// 0 turns the reuse of contacts off (WorldSettings::contact_reuse_distance).
void BM_WorldStep(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const auto bodies = scene(which);
  const bool sleep = which == 1;
  auto w = make_world(bodies, sleep, state.range(1) != 0);
  const int warm = which == 3 ? 0 : which == 1 ? 300 : 30;
  for (int i = 0; i < warm; ++i) w->step();
  const WorldSnapshot start = w->save();
  StepStats sum;
  std::int64_t steps = 0;
  for (auto _ : state) {
    if (which == 3 && w->step_count() >= 120) {
      state.PauseTiming();
      (void)w->restore(start);
      state.ResumeTiming();
    }
    w->step();
    const StepStats& s = w->stats();
    sum.broad_phase_ms += s.broad_phase_ms;
    sum.narrow_phase_ms += s.narrow_phase_ms;
    sum.solver_ms += s.solver_ms;
    sum.contact_points += s.contact_points;
    sum.awake_bodies += s.awake_bodies;
    sum.body_pairs += s.body_pairs;
    sum.reused_pairs += s.reused_pairs;
    ++steps;
  }
  const auto n = static_cast<double>(steps);
  state.counters["broad_ms"] = sum.broad_phase_ms / n;
  state.counters["narrow_ms"] = sum.narrow_phase_ms / n;
  state.counters["solver_ms"] = sum.solver_ms / n;
  state.counters["points"] = static_cast<double>(sum.contact_points) / n;
  state.counters["awake"] = static_cast<double>(sum.awake_bodies) / n;
  state.counters["reused"] =  // fraction of the pairs that kept their contacts
      sum.body_pairs > 0 ? static_cast<double>(sum.reused_pairs) / static_cast<double>(sum.body_pairs) : 0.0;
}
BENCHMARK(BM_WorldStep)
    ->ArgNames({"scene", "reuse"})
    ->ArgsProduct({{0, 1, 2, 3}, {1}})
    ->Args({0, 0})
    ->Args({2, 0})
    ->Args({3, 0})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

#ifdef SHATTER_HAVE_BULLET
// The same scene in Bullet: each body a btConvexHullShape of its piece hulls' vertices (the box
// pieces are one hull each), a static plane, the world's substeps (8 of 1/480 s per 1/60 s step),
// and 2 solver iterations per substep (shatter solves once and relaxes once per substep).
struct BulletWorld {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> motions;
  std::vector<std::unique_ptr<btRigidBody>> bodies;

  BulletWorld(const std::vector<SceneBody>& scene_bodies, bool sleep) {
    world.setGravity(btVector3(0, -9.81f, 0));
    world.getSolverInfo().m_numIterations = 2;
    add(std::make_unique<btStaticPlaneShape>(btVector3(0, 1, 0), 0), 0, btTransform::getIdentity(), sleep);
    World probe;  // to get the same convex pieces shatter builds
    for (const SceneBody& b : scene_bodies) {
      const BodyId id = *probe.add_body(b.model, {});
      auto hull = std::make_unique<btConvexHullShape>();
      for (const ConvexHull& piece : probe.pieces(id))
        for (const Vec3& v : piece.vertices)
          hull->addPoint(
              btVector3(static_cast<btScalar>(v.x()), static_cast<btScalar>(v.y()), static_cast<btScalar>(v.z())),
              false);
      hull->recalcLocalAabb();
      hull->setMargin(0.001f);
      btTransform t;
      t.setOrigin(btVector3(static_cast<btScalar>(b.rigid.position.x()), static_cast<btScalar>(b.rigid.position.y()),
                            static_cast<btScalar>(b.rigid.position.z())));
      const Quat& q = b.rigid.orientation;
      t.setRotation(btQuaternion(static_cast<btScalar>(q.x()), static_cast<btScalar>(q.y()),
                                 static_cast<btScalar>(q.z()), static_cast<btScalar>(q.w())));
      add(std::move(hull), static_cast<btScalar>(b.model->mass.mass), t, sleep);
    }
  }
  void add(std::unique_ptr<btCollisionShape> shape, btScalar mass, const btTransform& t, bool sleep) {
    btVector3 inertia(0, 0, 0);
    if (mass > 0) shape->calculateLocalInertia(mass, inertia);
    motions.push_back(std::make_unique<btDefaultMotionState>(t));
    btRigidBody::btRigidBodyConstructionInfo info(mass, motions.back().get(), shape.get(), inertia);
    info.m_friction = 0.6f;
    bodies.push_back(std::make_unique<btRigidBody>(info));
    if (!sleep) bodies.back()->setActivationState(DISABLE_DEACTIVATION);
    world.addRigidBody(bodies.back().get());
    shapes.push_back(std::move(shape));
  }
  ~BulletWorld() {
    for (auto& b : bodies) world.removeRigidBody(b.get());
  }
  void step() {
    const int substeps = WorldSettings{}.substeps;
    world.stepSimulation(1.0f / 60.0f, substeps, 1.0f / (60.0f * static_cast<float>(substeps)));
  }
};

void BM_BulletStep(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const auto bodies = scene(which);
  auto w = std::make_unique<BulletWorld>(bodies, which == 1);
  const int warm = which == 3 ? 0 : which == 1 ? 300 : 30;
  for (int i = 0; i < warm; ++i) w->step();
  int steps = 0;
  for (auto _ : state) {
    if (which == 3 && steps == 120) {
      state.PauseTiming();
      w = std::make_unique<BulletWorld>(bodies, false);
      steps = 0;
      state.ResumeTiming();
    }
    w->step();
    ++steps;
  }
}
BENCHMARK(BM_BulletStep)->ArgName("scene")->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->MinTime(2.0);
#endif

}  // namespace
}  // namespace shatter

SHATTER_BENCHMARK_MAIN()
