// Rigid-body integration (see integrate.h).
#include "shatter/rigid/integrate.h"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>

namespace shatter {
namespace {

// The Cayley rotation of the midpoint rule for angular velocity w over dt, as a unit quaternion:
// L_b' = q L_b solves (I + dt/2 [w]) L_b' = (I - dt/2 [w]) L_b (see integrate.h).
Quat cayley_step(const Vec3& w, double dt) {
  const Vec3 b = -0.5 * dt * w;
  return Quat(1.0, b.x(), b.y(), b.z()).normalized();
}

// The same rotation applied to v without forming the unit quaternion (no square root): with
// q = (1, b) / |(1, b)|, q v q* = v + 2 / (1 + b.b) (b x v + b x (b x v)).
Vec3 cayley_rotate(const Vec3& w, double dt, const Vec3& v) {
  const Vec3 b = -0.5 * dt * w;
  const Vec3 bv = b.cross(v);
  return v + (2.0 / (1.0 + b.squaredNorm())) * (bv + b.cross(bv));
}

// Body-frame midpoint angular velocity of the torque-free step: the fixed point of
// w = I_b^-1 (L_b + Q(w) L_b) / 2. Returns false when it does not converge (a step too large for
// the spin; the caller splits it).
bool midpoint_velocity(const Mat3& inverse_inertia, const Vec3& l_body, double dt, Vec3& w) {
  // First guess: the midpoint momentum after half an explicit step, L + dt/2 (L x w).
  const Vec3 w0 = inverse_inertia * l_body;
  w = inverse_inertia * (l_body + (0.5 * dt) * l_body.cross(w0));
  // Converged when the change is at most 4 ulp of |w|, compared squared (no square roots).
  constexpr double kTolerance = 16 * std::numeric_limits<double>::epsilon() * std::numeric_limits<double>::epsilon();
  for (int it = 0; it < 200; ++it) {
    const Vec3 next = inverse_inertia * (0.5 * (l_body + cayley_rotate(w, dt, l_body)));
    const double change = (next - w).squaredNorm();
    w = next;
    if (change <= kTolerance * w.squaredNorm()) return true;
  }
  return false;
}

// The torque-free rotation over dt: orientation and body angular momentum, by halves when the
// fixed point does not converge at full length. At 2^10 pieces the last iterate is used: the step
// is still an exact rotation (world angular momentum kept), only the energy is then kept to the
// iterate's accuracy rather than to 4 ulp.
void rotate(const Mat3& inverse_inertia, Quat& q, Vec3& l_body, double dt, int depth) {
  Vec3 w;
  if (!midpoint_velocity(inverse_inertia, l_body, dt, w) && depth < 10) {
    rotate(inverse_inertia, q, l_body, 0.5 * dt, depth + 1);
    rotate(inverse_inertia, q, l_body, 0.5 * dt, depth + 1);
    return;
  }
  const Quat step = cayley_step(w, dt);
  l_body = step * l_body;
  q = (q * step.conjugate()).normalized();
}

}  // namespace

RigidInertia rigid_inertia(const MassProperties& mass) {
  RigidInertia r;
  if (!(mass.mass > 0) || !std::isfinite(mass.mass)) return r;
  r.inverse_mass = 1.0 / mass.mass;
  r.inertia_body = 0.5 * (mass.inertia + mass.inertia.transpose());
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(r.inertia_body);
  if (eig.info() == Eigen::Success && eig.eigenvalues().minCoeff() > 0)
    r.inverse_inertia_body =
        eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  return r;
}

Mat3 world_inverse_inertia(const RigidInertia& inertia, const Quat& orientation) {
  const Mat3 R = orientation.toRotationMatrix();
  return R * inertia.inverse_inertia_body * R.transpose();
}

Vec3 angular_momentum(const RigidInertia& inertia, const RigidState& state) {
  const Mat3 R = state.orientation.toRotationMatrix();
  return R * (inertia.inertia_body * (R.transpose() * state.angular_velocity));
}

double kinetic_energy(const RigidInertia& inertia, const RigidState& state) {
  const double m = inertia.inverse_mass > 0 ? 1.0 / inertia.inverse_mass : 0.0;
  const Mat3 R = state.orientation.toRotationMatrix();
  const Vec3 wb = R.transpose() * state.angular_velocity;
  return 0.5 * m * state.linear_velocity.squaredNorm() + 0.5 * wb.dot(inertia.inertia_body * wb);
}

void integrate_velocity(const RigidInertia& inertia, RigidState& state, const Vec3& force, const Vec3& torque,
                        double dt) {
  if (inertia.inverse_mass == 0) return;
  state.linear_velocity += (dt * inertia.inverse_mass) * force;
  if (torque.squaredNorm() == 0) return;
  const Vec3 l = angular_momentum(inertia, state) + dt * torque;
  state.angular_velocity = world_inverse_inertia(inertia, state.orientation) * l;
}

void integrate_position(const RigidInertia& inertia, RigidState& state, double dt, Mat3* rotation) {
  state.position += dt * state.linear_velocity;
  if (state.angular_velocity.squaredNorm() == 0) {
    if (rotation != nullptr) *rotation = state.orientation.toRotationMatrix();
    return;
  }
  if (inertia.inverse_mass == 0) {  // kinematic: turn at the given (world) angular velocity exactly
    const double angle = dt * state.angular_velocity.norm();
    const Quat turn(Eigen::AngleAxisd(angle, state.angular_velocity.normalized()));
    state.orientation = (turn * state.orientation).normalized();
    if (rotation != nullptr) *rotation = state.orientation.toRotationMatrix();
    return;
  }
  const Mat3 R = state.orientation.toRotationMatrix();
  Vec3 l_body = inertia.inertia_body * (R.transpose() * state.angular_velocity);
  rotate(inertia.inverse_inertia_body, state.orientation, l_body, dt, 0);
  const Mat3 turned = state.orientation.toRotationMatrix();
  state.angular_velocity = turned * (inertia.inverse_inertia_body * l_body);
  if (rotation != nullptr) *rotation = turned;
}

}  // namespace shatter
