// The batched contact solver: its colouring keeps a body out of two constraints of one colour, and
// four constraints solved side by side give exactly what the one-at-a-time solver gives in the same order,
// with either instruction set.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstdint>
#include <set>

#include "shatter/core/random.h"
#include "shatter/core/simd.h"
#include "shatter/rigid/contact_batches.h"

namespace shatter {
namespace {

// Random bodies (every fifth static, one kinematic) and prepared constraints between random pairs,
// some overlapping and some with a gap, 1 to 4 points each.
struct Problem {
  std::vector<SolverBody> bodies;
  std::vector<ContactConstraint> constraints;
};

Problem random_setup(int n_bodies, int n_constraints, std::uint64_t seed) {
  Random rng(seed);
  Problem s;
  for (int i = 0; i < n_bodies; ++i) {
    SolverBody b;
    b.position = rng.uniform_vec3(-2, 2);
    // Braces draw left to right (a parenthesised call leaves its arguments' order to the compiler).
    b.rotation = Quat(Eigen::AngleAxisd{rng.uniform(0, 3), rng.uniform_vec3(-1, 1).normalized()}).toRotationMatrix();
    const bool fixed = i % 5 == 0;
    const bool kinematic = i == 1;
    if (!fixed) {
      b.linear_velocity = rng.uniform_vec3(-1, 1);
      b.angular_velocity = rng.uniform_vec3(-2, 2);
    }
    if (!fixed && !kinematic) {
      b.inverse_mass = 1 / rng.uniform(0.2, 3);
      const Vec3 d = rng.uniform_vec3(0.5, 4);
      b.inverse_inertia = b.rotation * d.asDiagonal() * b.rotation.transpose();
    }
    s.bodies.push_back(b);
  }
  for (int k = 0; k < n_constraints; ++k) {
    ContactConstraint c;
    c.body_a = static_cast<Index>(rng.below(static_cast<std::uint64_t>(n_bodies)));
    do {
      c.body_b = static_cast<Index>(rng.below(static_cast<std::uint64_t>(n_bodies)));
    } while (c.body_b == c.body_a);
    const SolverBody& a = s.bodies[c.body_a];
    const SolverBody& b = s.bodies[c.body_b];
    c.normal = rng.uniform_vec3(-1, 1).normalized();
    c.friction = rng.uniform(0.2, 0.9);
    c.softness = make_softness(30, 10, 1.0 / 480);
    c.count = 1 + static_cast<int>(rng.below(4));
    for (int i = 0; i < c.count; ++i) {
      ContactPoint& p = c.points[i];
      p.position = 0.5 * (a.position + b.position) + rng.uniform_vec3(-0.1, 0.1);
      p.separation = rng.uniform(-0.01, 0.005);
      p.normal_impulse = rng.uniform(0, 0.5);  // warm start
    }
    c.friction_impulse = Eigen::Vector2d{rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1)};
    c.twist_impulse = rng.uniform(-0.01, 0.01);
    prepare_contact(c, s.bodies, 0.01);
    if (c.a_responds || c.b_responds) s.constraints.push_back(c);
  }
  return s;
}

std::vector<ContactConstraint*> pointers(std::vector<ContactConstraint>& cs) {
  std::vector<ContactConstraint*> out;
  out.reserve(cs.size());
  for (ContactConstraint& c : cs) out.push_back(&c);
  return out;
}

// Three substeps of approach measurement, warm start, biased pass and relax pass (without moving
// the bodies).
void run_batched(Problem& s) {
  ContactBatches batches;
  const auto list = pointers(s.constraints);
  batches.build(list, s.bodies);
  for (int sub = 0; sub < 3; ++sub) {
    batches.measure_approach(s.bodies);
    batches.warm_start(s.bodies);
    batches.solve(s.bodies, 480, true, 3);
    batches.solve(s.bodies, 480, false, 3);
  }
  batches.store();
}

TEST(ContactBatches, NoBodyTakesImpulsesFromTwoConstraintsOfOneColour) {
  Problem s = random_setup(60, 400, 3);
  ContactBatches batches;
  const auto list = pointers(s.constraints);
  batches.build(list, s.bodies);
  ASSERT_FALSE(batches.overflow().empty());  // 400 constraints on 48 moving bodies: some find no colour
  std::set<const ContactConstraint*> seen;
  std::vector<std::set<Index>> colour_bodies(ContactBatches::kColours);
  int last_colour = 0;
  for (std::size_t i = 0; i < batches.batches().size(); ++i) {
    const int colour = batches.batch_colours()[i];
    EXPECT_GE(colour, last_colour);  // colours in order
    last_colour = colour;
    for (const ContactConstraint* c : batches.batches()[i]) {
      if (c == nullptr) continue;
      EXPECT_TRUE(seen.insert(c).second);
      for (const auto& [body, responds] : {std::pair{c->body_a, c->a_responds}, std::pair{c->body_b, c->b_responds}})
        if (responds) {
          EXPECT_TRUE(colour_bodies[static_cast<std::size_t>(colour)].insert(body).second) << body;
        }
    }
  }
  for (const ContactConstraint* c : batches.overflow()) EXPECT_TRUE(seen.insert(c).second);
  EXPECT_EQ(seen.size(), s.constraints.size());
}

TEST(ContactBatches, FourAtATimeGiveWhatOneAtATimeGivesInTheSameOrder) {
  Problem batched = random_setup(60, 400, 5);
  Problem single = batched;
  run_batched(batched);
  // The same passes, one constraint at a time in the batches' order (recomputed on the copy).
  ContactBatches order;
  const auto list = pointers(single.constraints);
  order.build(list, single.bodies);
  std::vector<ContactConstraint*> sequence;
  for (const auto& lanes : order.batches())
    for (ContactConstraint* c : lanes)
      if (c != nullptr) sequence.push_back(c);
  for (ContactConstraint* c : order.overflow()) sequence.push_back(c);
  for (int sub = 0; sub < 3; ++sub) {
    for (ContactConstraint* c : sequence) measure_approach(*c, single.bodies);
    for (ContactConstraint* c : sequence) warm_start_contact(*c, single.bodies);
    for (ContactConstraint* c : sequence) solve_contact(*c, single.bodies, 480, true, 3);
    for (ContactConstraint* c : sequence) solve_contact(*c, single.bodies, 480, false, 3);
  }
  // Equal values (a lane may differ from one at a time only in the sign of a zero).
  for (std::size_t i = 0; i < batched.bodies.size(); ++i) {
    EXPECT_EQ(batched.bodies[i].linear_velocity, single.bodies[i].linear_velocity) << i;
    EXPECT_EQ(batched.bodies[i].angular_velocity, single.bodies[i].angular_velocity) << i;
  }
  for (std::size_t k = 0; k < batched.constraints.size(); ++k) {
    const ContactConstraint& b = batched.constraints[k];
    const ContactConstraint& o = single.constraints[k];
    EXPECT_EQ(b.twist_impulse, o.twist_impulse);
    EXPECT_EQ(b.total_friction_impulse, o.total_friction_impulse);
    for (int i = 0; i < b.count; ++i) {
      EXPECT_EQ(b.points[i].normal_impulse, o.points[i].normal_impulse);
      EXPECT_EQ(b.points[i].total_normal_impulse, o.points[i].total_normal_impulse);
      EXPECT_EQ(b.points[i].max_normal_impulse, o.points[i].max_normal_impulse);
      EXPECT_EQ(b.points[i].approach_speed, o.points[i].approach_speed);
    }
  }
  // Something happened: the velocities moved, and later substeps raised approach speeds above
  // what the constraints were prepared with.
  const Problem start = random_setup(60, 400, 5);
  int raised = 0;
  for (std::size_t k = 0; k < start.constraints.size(); ++k)
    for (int i = 0; i < start.constraints[k].count; ++i)
      raised += batched.constraints[k].points[i].approach_speed > start.constraints[k].points[i].approach_speed;
  EXPECT_GT(raised, 10);
  double moved = 0;
  for (std::size_t i = 0; i < start.bodies.size(); ++i)
    moved = std::max(moved, (batched.bodies[i].linear_velocity - start.bodies[i].linear_velocity).norm());
  EXPECT_GT(moved, 1e-3);
}

TEST(ContactBatches, BaselineAndAvx2GiveTheSameBits) {
  const SimdIsa saved = simd_isa();
  Problem baseline = random_setup(60, 400, 9);
  Problem avx2 = baseline;
  set_simd_isa(SimdIsa::baseline);
  run_batched(baseline);
  set_simd_isa(SimdIsa::avx2);  // baseline again on a CPU without AVX2
  run_batched(avx2);
  set_simd_isa(saved);
  auto bits = [](const Vec3& v) {
    return std::array{std::bit_cast<std::uint64_t>(v.x()), std::bit_cast<std::uint64_t>(v.y()),
                      std::bit_cast<std::uint64_t>(v.z())};
  };
  for (std::size_t i = 0; i < baseline.bodies.size(); ++i) {
    EXPECT_EQ(bits(baseline.bodies[i].linear_velocity), bits(avx2.bodies[i].linear_velocity)) << i;
    EXPECT_EQ(bits(baseline.bodies[i].angular_velocity), bits(avx2.bodies[i].angular_velocity)) << i;
  }
  for (std::size_t k = 0; k < baseline.constraints.size(); ++k)
    for (int i = 0; i < baseline.constraints[k].count; ++i) {
      EXPECT_EQ(baseline.constraints[k].points[i].total_normal_impulse,
                avx2.constraints[k].points[i].total_normal_impulse);
      EXPECT_EQ(std::bit_cast<std::uint64_t>(baseline.constraints[k].points[i].approach_speed),
                std::bit_cast<std::uint64_t>(avx2.constraints[k].points[i].approach_speed));
    }
}

}  // namespace
}  // namespace shatter
