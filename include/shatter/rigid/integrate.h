// Rigid-body motion between impacts (docs/method.md §2.7, eq. 23), split so a contact solver can sit
// between the two halves of a step:
//   integrate_velocity: v += dt F / m and the angular momentum L += dt tau (a kick);
//   integrate_position: x += dt v, and the torque-free rotation over dt (a drift).
// The drift is the implicit midpoint rule for the body-frame angular momentum L_b (Euler's
// equations dL_b/dt = L_b x w, w = I_b^-1 L_b). Its update is a rotation, L_b' = Q L_b with the
// Cayley transform Q = cay(-dt [w_mid]), and the orientation turns by Q^T, so
//   - the world angular momentum L = R L_b is kept exactly (to round-off),
//   - the kinetic energy L_b . I_b^-1 L_b / 2 and |L_b| are quadratic invariants of the midpoint
//     rule, kept to the tolerance of its fixed-point solve: a tumbling body never gains energy,
//   - the orientation stays a unit quaternion (q' = q (1, dt w_mid / 2) normalised, the quaternion
//     of the Cayley rotation), and the scheme is time-reversible.
// It reproduces the intermediate-axis (Dzhanibekov) flip of a free asymmetric body.
// integrate_positions drifts up to four bodies at once with the same arithmetic (the same bits).
#pragma once

#include <span>

#include "shatter/core/types.h"
#include "shatter/rigid/body.h"

namespace shatter {

/// A body's inertia as the integrator needs it.
struct RigidInertia {
  double inverse_mass = 0;                   ///< 1/kg (0: static or kinematic)
  Mat3 inertia_body = Mat3::Identity();      ///< about the centre of mass, body frame, kg m^2
  Mat3 inverse_inertia_body = Mat3::Zero();  ///< its inverse (0: no rotation)
};

/// From exact mass properties. A mass that is not > 0 gives an infinitely heavy body (inverse mass
/// 0); an inertia that is not positive definite gives a zero inverse inertia (torques do not turn it).
RigidInertia rigid_inertia(const MassProperties& mass);

/// World inverse inertia R I_b^-1 R^T at `orientation`.
Mat3 world_inverse_inertia(const RigidInertia& inertia, const Quat& orientation);

/// Angular momentum in the world, I w = R I_b R^T w, kg m^2 / s.
Vec3 angular_momentum(const RigidInertia& inertia, const RigidState& state);

/// Kinetic energy (1/2 m v^2 + 1/2 w . I w), J.
double kinetic_energy(const RigidInertia& inertia, const RigidState& state);

/// Kick: v += dt f / m, L += dt torque (world, N and N m), w from the new L at the current
/// orientation. No effect on an infinitely heavy body.
void integrate_velocity(const RigidInertia& inertia, RigidState& state, const Vec3& force, const Vec3& torque,
                        double dt);

/// Drift: x += dt v, and the torque-free rotation over dt described at the top of this file. The
/// angular velocity is updated to the end-of-step one (w = R' I_b^-1 L_b'). An infinitely heavy
/// (kinematic) body turns at its given world angular velocity instead. `rotation`, when given, gets
/// the new orientation as a matrix (computed on the way).
void integrate_position(const RigidInertia& inertia, RigidState& state, double dt, Mat3* rotation = nullptr);

/// integrate_position on up to four bodies at once, the same bits as one at a time: dynamic bodies
/// that spin are drifted side by side in vector lanes (AVX2 where the CPU has it, core/simd.h).
/// `rotations[i]` may be null. The three spans have the same length, at most 4.
void integrate_positions(std::span<const RigidInertia* const> inertia, std::span<RigidState* const> states, double dt,
                         std::span<Mat3* const> rotations);

}  // namespace shatter
