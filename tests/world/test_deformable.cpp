// Deformable bodies in a world (BodyDef::deformable, docs/dynamics.md): free fall, resting on the
// ground and on static bodies, a rigid box carried by a soft slab, exact momentum exchange with
// rigid bodies, impulses on the nodes, and the state hash over thread counts and save/restore.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "shatter/core/parallel.h"
#include "world/world_scenes.h"

namespace shatter {
namespace {

using scenes::add_ground;
using scenes::box_model;

// A rubber-like solid: soft enough to squash visibly, stiff enough to carry a box.
Material rubber() {
  return {.name = "rubber",
          .youngs_modulus = 2e6,
          .poisson_ratio = 0.4,
          .density = 1100,
          .tensile_strength = kInfinity,
          .yield_stress = kInfinity,
          .fracture_toughness = kInfinity};
}

BodyDef deformable_def(const Vec3& position, const Vec3& velocity = Vec3::Zero(), double stiffness_damping = 0.01) {
  BodyDef def;
  def.rigid.position = position;
  def.rigid.linear_velocity = velocity;
  def.can_sleep = false;
  def.deformable = DeformableSettings{.stiffness_damping = stiffness_damping};
  return def;
}

double lowest_node(const World& w, BodyId id) {
  double y = kInfinity;
  for (const Vec3& x : w.node_positions(id)) y = std::min(y, x.y());
  return y;
}

double fastest_node(const World& w, BodyId id) {
  double s = 0;
  for (const Vec3& v : w.node_velocities(id)) s = std::max(s, v.norm());
  return s;
}

// Linear momentum of every dynamic body, N s (nodes for deformable ones).
Vec3 momentum(const World& w) {
  Vec3 p = Vec3::Zero();
  for (Index slot = 0; slot < w.body_count(); ++slot) {
    const BodyId id = w.body_id(slot);
    if (w.body_type(id) != BodyType::dynamic) continue;
    if (w.deformable(id)) {
      const std::vector<double>& m = w.model(id)->fem.node_mass;
      for (std::size_t i = 0; i < m.size(); ++i) p += m[i] * w.node_velocities(id)[i];
    } else {
      p += w.rigid_state(id).linear_velocity / w.inertia(id).inverse_mass;
    }
  }
  return p;
}

// Angular momentum about the origin, N m s.
Vec3 angular_momentum(const World& w) {
  Vec3 l = Vec3::Zero();
  for (Index slot = 0; slot < w.body_count(); ++slot) {
    const BodyId id = w.body_id(slot);
    if (w.body_type(id) != BodyType::dynamic) continue;
    if (w.deformable(id)) {
      const std::vector<double>& m = w.model(id)->fem.node_mass;
      for (std::size_t i = 0; i < m.size(); ++i) l += m[i] * w.node_positions(id)[i].cross(w.node_velocities(id)[i]);
    } else {
      const RigidState& r = w.rigid_state(id);
      const RigidInertia& in = w.inertia(id);
      const Mat3 R = r.orientation.toRotationMatrix();
      l += r.position.cross(r.linear_velocity / in.inverse_mass) +
           R * in.inertia_body * R.transpose() * r.angular_velocity;
    }
  }
  return l;
}

TEST(Deformable, FallsFreelyThenRestsSquashedOnTheGround) {
  World w;
  add_ground(w);
  const auto model = box_model(Vec3(0.1, 0.1, 0.1), rubber(), {3, 3, 3});
  const BodyId id = *w.add_body(model, deformable_def(Vec3(0, 0.6, 0)));
  EXPECT_TRUE(w.deformable(id));
  const double h = w.settings().time_step;
  // Implicit Euler in free fall: v_n = n h g, y_n = y_0 + h^2 g n (n + 1) / 2, node by node.
  for (int n = 1; n <= 15; ++n) {
    w.step();
    const double expect = 0.6 - 9.81 * h * h * n * (n + 1) / 2;
    EXPECT_NEAR(w.rigid_state(id).position.y(), expect, 1e-9) << "step " << n;
    EXPECT_NEAR(w.rigid_state(id).linear_velocity.y(), -9.81 * h * n, 1e-9);
  }
  double deepest = 0;
  for (int n = 0; n < 240; ++n) {
    w.step();
    deepest = std::min(deepest, lowest_node(w, id));
  }
  // At rest: the centre a little below the half height (its own weight squashes it), no node
  // through the ground, hardly moving, not turned.
  const RigidState& r = w.rigid_state(id);
  EXPECT_GT(r.position.y(), 0.095);
  EXPECT_LT(r.position.y(), 0.1);
  EXPECT_GT(deepest, -5e-3);  // not even while landing
  EXPECT_GT(lowest_node(w, id), -1e-4);
  EXPECT_LT(fastest_node(w, id), 1e-3);
  EXPECT_LT(std::abs(r.position.x()) + std::abs(r.position.z()), 1e-4);
  EXPECT_GT(std::abs(r.orientation.w()), 1 - 1e-6);
  // The model shows the squashed shape: the bottom face wider than the top.
  const BodyModel& m = *w.model(id);
  double top = 0, bottom = 0;
  for (const Vec3& p : m.mesh.positions) {
    if (p.y() > 0.09) top = std::max(top, std::abs(p.x()));
    if (p.y() < -0.09) bottom = std::max(bottom, std::abs(p.x()));
  }
  EXPECT_GT(bottom, top);
  // Its surface is where its nodes are.
  const BodySurface s = w.surface(id);
  for (std::size_t k = 0; k < s.positions.size(); ++k)
    EXPECT_LT((s.positions[k] - w.node_positions(id)[m.surface.vertex_node[k]]).norm(), 1e-12);
}

// In a world as on its own (docs/dynamics.md): kinetic + elastic + gravitational + penalty energy
// never grows, through the fall, the landing, the rebound and the settling.
TEST(Deformable, BouncesAndSettlesWithEnergyThatNeverGrows) {
  World w;
  add_ground(w, {.friction = 0.5});
  const auto model = box_model(Vec3(0.1, 0.1, 0.1), rubber(), {3, 3, 3});
  BodyDef def = deformable_def(Vec3(0, 0.4, 0), Vec3(0.5, 0, 0), 0.002);
  def.rigid.angular_velocity = Vec3(0, 0, 3);
  def.deformable->substeps = 4;
  def.surface.friction = 0.5;
  const BodyId id = *w.add_body(model, def);
  const DynamicSolver solver({.time_step = w.settings().time_step / 4, .gravity = w.settings().gravity});
  const DynamicObstacles ground{.planes = {{.normal = Vec3::UnitY(), .offset = 0, .friction = 0.5}}};
  auto energy = [&] {
    const std::span<const Vec3> x = w.node_positions(id), v = w.node_velocities(id);
    return solver.energy(model->fem, ground, {{x.begin(), x.end()}, {v.begin(), v.end()}});
  };
  double e = energy();
  const double e0 = e;
  double bounce = 0;
  bool landed = false;
  for (int n = 0; n < 240; ++n) {
    w.step();
    const double next = energy();
    EXPECT_LE(next, e + 1e-9 * std::abs(e0)) << "step " << n;
    e = next;
    landed = landed || lowest_node(w, id) < 1e-3;
    if (landed) bounce = std::max(bounce, lowest_node(w, id));
  }
  EXPECT_GT(bounce, 0.005);  // it bounced
  EXPECT_LT(fastest_node(w, id), 1e-2);
  EXPECT_GT(lowest_node(w, id), -1e-4);
}

TEST(Deformable, RestsOnAStaticBox) {
  World w;
  add_ground(w);
  BodyDef table;
  table.type = BodyType::static_body;
  table.rigid.position = Vec3(0, 0.25, 0);
  ASSERT_TRUE(w.add_box(Vec3(0.5, 0.25, 0.5), table));
  const BodyId id = *w.add_body(box_model(Vec3(0.1, 0.1, 0.1), rubber(), {2, 2, 2}), deformable_def(Vec3(0, 0.8, 0)));
  for (int n = 0; n < 240; ++n) w.step();
  EXPECT_NEAR(w.rigid_state(id).position.y(), 0.6, 5e-3);
  EXPECT_GT(lowest_node(w, id), 0.5 - 1e-4);
  EXPECT_LT(fastest_node(w, id), 1e-3);
}

TEST(Deformable, ExchangesMomentumExactlyWithARigidBody) {
  WorldSettings settings;
  settings.gravity = Vec3::Zero();
  settings.enable_impacts = false;
  World w(settings);
  const BodyId soft =
      *w.add_body(box_model(Vec3(0.1, 0.1, 0.1), rubber(), {2, 2, 2}), deformable_def(Vec3(0, 0, 0), Vec3(2, 0, 0), 0));
  BodyDef def;
  def.rigid.position = Vec3(0.3, 0.05, 0.02);  // off centre: the hit turns both
  def.can_sleep = false;
  const BodyId hard = *w.add_body(box_model(Vec3(0.08, 0.08, 0.08), rubber()), def);
  const Vec3 p0 = momentum(w);
  const Vec3 l0 = angular_momentum(w);
  bool touched = false;
  for (int n = 0; n < 60; ++n) {
    w.step();
    touched = touched || !w.contacts().empty();
    // Linear momentum stays that of the start, to the FEM step's Newton tolerance. Angular
    // momentum too, but for implicit Euler's own error: it conserves L only to first order in h
    // (docs/dynamics.md), while a deformed body spins.
    EXPECT_LT((momentum(w) - p0).norm(), 1e-7 * p0.norm()) << "step " << n;
    EXPECT_LT((angular_momentum(w) - l0).norm(), 1e-2 * p0.norm() * 0.3) << "step " << n;
  }
  EXPECT_TRUE(touched);
  EXPECT_GT(w.rigid_state(hard).linear_velocity.x(), 0.5);  // the rigid box was pushed on
  EXPECT_LT(w.rigid_state(soft).linear_velocity.x(), 1.5);  // and the soft one slowed
  EXPECT_GT(w.rigid_state(hard).angular_velocity.norm(), 1e-3);
  // Nothing gained energy.
  EXPECT_LE(w.kinetic_energy(), 0.5 * w.model(soft)->mass.mass * 4 * (1 + 1e-9));
}

TEST(Deformable, TwoDeformableBodiesExchangeMomentumExactly) {
  WorldSettings settings;
  settings.gravity = Vec3::Zero();
  World w(settings);
  const auto model = box_model(Vec3(0.1, 0.1, 0.1), rubber(), {2, 2, 2});
  const BodyId a = *w.add_body(model, deformable_def(Vec3(0, 0, 0), Vec3(1.5, 0, 0), 0));
  const BodyId b = *w.add_body(model, deformable_def(Vec3(0.35, 0.08, 0), Vec3(-0.5, 0, 0), 0));
  const Vec3 p0 = momentum(w);
  bool touched = false;
  for (int n = 0; n < 60; ++n) {
    w.step();
    touched = touched || !w.contacts().empty();
    EXPECT_LT((momentum(w) - p0).norm(), 1e-7 * p0.norm()) << "step " << n;
  }
  EXPECT_TRUE(touched);
  // No restitution: they go on together at the mean velocity, 0.5 m/s.
  EXPECT_NEAR(w.rigid_state(a).linear_velocity.x(), 0.5, 0.05);
  EXPECT_NEAR(w.rigid_state(b).linear_velocity.x(), 0.5, 0.05);
}

TEST(Deformable, AMovingKinematicBoxPushesItAlongTheGround) {
  World w;
  add_ground(w);
  BodyDef pusher;
  pusher.type = BodyType::kinematic;
  // Taller than the cube: a node level with the pusher's top would be pushed out upwards.
  pusher.rigid.position = Vec3(-0.3, 0.15, 0);
  pusher.rigid.linear_velocity = Vec3(0.5, 0, 0);
  const BodyId k = *w.add_box(Vec3(0.1, 0.15, 0.3), pusher);
  BodyDef def = deformable_def(Vec3(0, 0.1, 0));
  def.can_sleep = true;
  const BodyId soft = *w.add_body(box_model(Vec3(0.1, 0.1, 0.1), rubber(), {2, 2, 2}), def);
  for (int n = 0; n < 120; ++n) w.step();  // 2 s: the box moves 1 m
  const double front = w.rigid_state(k).position.x() + 0.1;
  // Pushed ahead of the box, never through it, and still on the ground.
  EXPECT_GT(w.rigid_state(soft).position.x(), 0.5);
  for (const Vec3& x : w.node_positions(soft)) EXPECT_GT(x.x(), front - 5e-3);
  EXPECT_GT(lowest_node(w, soft), -1e-3);
  EXPECT_TRUE(w.awake(soft));  // a moving kinematic body keeps what it pushes awake
}

// A rigid box dropped on a soft slab lying on the ground: the slab carries it.
World slab_world(BodyId& slab, BodyId& box) {
  World w;
  add_ground(w);
  BodyDef sd = deformable_def(Vec3(0, 0.05, 0));
  sd.can_sleep = true;
  slab = *w.add_body(box_model(Vec3(0.3, 0.05, 0.3), rubber(), {6, 2, 6}), sd);
  BodyDef bd;
  bd.rigid.position = Vec3(0.05, 0.3, 0);
  box = *w.add_body(box_model(Vec3(0.1, 0.1, 0.1), Material{}), bd);
  return w;
}

TEST(Deformable, CarriesARigidBoxDroppedOnIt) {
  BodyId slab, box;
  World w = slab_world(slab, box);
  double lowest_box = kInfinity;
  for (int n = 0; n < 180; ++n) {
    w.step();
    lowest_box = std::min(lowest_box, w.rigid_state(box).position.y());
  }
  // The box sits on the slab's top (0.1 m), pressing it in by at most a centimetre.
  EXPECT_GT(lowest_box, 0.2 - 0.01);
  EXPECT_NEAR(w.rigid_state(box).position.y(), 0.2, 0.01);
  EXPECT_LT(w.rigid_state(box).linear_velocity.norm(), 0.01);
  EXPECT_GT(lowest_node(w, slab), -1e-3);
  // The box's weight goes through the slab into the ground: the slab is pressed in under it.
  double under = kInfinity, aside = kInfinity;
  for (const Vec3& x : w.node_positions(slab)) {
    if (x.y() < 0.09) continue;
    if (std::abs(x.x()) < 0.03 && std::abs(x.z()) < 0.03) under = std::min(under, x.y());
    if (std::abs(x.x()) > 0.25) aside = std::min(aside, x.y());
  }
  EXPECT_LT(under, aside);
  // Then both fall asleep.
  for (int n = 0; n < 240; ++n) w.step();
  EXPECT_FALSE(w.awake(box));
  EXPECT_FALSE(w.awake(slab));
}

std::uint64_t slab_hash(int threads, int steps, int save_at) {
  const int saved = num_threads();
  set_num_threads(threads);
  BodyId slab, box;
  World w = slab_world(slab, box);
  WorldSnapshot snap;
  std::vector<Vec3> saved_shape;
  for (int n = 0; n < steps; ++n) {
    if (n == save_at) {
      snap = w.save();
      saved_shape = w.model(slab)->mesh.positions;
    }
    w.step();
  }
  if (save_at >= 0) {  // go back and run the rest again
    EXPECT_TRUE(w.restore(snap));
    EXPECT_EQ(w.model(slab)->mesh.positions, saved_shape);  // the snapshot kept its own shape
    for (int n = save_at; n < steps; ++n) w.step();
  }
  set_num_threads(saved);
  return w.state_hash();
}

TEST(Deformable, StateHashIsTheSameAcrossThreadCountsAndRestore) {
  const std::uint64_t h = slab_hash(1, 60, -1);
  EXPECT_EQ(slab_hash(1, 60, -1), h);
  EXPECT_EQ(slab_hash(2, 60, -1), h);
  EXPECT_EQ(slab_hash(2, 60, 25), h);
}

TEST(Deformable, ImpulsesChangeTheNodesMomentumExactly) {
  WorldSettings settings;
  settings.gravity = Vec3::Zero();
  World w(settings);
  const BodyId id = *w.add_body(box_model(Vec3(0.1, 0.1, 0.1), rubber(), {2, 2, 2}), deformable_def(Vec3(1, 2, 3)));
  const Vec3 p0 = momentum(w), l0 = angular_momentum(w);
  const Vec3 point(1.1, 2.03, 2.95), impulse(0.3, -0.2, 0.5);
  ASSERT_TRUE(w.apply_impulse(id, impulse, point));
  EXPECT_LT((momentum(w) - p0 - impulse).norm(), 1e-12);
  EXPECT_LT((angular_momentum(w) - l0 - point.cross(impulse)).norm(), 1e-12);
  // The pose's velocities follow the nodes'.
  EXPECT_LT((w.rigid_state(id).linear_velocity - impulse / w.model(id)->mass.mass).norm(), 1e-12);
  // Moved to a new pose, it keeps its shape and takes the rigid motion.
  RigidState r = w.rigid_state(id);
  r.position = Vec3(0, 1, 0);
  r.orientation = Quat(Eigen::AngleAxisd(0.5, Vec3::UnitZ()));
  r.linear_velocity = Vec3(0, 0, 1);
  r.angular_velocity = Vec3(0, 2, 0);
  ASSERT_TRUE(w.set_rigid_state(id, r));
  EXPECT_LT((w.rigid_state(id).position - r.position).norm(), 1e-12);
  EXPECT_LT(w.rigid_state(id).orientation.angularDistance(r.orientation), 1e-9);
  EXPECT_LT((w.rigid_state(id).angular_velocity - r.angular_velocity).norm(), 1e-9);
}

TEST(Deformable, BadSettingsGiveErrors) {
  World w;
  const auto model = box_model(Vec3(0.1, 0.1, 0.1), rubber());
  BodyDef def = deformable_def(Vec3::Zero());
  def.type = BodyType::kinematic;
  EXPECT_FALSE(w.add_body(model, def));
  def = deformable_def(Vec3::Zero());
  def.deformable->mass_damping = -1;
  EXPECT_FALSE(w.add_body(model, def));
  def = deformable_def(Vec3::Zero());
  def.deformable->contact_stiffness = std::nan("");
  EXPECT_FALSE(w.add_body(model, def));
  def = deformable_def(Vec3::Zero());
  def.deformable->max_newton_iterations = 0;
  EXPECT_FALSE(w.add_body(model, def));
  def = deformable_def(Vec3::Zero());
  def.type = BodyType::static_body;
  EXPECT_FALSE(w.add_box(Vec3(1, 1, 1), def));
  const BodyId id = *w.add_body(model, deformable_def(Vec3::Zero()));
  EXPECT_FALSE(w.slice(id, Vec3::Zero(), Vec3::UnitX()));
  EXPECT_EQ(w.body_count(), 1);
}

}  // namespace
}  // namespace shatter
