// One contact as the solver prepares and follows it: the anchors on each body's own surface, and
// the gap the passes track through the step.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "shatter/core/random.h"
#include "shatter/rigid/contact_solver.h"

namespace shatter {
namespace {

// A static body A and a dynamic body B at random poses, one point between them with `separation`
// along a random normal.
struct Pair {
  std::vector<SolverBody> bodies;
  ContactConstraint c;
};

Pair random_pair(Random& rng, double separation) {
  Pair s;
  s.bodies.resize(2);
  for (SolverBody& b : s.bodies) {
    b.position = rng.uniform_vec3(-1, 1);
    // Braces draw left to right (a parenthesised call leaves its arguments' order to the compiler).
    b.rotation = Quat(Eigen::AngleAxisd{rng.uniform(0, 3), rng.uniform_vec3(-1, 1).normalized()}).toRotationMatrix();
  }
  SolverBody& b = s.bodies[1];
  b.inverse_mass = 1 / rng.uniform(0.2, 3);
  const Vec3 d = rng.uniform_vec3(0.5, 4);
  b.inverse_inertia = b.rotation * d.asDiagonal() * b.rotation.transpose();
  s.c.body_a = 0;
  s.c.body_b = 1;
  s.c.normal = rng.uniform_vec3(-1, 1).normalized();
  s.c.friction = 0;  // the normal row alone (friction turns B too)
  s.c.count = 1;
  s.c.points[0].position = 0.5 * (s.bodies[0].position + s.bodies[1].position) + rng.uniform_vec3(-0.1, 0.1);
  s.c.points[0].separation = separation;
  return s;
}

// The gap as the passes track it: n . (on_B - on_A) from the surface anchors at the bodies' current
// poses, plus the adjusted separation.
double tracked_gap(const ContactConstraint& c, std::span<const SolverBody> bodies) {
  const ContactPoint& p = c.points[0];
  const SolverBody& a = bodies[c.body_a];
  const SolverBody& b = bodies[c.body_b];
  return p.adjusted_separation + c.normal.dot(b.position + b.rotation * p.local_anchor_b) -
         c.normal.dot(a.position + a.rotation * p.local_anchor_a);
}

TEST(ContactSolver, AnchorsLieOnEachSurfaceAndTheGapFollowsThem) {
  Random rng(20261206);
  for (int trial = 0; trial < 20; ++trial) {
    const double separation = trial % 2 == 0 ? rng.uniform(0.05, 0.5) : -rng.uniform(0, 0.01);
    Pair s = random_pair(rng, separation);
    prepare_contact(s.c, s.bodies, 0.004);
    const ContactPoint& p = s.c.points[0];
    const SolverBody& a = s.bodies[0];
    SolverBody& b = s.bodies[1];
    // The rows' lever arms at the manifold point; the tracked points on each surface.
    EXPECT_LT((p.anchor_a - (p.position - a.position)).norm(), 1e-15);
    EXPECT_LT((p.anchor_b - (p.position - b.position)).norm(), 1e-15);
    const Vec3 on_a = p.position - 0.5 * separation * s.c.normal;
    const Vec3 on_b = p.position + 0.5 * separation * s.c.normal;
    EXPECT_LT((a.position + a.rotation * p.local_anchor_a - on_a).norm(), 1e-14);
    EXPECT_LT((b.position + b.rotation * p.local_anchor_b - on_b).norm(), 1e-14);
    EXPECT_NEAR(tracked_gap(s.c, s.bodies), separation, 1e-15);
    EXPECT_LT(std::abs(p.adjusted_separation), 1e-14);

    // B turns a third of a turn about its own surface point: the gap stays (the manifold point,
    // half the gap off B, would have swung by up to half the gap).
    const Mat3 turn = Quat(Eigen::AngleAxisd{2.1, rng.uniform_vec3(-1, 1).normalized()}).toRotationMatrix();
    b.position = on_b + turn * (b.position - on_b);
    b.rotation = turn * b.rotation;
    EXPECT_NEAR(tracked_gap(s.c, s.bodies), separation, 1e-14);

    // The solver closes a gap at most within the substep: B rushing at A leaves at the speed that
    // just closes the tracked gap.
    if (separation > 0) {
      const double inverse_h = 480;
      b.linear_velocity = -(2 * separation * inverse_h + 50) * s.c.normal;
      b.angular_velocity = rng.uniform_vec3(-20, 20);
      solve_contact(s.c, s.bodies, inverse_h, true, 3);
      const double vn = s.c.normal.dot(b.linear_velocity) + p.rn_b.dot(b.angular_velocity);
      EXPECT_NEAR(vn, -separation * inverse_h, 1e-9 * separation * inverse_h) << "trial " << trial;
    }
  }
}

}  // namespace
}  // namespace shatter
