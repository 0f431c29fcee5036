// Rigid-body integration (see integrate.h).
#include "shatter/rigid/integrate.h"

#include <Eigen/Eigenvalues>

#include <array>
#include <cmath>
#include <limits>

#include "shatter/core/assert.h"
#include "shatter/core/lanes.h"
#include "shatter/core/simd.h"

namespace shatter {

// The drift's arithmetic is written once, over a number type T: double for one body, PlainLanes
// (core/lanes.h) for four bodies side by side (integrate_positions). Both run the same operations in
// the same order, none fused (-ffp-contract=off), so four at a time gives the bits of one at a time.
// The vectors live only in the locals of one function (drift_lanes, compiled once per instruction
// set), never in memory another function reads, so their alignment may follow the instruction set.

namespace {

template <class T>
struct V3 {
  T x, y, z;
};
template <class T>
struct Q4 {
  T w, x, y, z;
};
template <class T>
struct M3 {
  T m[3][3];  // row-major
};

#define SHATTER_INLINE [[gnu::always_inline]] inline
template <class T>
SHATTER_INLINE V3<T> operator+(const V3<T>& a, const V3<T>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
SHATTER_INLINE V3<T> operator-(const V3<T>& a, const V3<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T, class S>
SHATTER_INLINE V3<T> operator*(const S& s, const V3<T>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class T>
SHATTER_INLINE T dot(const V3<T>& a, const V3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
SHATTER_INLINE V3<T> cross(const V3<T>& a, const V3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
SHATTER_INLINE V3<T> mul(const M3<T>& m, const V3<T>& v) {
  return {m.m[0][0] * v.x + m.m[0][1] * v.y + m.m[0][2] * v.z, m.m[1][0] * v.x + m.m[1][1] * v.y + m.m[1][2] * v.z,
          m.m[2][0] * v.x + m.m[2][1] * v.y + m.m[2][2] * v.z};
}
template <class T>
SHATTER_INLINE V3<T> mul_transposed(const M3<T>& m, const V3<T>& v) {
  return {m.m[0][0] * v.x + m.m[1][0] * v.y + m.m[2][0] * v.z, m.m[0][1] * v.x + m.m[1][1] * v.y + m.m[2][1] * v.z,
          m.m[0][2] * v.x + m.m[1][2] * v.y + m.m[2][2] * v.z};
}
// Correctly rounded square roots; kAvx2 tells the lanes' version which instructions the caller uses.
template <bool kAvx2>
SHATTER_INLINE double root(double x) {
  return std::sqrt(x);
}
template <bool kAvx2>
SHATTER_INLINE PlainLanes root(const PlainLanes& x) {
  return lane_sqrt<kAvx2>(x);
}
template <bool kAvx2, class T>
SHATTER_INLINE Q4<T> normalized(const Q4<T>& q) {
  const T n = root<kAvx2>(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}
// a * conj(b)
template <class T>
SHATTER_INLINE Q4<T> times_conjugate(const Q4<T>& a, const Q4<T>& b) {
  return {a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z, -a.w * b.x + b.w * a.x - (a.y * b.z - a.z * b.y),
          -a.w * b.y + b.w * a.y - (a.z * b.x - a.x * b.z), -a.w * b.z + b.w * a.z - (a.x * b.y - a.y * b.x)};
}
// q v q*, as Eigen writes it: v + w (2 u x v) + u x (2 u x v).
template <class T>
SHATTER_INLINE V3<T> turn(const Q4<T>& q, const V3<T>& v) {
  const V3<T> u{q.x, q.y, q.z};
  V3<T> uv = cross(u, v);
  uv = uv + uv;
  return v + q.w * uv + cross(u, uv);
}
template <class T>
SHATTER_INLINE M3<T> rotation_matrix(const Q4<T>& q) {
  const T tx = q.x + q.x, ty = q.y + q.y, tz = q.z + q.z;
  const T twx = tx * q.w, twy = ty * q.w, twz = tz * q.w;
  const T txx = tx * q.x, txy = ty * q.x, txz = tz * q.x;
  const T tyy = ty * q.y, tyz = tz * q.y, tzz = tz * q.z;
  const T one = T{} + 1.0;
  return {{{one - (tyy + tzz), txy - twz, txz + twy},
           {txy + twz, one - (txx + tzz), tyz - twx},
           {txz - twy, tyz + twx, one - (txx + tyy)}}};
}

// The Cayley rotation of the midpoint rule for angular velocity w over dt, as a unit quaternion:
// L_b' = q L_b solves (I + dt/2 [w]) L_b' = (I - dt/2 [w]) L_b (see integrate.h).
template <bool kAvx2, class T>
SHATTER_INLINE Q4<T> cayley_step(const V3<T>& w, double dt) {
  const V3<T> b = (-0.5 * dt) * w;
  return normalized<kAvx2>(Q4<T>{T{} + 1.0, b.x, b.y, b.z});
}

// The same rotation applied to v without forming the unit quaternion (no square root): with
// q = (1, b) / |(1, b)|, q v q* = v + 2 / (1 + b.b) (b x v + b x (b x v)).
template <class T>
SHATTER_INLINE V3<T> cayley_rotate(const V3<T>& w, double dt, const V3<T>& v) {
  const V3<T> b = (-0.5 * dt) * w;
  const V3<T> bv = cross(b, v);
  return v + (2.0 / (1.0 + dot(b, b))) * (bv + cross(b, bv));
}

// Converged when the change is at most 4 ulp of |w|, compared squared (no square roots).
constexpr double kTolerance = 16 * std::numeric_limits<double>::epsilon() * std::numeric_limits<double>::epsilon();
constexpr int kMaxIterations = 200;

// The fixed point's first guess: the midpoint momentum after half an explicit step, L + dt/2 (L x w).
template <class T>
SHATTER_INLINE V3<T> first_guess(const M3<T>& inverse_inertia, const V3<T>& l_body, double dt) {
  const V3<T> w0 = mul(inverse_inertia, l_body);
  return mul(inverse_inertia, l_body + (0.5 * dt) * cross(l_body, w0));
}
// One iteration w -> I_b^-1 (L_b + Q(w) L_b) / 2; `change` gets |w' - w|^2.
template <class T>
SHATTER_INLINE V3<T> iterate(const M3<T>& inverse_inertia, const V3<T>& l_body, double dt, const V3<T>& w, T& change) {
  const V3<T> next = mul(inverse_inertia, 0.5 * (l_body + cayley_rotate(w, dt, l_body)));
  const V3<T> d = next - w;
  change = dot(d, d);
  return next;
}
// After the midpoint velocity w: the body momentum and the orientation turned by the Cayley step.
template <bool kAvx2, class T>
SHATTER_INLINE void finish_rotation(const V3<T>& w, double dt, Q4<T>& q, V3<T>& l_body) {
  const Q4<T> step = cayley_step<kAvx2>(w, dt);
  l_body = turn(step, l_body);
  q = normalized<kAvx2>(times_conjugate(q, step));
}

// Body-frame midpoint angular velocity of the torque-free step: the fixed point of
// w = I_b^-1 (L_b + Q(w) L_b) / 2. Returns false when it does not converge (a step too large for
// the spin; the caller splits it).
bool midpoint_velocity(const M3<double>& inverse_inertia, const V3<double>& l_body, double dt, V3<double>& w) {
  w = first_guess(inverse_inertia, l_body, dt);
  for (int it = 0; it < kMaxIterations; ++it) {
    double change = 0;
    w = iterate(inverse_inertia, l_body, dt, w, change);
    if (change <= kTolerance * dot(w, w)) return true;
  }
  return false;
}

// The torque-free rotation over dt: orientation and body angular momentum, by halves when the
// fixed point does not converge at full length. At 2^10 pieces the last iterate is used: the step
// is still an exact rotation (world angular momentum kept), only the energy is then kept to the
// iterate's accuracy rather than to 4 ulp.
void rotate(const M3<double>& inverse_inertia, Q4<double>& q, V3<double>& l_body, double dt, int depth) {
  V3<double> w;
  if (!midpoint_velocity(inverse_inertia, l_body, dt, w) && depth < 10) {
    rotate(inverse_inertia, q, l_body, 0.5 * dt, depth + 1);
    rotate(inverse_inertia, q, l_body, 0.5 * dt, depth + 1);
    return;
  }
  finish_rotation<false>(w, dt, q, l_body);
}

M3<double> to_m3(const Mat3& a) {
  M3<double> m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m.m[i][j] = a(i, j);
  return m;
}
Mat3 to_mat3(const M3<double>& m) {
  Mat3 a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a(i, j) = m.m[i][j];
  return a;
}
V3<double> to_v3(const Vec3& v) { return {v.x(), v.y(), v.z()}; }
Vec3 to_vec3(const V3<double>& v) { return {v.x, v.y, v.z}; }
Q4<double> to_q4(const Quat& q) { return {q.w(), q.x(), q.y(), q.z()}; }
Quat to_quat(const Q4<double>& q) { return {q.w, q.x, q.y, q.z}; }

// The rotation part of integrate_position for a dynamic body with w != 0: from the orientation
// and world angular velocity to the new ones and the new rotation matrix.
template <class T>
SHATTER_INLINE V3<T> body_momentum(const M3<T>& inertia_body, const Q4<T>& q, const V3<T>& w_world) {
  return mul(inertia_body, mul_transposed(rotation_matrix(q), w_world));
}
template <class T>
SHATTER_INLINE V3<T> world_velocity(const M3<T>& inverse_inertia, const Q4<T>& q, const V3<T>& l_body, M3<T>& turned) {
  turned = rotation_matrix(q);
  return mul(turned, mul(inverse_inertia, l_body));
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
    if (rotation != nullptr) *rotation = to_mat3(rotation_matrix(to_q4(state.orientation)));
    return;
  }
  if (inertia.inverse_mass == 0) {  // kinematic: turn at the given (world) angular velocity exactly
    const double angle = dt * state.angular_velocity.norm();
    const Quat turn(Eigen::AngleAxisd(angle, state.angular_velocity.normalized()));
    state.orientation = (turn * state.orientation).normalized();
    if (rotation != nullptr) *rotation = to_mat3(rotation_matrix(to_q4(state.orientation)));
    return;
  }
  const M3<double> inverse_inertia = to_m3(inertia.inverse_inertia_body);
  Q4<double> q = to_q4(state.orientation);
  V3<double> l_body = body_momentum(to_m3(inertia.inertia_body), q, to_v3(state.angular_velocity));
  rotate(inverse_inertia, q, l_body, dt, 0);
  M3<double> turned;
  state.angular_velocity = to_vec3(world_velocity(inverse_inertia, q, l_body, turned));
  state.orientation = to_quat(q);
  if (rotation != nullptr) *rotation = to_mat3(turned);
}

namespace {

// Four dynamic, spinning bodies at once: integrate_position's rotation part lane by lane, each lane
// iterating until it converges (converged lanes keep their value). Returns a mask of the lanes whose
// fixed point did not converge at full length; their outputs are not written.
template <bool kAvx2>
SHATTER_INLINE int drift_lanes(std::span<const RigidInertia* const> inertia, std::span<RigidState* const> states,
                               double dt, std::span<Mat3* const> rotations) {
  // Empty lanes repeat the first body and are not written. Each vector is built in registers from
  // its four values (written lane by lane it would go through memory, and reading it back would wait
  // for the four stores).
  const int n = static_cast<int>(states.size());
  std::array<const RigidInertia*, 4> inertia_of{};
  std::array<const RigidState*, 4> state_of{};
  for (int l = 0; l < 4; ++l) {
    const auto k = static_cast<std::size_t>(l < n ? l : 0);
    inertia_of[static_cast<std::size_t>(l)] = inertia[k];
    state_of[static_cast<std::size_t>(l)] = states[k];
  }
  auto matrix = [&](Mat3 RigidInertia::* member) {
    M3<PlainLanes> m;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        m.m[i][j] = PlainLanes{(inertia_of[0]->*member)(i, j), (inertia_of[1]->*member)(i, j),
                               (inertia_of[2]->*member)(i, j), (inertia_of[3]->*member)(i, j)};
    return m;
  };
  const M3<PlainLanes> inertia_body = matrix(&RigidInertia::inertia_body);
  const M3<PlainLanes> inverse_inertia = matrix(&RigidInertia::inverse_inertia_body);
  Q4<PlainLanes> q{PlainLanes{state_of[0]->orientation.w(), state_of[1]->orientation.w(), state_of[2]->orientation.w(),
                              state_of[3]->orientation.w()},
                   PlainLanes{state_of[0]->orientation.x(), state_of[1]->orientation.x(), state_of[2]->orientation.x(),
                              state_of[3]->orientation.x()},
                   PlainLanes{state_of[0]->orientation.y(), state_of[1]->orientation.y(), state_of[2]->orientation.y(),
                              state_of[3]->orientation.y()},
                   PlainLanes{state_of[0]->orientation.z(), state_of[1]->orientation.z(), state_of[2]->orientation.z(),
                              state_of[3]->orientation.z()}};
  const V3<PlainLanes> w_world{PlainLanes{state_of[0]->angular_velocity.x(), state_of[1]->angular_velocity.x(),
                                          state_of[2]->angular_velocity.x(), state_of[3]->angular_velocity.x()},
                               PlainLanes{state_of[0]->angular_velocity.y(), state_of[1]->angular_velocity.y(),
                                          state_of[2]->angular_velocity.y(), state_of[3]->angular_velocity.y()},
                               PlainLanes{state_of[0]->angular_velocity.z(), state_of[1]->angular_velocity.z(),
                                          state_of[2]->angular_velocity.z(), state_of[3]->angular_velocity.z()}};
  V3<PlainLanes> l_body = body_momentum(inertia_body, q, w_world);
  V3<PlainLanes> w = first_guess(inverse_inertia, l_body, dt);
  PlainLaneMask done{};  // all false
  for (int it = 0; it < kMaxIterations; ++it) {
    PlainLanes change;
    const V3<PlainLanes> next = iterate(inverse_inertia, l_body, dt, w, change);
    w.x = done ? w.x : next.x;
    w.y = done ? w.y : next.y;
    w.z = done ? w.z : next.z;
    done = done | (change <= kTolerance * dot(next, next));
    if (done[0] && done[1] && done[2] && done[3]) break;
  }
  finish_rotation<kAvx2>(w, dt, q, l_body);
  M3<PlainLanes> turned;
  const V3<PlainLanes> w_new = world_velocity(inverse_inertia, q, l_body, turned);
  int failed = 0;
  for (int l = 0; l < n; ++l) {
    if (!done[l]) {
      failed |= 1 << l;
      continue;
    }
    RigidState& st = *states[static_cast<std::size_t>(l)];
    st.position += dt * st.linear_velocity;
    st.orientation = Quat(q.w[l], q.x[l], q.y[l], q.z[l]);
    st.angular_velocity = Vec3(w_new.x[l], w_new.y[l], w_new.z[l]);
    if (rotations[static_cast<std::size_t>(l)] != nullptr)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) (*rotations[static_cast<std::size_t>(l)])(i, j) = turned.m[i][j][l];
  }
  return failed;
}

[[gnu::target("avx2")]] int drift_lanes_avx2(std::span<const RigidInertia* const> inertia,
                                             std::span<RigidState* const> states, double dt,
                                             std::span<Mat3* const> rotations) {
  return drift_lanes<true>(inertia, states, dt, rotations);
}
int drift_lanes_baseline(std::span<const RigidInertia* const> inertia, std::span<RigidState* const> states, double dt,
                         std::span<Mat3* const> rotations) {
  return drift_lanes<false>(inertia, states, dt, rotations);
}

}  // namespace

void integrate_positions(std::span<const RigidInertia* const> inertia, std::span<RigidState* const> states, double dt,
                         std::span<Mat3* const> rotations) {
  SHATTER_CHECK(inertia.size() == states.size() && rotations.size() == states.size() && states.size() <= 4);
  // The dynamic bodies that spin go side by side in lanes (when there are two or more); the others,
  // and lanes whose fixed point must be split, one at a time. The same bits either way.
  std::array<std::size_t, 4> of_lane{};
  std::array<const RigidInertia*, 4> lane_inertia{};
  std::array<RigidState*, 4> lane_states{};
  std::array<Mat3*, 4> lane_rotations{};
  std::size_t lanes = 0;
  for (std::size_t i = 0; i < states.size(); ++i)
    if (inertia[i]->inverse_mass != 0 && states[i]->angular_velocity.squaredNorm() != 0) {
      of_lane[lanes] = i;
      lane_inertia[lanes] = inertia[i];
      lane_states[lanes] = states[i];
      lane_rotations[lanes] = rotations[i];
      ++lanes;
    }
  if (lanes < 2) lanes = 0;
  int failed = 0;  // by lane
  if (lanes > 0) {
    const auto drift = simd_isa() == SimdIsa::avx2 ? drift_lanes_avx2 : drift_lanes_baseline;
    failed = drift(std::span(lane_inertia.data(), lanes), std::span(lane_states.data(), lanes), dt,
                   std::span(lane_rotations.data(), lanes));
  }
  std::array<bool, 4> drifted{};
  for (std::size_t l = 0; l < lanes; ++l) drifted[of_lane[l]] = (failed >> l & 1) == 0;
  for (std::size_t i = 0; i < states.size(); ++i)
    if (!drifted[i]) integrate_position(*inertia[i], *states[i], dt, rotations[i]);
}

}  // namespace shatter
#undef SHATTER_INLINE
