// Rigid-body integration: free flight, torque-free tumbling (angular momentum kept, energy never
// gained, the intermediate-axis flip), fast spins, kicks by torque, four bodies at a time.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "shatter/core/random.h"
#include "shatter/core/simd.h"
#include "shatter/mesh/generate.h"
#include "shatter/rigid/integrate.h"

namespace shatter {
namespace {

// An asymmetric brick (principal moments in ratio about 1 : 2.4 : 2.9) meshed with tets.
RigidInertia brick() {
  const TetMesh m =
      make_box_mesh({.min = Vec3(-0.15, -0.05, -0.025), .max = Vec3(0.15, 0.05, 0.025), .cells = {6, 2, 1}});
  return rigid_inertia(mass_properties(m, 2400));
}

// The bit patterns of a vector or matrix's entries.
template <class Derived>
std::vector<std::uint64_t> bits(const Eigen::MatrixBase<Derived>& m) {
  std::vector<std::uint64_t> out;
  out.reserve(static_cast<std::size_t>(m.size()));
  for (Eigen::Index i = 0; i < m.size(); ++i) out.push_back(std::bit_cast<std::uint64_t>(m(i)));
  return out;
}

TEST(RigidIntegrate, FreeFlightIsTheDiscreteParabola) {
  const RigidInertia in = brick();
  RigidState s;
  s.position = Vec3(0, 1, 0);
  s.linear_velocity = Vec3(2, 3, -1);
  const Vec3 g(0, -9.81, 0);
  const double dt = 1.0 / 60;
  const double m = 1.0 / in.inverse_mass;
  const int n = 120;
  for (int i = 0; i < n; ++i) {
    integrate_velocity(in, s, m * g, Vec3::Zero(), dt);
    integrate_position(in, s, dt);
  }
  // Symplectic Euler with constant g: x_n = x0 + v0 t + g t^2 / 2 + g dt t / 2, v_n = v0 + g t.
  const double t = n * dt;
  const Vec3 x = Vec3(0, 1, 0) + Vec3(2, 3, -1) * t + 0.5 * g * t * t + 0.5 * g * dt * t;
  EXPECT_LT((s.position - x).norm(), 1e-12);
  EXPECT_LT((s.linear_velocity - (Vec3(2, 3, -1) + g * t)).norm(), 1e-12);
  EXPECT_EQ(s.orientation.coeffs(), Quat::Identity().coeffs());
}

TEST(RigidIntegrate, TumblingKeepsAngularMomentumNeverGainsEnergyAndFlips) {
  const RigidInertia in = brick();
  // Principal axes of the brick are x, y, z; y is the intermediate one (moment 2.4 of 1 : 2.4 : 2.9).
  const Mat3& I = in.inertia_body;
  ASSERT_LT(I(0, 0), I(1, 1));
  ASSERT_LT(I(1, 1), I(2, 2));
  RigidState s;
  s.orientation = Quat(Eigen::AngleAxisd(0.4, Vec3(1, 1, 0).normalized()));
  // Spin mostly about the intermediate axis, slightly perturbed.
  s.angular_velocity = s.orientation * Vec3(0.01, 6.0, 0.01);
  const Vec3 l0 = angular_momentum(in, s);
  const double e0 = kinetic_energy(in, s);
  const double dt = 1.0 / 60;
  int flips = 0;
  double previous = 6.0;
  double max_l_error = 0, max_energy_gain = 0;
  for (int i = 0; i < 600; ++i) {  // 10 s
    integrate_position(in, s, dt);
    max_l_error = std::max(max_l_error, (angular_momentum(in, s) - l0).norm() / l0.norm());
    max_energy_gain = std::max(max_energy_gain, (kinetic_energy(in, s) - e0) / e0);
    const double wy = (s.orientation.conjugate() * s.angular_velocity).y();
    if (wy * previous < 0) ++flips;
    previous = wy;
    ASSERT_NEAR(s.orientation.norm(), 1.0, 1e-15);
  }
  EXPECT_LT(max_l_error, 1e-6);
  EXPECT_LT(max_energy_gain, 1e-12);
  EXPECT_GE(flips, 2) << "no intermediate-axis flip in 10 s";
}

TEST(RigidIntegrate, SpinAboutAPrincipalAxisIsSteady) {
  const RigidInertia in = brick();
  RigidState s;
  s.angular_velocity = Vec3(0, 0, 3);  // major axis
  for (int i = 0; i < 600; ++i) integrate_position(in, s, 1.0 / 60);
  EXPECT_LT((s.angular_velocity - Vec3(0, 0, 3)).norm(), 1e-12);
  // Cayley rotation: the angle per step is 2 atan(dt w / 2), within (dt w)^3 / 12 of dt w.
  const double angle = 600 * 2 * std::atan(0.5 * 3.0 / 60);
  const Quat expected(Eigen::AngleAxisd(angle, Vec3::UnitZ()));
  EXPECT_LT(s.orientation.angularDistance(expected), 1e-9);
}

TEST(RigidIntegrate, FastSpinStaysBounded) {
  const RigidInertia in = brick();
  RigidState s;
  s.angular_velocity = Vec3(40, 300, 25);  // dt w ~ 5 rad per step
  const Vec3 l0 = angular_momentum(in, s);
  const double e0 = kinetic_energy(in, s);
  for (int i = 0; i < 120; ++i) integrate_position(in, s, 1.0 / 60);
  EXPECT_LT((angular_momentum(in, s) - l0).norm(), 1e-9 * l0.norm());
  EXPECT_LE(kinetic_energy(in, s), e0 * (1 + 1e-12));
  EXPECT_TRUE(s.angular_velocity.allFinite());
}

TEST(RigidIntegrate, TorqueKickChangesAngularMomentumByTheImpulse) {
  const RigidInertia in = brick();
  RigidState s;
  s.orientation = Quat(Eigen::AngleAxisd(1.0, Vec3(0, 1, 1).normalized()));
  s.angular_velocity = Vec3(1, -2, 0.5);
  const Vec3 l0 = angular_momentum(in, s);
  const Vec3 torque(0.3, 0.1, -0.2);
  integrate_velocity(in, s, Vec3::Zero(), torque, 0.01);
  EXPECT_LT((angular_momentum(in, s) - (l0 + 0.01 * torque)).norm(), 1e-14);
}

TEST(RigidIntegrate, KinematicBodyTurnsAtItsAngularVelocity) {
  RigidInertia kinematic;  // infinite mass
  RigidState s;
  s.angular_velocity = Vec3(0, 2, 0);
  s.linear_velocity = Vec3(1, 0, 0);
  integrate_velocity(kinematic, s, Vec3(0, -100, 0), Vec3(5, 5, 5), 0.1);  // no effect
  EXPECT_EQ(s.linear_velocity, Vec3(1, 0, 0));
  for (int i = 0; i < 10; ++i) integrate_position(kinematic, s, 0.1);
  EXPECT_LT(s.orientation.angularDistance(Quat(Eigen::AngleAxisd(2.0, Vec3::UnitY()))), 1e-12);
  EXPECT_LT((s.position - Vec3(1, 0, 0)).norm(), 1e-15);
}

}  // namespace
}  // namespace shatter

namespace shatter {
namespace {

// Four at a time gives the bits of one at a time, with either instruction set: groups of 1 to 4
// bodies, spinning slowly (one iteration), fast (many, some splitting the step), not at all, or
// kinematic.
TEST(RigidIntegrate, FourAtATimeGiveTheBitsOfOneAtATime) {
  const SimdIsa saved = simd_isa();
  Random rng(21);
  const RigidInertia dynamic = brick();
  const RigidInertia kinematic;
  for (const SimdIsa isa : {SimdIsa::baseline, SimdIsa::avx2}) {
    set_simd_isa(isa);
    for (int trial = 0; trial < 200; ++trial) {
      const auto count = static_cast<std::size_t>(1 + rng.below(4));
      std::array<RigidState, 4> one{}, four{};
      std::array<const RigidInertia*, 4> inertia{};
      for (std::size_t i = 0; i < count; ++i) {
        RigidState& s = one[i];
        s.position = rng.uniform_vec3(-1, 1);
        s.linear_velocity = rng.uniform_vec3(-2, 2);
        // Braces draw left to right (a parenthesised call leaves its arguments' order to the compiler).
        s.orientation = Quat(Eigen::AngleAxisd{rng.uniform(0, 3), rng.uniform_vec3(-1, 1).normalized()});
        const double speed = std::array{0.0, 1e-4, 1.0, 300.0}[rng.below(4)];
        s.angular_velocity = speed * rng.uniform_vec3(-1, 1);
        inertia[i] = trial % 7 == 0 && i == 0 ? &kinematic : &dynamic;
        four[i] = s;
      }
      std::array<Mat3, 4> r_one{}, r_four{};
      std::array<RigidState*, 4> states{};
      std::array<Mat3*, 4> rotations{};
      for (std::size_t i = 0; i < count; ++i) {
        integrate_position(*inertia[i], one[i], 1.0 / 480, &r_one[i]);
        states[i] = &four[i];
        rotations[i] = &r_four[i];
      }
      integrate_positions(std::span(inertia.data(), count), std::span(states.data(), count), 1.0 / 480,
                          std::span(rotations.data(), count));
      for (std::size_t i = 0; i < count; ++i) {
        EXPECT_EQ(bits(one[i].position), bits(four[i].position)) << trial << " " << i;
        EXPECT_EQ(bits(one[i].angular_velocity), bits(four[i].angular_velocity)) << trial << " " << i;
        EXPECT_EQ(bits(one[i].orientation.coeffs()), bits(four[i].orientation.coeffs())) << trial << " " << i;
        EXPECT_EQ(bits(r_one[i]), bits(r_four[i])) << trial << " " << i;
      }
    }
  }
  set_simd_isa(saved);
}

}  // namespace
}  // namespace shatter
