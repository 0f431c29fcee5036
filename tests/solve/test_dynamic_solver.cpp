// Full FEM dynamics by implicit Euler (docs/dynamics.md): free fall exactly as eq. 20 says, linear
// momentum kept, energy that never grows, a soft cube that bounces and settles on the ground or on
// a box (pushing it with its weight), the same bits on any thread count, bad input refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/solve/dynamic_solver.h"
#include "solve/solve_test_util.h"

namespace shatter {
namespace {

// A soft 0.2 m cube (E = 0.1 MPa, rubber-like foam) at rest, its lowest corner `height` above y = 0
// after turning it about x and z.
struct Cube {
  FemModel model;
  DynamicState state;
};
Cube soft_cube(double height, double tilt) {
  TetMesh mesh = test::box(Vec3(0.2, 0.2, 0.2), {4, 4, 4});
  const Mat3 r = (Eigen::AngleAxisd(tilt, Vec3::UnitX()) * Eigen::AngleAxisd(0.7 * tilt, Vec3::UnitZ())).matrix();
  double lowest = INFINITY;
  for (Vec3& x : mesh.positions) x = r * (x - Vec3(0.1, 0.1, 0.1)), lowest = std::min(lowest, x.y());
  for (Vec3& x : mesh.positions) x.y() += height - lowest;
  Material material = test::test_material(1e5, 0.3);
  material.density = 1000;
  Cube c{make_fem_model(mesh, material, ModelKind::stvk), {}};
  c.state.x = mesh.positions;
  c.state.v.assign(mesh.positions.size(), Vec3::Zero());
  return c;
}

Vec3 momentum(const FemModel& model, const DynamicState& s) {
  Vec3 p = Vec3::Zero();
  for (Index i = 0; i < model.num_nodes; ++i) p += model.node_mass[i] * s.v[i];
  return p;
}

TEST(DynamicSolver, FreeFallIsImplicitEulerExactly) {
  Cube c = soft_cube(1.0, 0.3);
  for (Vec3& v : c.state.v) v = Vec3(0.5, 2.0, 0);
  const std::vector<Vec3> x0 = c.state.x;
  DynamicSolver solver;
  const double h = solver.options().time_step;
  const Vec3 g = solver.options().gravity;
  Vec3 shift = Vec3::Zero();
  for (int k = 1; k <= 30; ++k) {
    auto r = solver.step(c.model, {}, c.state);
    ASSERT_TRUE(r.ok()) << r.error().to_string();
    ASSERT_TRUE(r->converged) << r->message;
    shift += h * (Vec3(0.5, 2.0, 0) + k * h * g);  // v_k = v_0 + k h g, x_k = x_{k-1} + h v_k (eq. 20)
  }
  for (Index i = 0; i < c.model.num_nodes; ++i) {
    EXPECT_LT((c.state.v[i] - (Vec3(0.5, 2.0, 0) + 30 * h * g)).norm(), 1e-9);
    EXPECT_LT((c.state.x[i] - (x0[i] + shift)).norm(), 1e-10);
  }
}

TEST(DynamicSolver, KeepsMomentumAndNeverGainsEnergy) {
  // No gravity, no ground: a cube thrown spinning with a random velocity field wobbles; internal
  // forces sum to zero, so its momentum stays; implicit Euler only takes energy away.
  Cube c = soft_cube(1.0, 0.0);
  Random rng(5);
  for (Index i = 0; i < c.model.num_nodes; ++i)
    c.state.v[i] =
        Vec3(1, 0, 0) + Vec3(0, 0, 3).cross(c.state.x[i] - Vec3(0.1, 1.1, 0.1)) + 0.3 * rng.uniform_vec3(-1, 1);
  DynamicSolver solver({.gravity = Vec3::Zero()});
  const Vec3 p0 = momentum(c.model, c.state);
  double e = solver.energy(c.model, {}, c.state);
  const double e0 = e;
  for (int k = 0; k < 120; ++k) {
    auto r = solver.step(c.model, {}, c.state);
    ASSERT_TRUE(r.ok());
    ASSERT_TRUE(r->converged) << "step " << k << ": " << r->message;
    const double next = solver.energy(c.model, {}, c.state);
    EXPECT_LE(next, e + 1e-12 * e0) << "step " << k;
    e = next;
    EXPECT_LT((momentum(c.model, c.state) - p0).norm(), 1e-9 * p0.norm()) << "step " << k;
  }
  EXPECT_LT(e, e0);
  std::printf("energy after 2 s: %.4f of the initial\n", e / e0);
}

struct Drop {
  std::vector<double> height;  // lowest node per step, m
  std::vector<double> vy;      // mean vertical velocity per step, m/s
  std::vector<double> energy;  // J
  DynamicState final;
  int max_iterations = 0;
  DynamicStepReport last;  // one more step after `final`
  Vec3 centre;             // centre of mass after it, m
  double mass = 0;         // kg
};

// The ground as a plane, or as the top of a static 2 x 0.5 x 2 m box.
DynamicObstacles ground(bool as_box) {
  if (!as_box) return {.planes = {ContactPlane{.normal = Vec3::UnitY(), .offset = 0, .friction = 0.5}}};
  ContactConvex box{.faces = {}, .friction = 0.5};
  for (int axis = 0; axis < 3; ++axis)
    for (const double sign : {1.0, -1.0}) {
      const Vec3 n = sign * Vec3::Unit(axis);
      box.faces.push_back({n, axis == 1 ? (sign > 0 ? 0.0 : 0.5) : 1.0});
    }
  return {.convexes = {box}};
}

Drop drop(const DynamicSolverOptions& options, int steps, bool on_box = false) {
  Cube c = soft_cube(0.3, 0.4);
  DynamicSolver solver(options);
  const DynamicObstacles planes = ground(on_box);
  Drop d;
  d.energy.push_back(solver.energy(c.model, planes, c.state));
  for (int k = 0; k < steps; ++k) {
    auto r = solver.step(c.model, planes, c.state);
    EXPECT_TRUE(r.ok());
    EXPECT_TRUE(r->converged) << "step " << k << ": " << r->message;
    d.max_iterations = std::max(d.max_iterations, r->newton_iterations);
    double lowest = INFINITY;
    for (const Vec3& x : c.state.x) lowest = std::min(lowest, x.y());
    d.height.push_back(lowest);
    double mass = 0;
    for (const double m : c.model.node_mass) mass += m;
    d.vy.push_back(momentum(c.model, c.state).y() / mass);
    d.energy.push_back(solver.energy(c.model, planes, c.state));
  }
  d.final = c.state;
  d.last = solver.step(c.model, planes, c.state).value();
  double mass = 0;
  d.centre = Vec3::Zero();
  for (Index i = 0; i < c.model.num_nodes; ++i)
    mass += c.model.node_mass[i], d.centre += c.model.node_mass[i] * c.state.x[i];
  d.centre /= mass;
  d.mass = mass;
  return d;
}

TEST(DynamicSolver, SoftCubeBouncesAndSettles) {
  const Drop d = drop({}, 240);
  // Energy never grows (kinetic + elastic + gravity + the contact penalty's).
  for (std::size_t k = 1; k < d.energy.size(); ++k)
    EXPECT_LE(d.energy[k], d.energy[k - 1] + 1e-9 * std::abs(d.energy[0])) << "step " << k;
  // It lands (moving down), bounces (moving up after touching), and comes to rest on the ground.
  std::size_t touch = 0;
  while (touch < d.height.size() && d.height[touch] > 0) ++touch;
  ASSERT_LT(touch, d.height.size());
  EXPECT_LT(d.vy[touch], -1.0);
  double up = 0;
  for (std::size_t k = touch; k < d.vy.size(); ++k) up = std::max(up, d.vy[k]);
  EXPECT_GT(up, 0.1);
  double speed = 0, lowest = INFINITY;
  for (const Vec3& v : d.final.v) speed = std::max(speed, v.norm());
  for (const Vec3& x : d.final.x) lowest = std::min(lowest, x.y());
  EXPECT_LT(speed, 1e-3);
  EXPECT_LT(-lowest, 1e-4);  // the penalty's sinking under the cube's own weight
  std::printf(
      "touch at step %zu (%.2f m/s down), rebound %.2f m/s up, at rest: %.2g m/s, %.2g m deep, <= %d Newton "
      "iterations\n",
      touch, -d.vy[touch], up, speed, -lowest, d.max_iterations);
}

// A convex obstacle acts as the plane of its nearest face: the cube falling on the top of a box
// moves exactly as on the ground plane. At rest, it pushes the box with its weight, under its
// centre.
TEST(DynamicSolver, ConvexObstaclesActLikeTheirNearestFace) {
  const Drop on_plane = drop({}, 240);
  const Drop on_box = drop({}, 240, true);
  EXPECT_EQ(on_plane.final.x, on_box.final.x);
  EXPECT_EQ(on_plane.final.v, on_box.final.v);
  ASSERT_EQ(on_box.last.convex_impulse.size(), 1u);
  const DynamicSolverOptions o;
  const Vec3 weight = on_box.mass * o.gravity * o.time_step;  // N s over one step
  const Vec3 impulse = on_box.last.convex_impulse[0];
  EXPECT_LT((impulse - weight).norm(), 1e-3 * weight.norm());
  const Vec3 about_centre = on_box.last.convex_moment[0] - on_box.centre.cross(impulse);
  EXPECT_LT(about_centre.norm(), 1e-3 * weight.norm() * 0.2);
  EXPECT_TRUE(on_plane.last.convex_impulse.empty());
}

TEST(DynamicSolver, RayleighDampingTakesEnergyAway) {
  const Drop plain = drop({}, 60);
  const Drop damped = drop({.mass_damping = 2.0, .stiffness_damping = 0.01}, 60);
  EXPECT_LT(damped.energy.back(), plain.energy.back());
  for (std::size_t k = 1; k < damped.energy.size(); ++k)
    EXPECT_LE(damped.energy[k], damped.energy[k - 1] + 1e-9 * std::abs(damped.energy[0])) << "step " << k;
}

TEST(DynamicSolver, SameBitsOnAnyThreadCount) {
  const int threads = num_threads();
  set_num_threads(1);
  const Drop one = drop({}, 40);
  set_num_threads(2);
  const Drop two = drop({}, 40);
  set_num_threads(threads);
  EXPECT_EQ(one.final.x, two.final.x);
  EXPECT_EQ(one.final.v, two.final.v);
}

// One solver stepping two models with the same nodes but other tets (the pattern is rebuilt):
// the same bits as a solver of its own.
TEST(DynamicSolver, ANewModelGetsItsOwnPattern) {
  const Cube six = soft_cube(0.3, 0.4);
  TetMesh five_mesh =
      make_box_mesh({.max = Vec3(0.2, 0.2, 0.2), .cells = {4, 4, 4}, .pattern = BoxMeshDef::Pattern::five});
  ASSERT_EQ(five_mesh.positions.size(), six.state.x.size());
  ASSERT_NE(five_mesh.tets, six.model.tets);
  for (std::size_t i = 0; i < five_mesh.positions.size(); ++i) five_mesh.positions[i] = six.state.x[i];
  const FemModel five = make_fem_model(five_mesh, six.model.material, ModelKind::stvk);
  const DynamicObstacles planes = ground(false);
  DynamicSolver shared, own;
  DynamicState a = six.state;
  for (int k = 0; k < 20; ++k) ASSERT_TRUE(shared.step(six.model, planes, a).ok());
  DynamicState c = a;
  for (int k = 0; k < 20; ++k) {
    ASSERT_TRUE(shared.step(five, planes, a).ok());
    ASSERT_TRUE(own.step(five, planes, c).ok());
  }
  EXPECT_EQ(a.x, c.x);
}

TEST(DynamicSolver, BadInputIsAnErrorAndLeavesTheState) {
  Cube c = soft_cube(0.3, 0.0);
  const DynamicState before = c.state;
  const auto fails = [&](const DynamicSolverOptions& o, const DynamicObstacles& planes, DynamicState s,
                         const std::string& word) {
    DynamicSolver solver(o);
    const DynamicState kept = s;
    auto r = solver.step(c.model, planes, s);
    ASSERT_FALSE(r.ok()) << word;
    EXPECT_NE(r.error().message.find(word), std::string::npos) << r.error().message;
    EXPECT_EQ(std::memcmp(s.x.data(), kept.x.data(), s.x.size() * sizeof(Vec3)), 0);  // bitwise (NaN too)
  };
  DynamicState short_state = before;
  short_state.v.pop_back();
  fails({}, {}, short_state, "velocities");
  DynamicState nan_state = before;
  nan_state.x[3].y() = NAN;
  fails({}, {}, nan_state, "node 3");
  fails({.time_step = 0}, {}, before, "time_step");
  fails({.time_step = INFINITY}, {}, before, "time_step");
  fails({.mass_damping = -1}, {}, before, "damping");
  fails({.contact_stiffness = 0}, {}, before, "contact_stiffness");
  fails({}, {.planes = {ContactPlane{.normal = Vec3(0, 2, 0)}}}, before, "plane 0");
  fails({}, {.planes = {ContactPlane{.friction = -0.1}}}, before, "plane 0");
  DynamicObstacles box = ground(true);
  box.convexes[0].faces.resize(3);
  fails({}, box, before, "convex 0");
  box = ground(true);
  box.convexes[0].faces[2].offset = NAN;
  fails({}, box, before, "convex 0");
}

}  // namespace
}  // namespace shatter
