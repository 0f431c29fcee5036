// Soft-step contact solver (see contact_solver.h).
#include "shatter/rigid/contact_solver.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace shatter {
namespace {

// Velocity of the material point at offset r of body b, m/s.
Vec3 point_velocity(const SolverBody& b, const Vec3& r) { return b.linear_velocity + b.angular_velocity.cross(r); }

// The velocities of a constraint's two bodies, copied out of the body array for one pass over the
// constraint and written back once at its end: the compiler keeps them in registers across the
// rows instead of reloading them through the array after every impulse.
struct PairMotion {
  Vec3 va, wa, vb, wb;  // linear (m/s) and angular (rad/s) velocity of A and of B
  double inverse_mass_a, inverse_mass_b;
  bool a_responds, b_responds;

  PairMotion(const ContactConstraint& c, std::span<const SolverBody> bodies)
      : va(bodies[c.body_a].linear_velocity),
        wa(bodies[c.body_a].angular_velocity),
        vb(bodies[c.body_b].linear_velocity),
        wb(bodies[c.body_b].angular_velocity),
        inverse_mass_a(bodies[c.body_a].inverse_mass),
        inverse_mass_b(bodies[c.body_b].inverse_mass),
        a_responds(c.a_responds),
        b_responds(c.b_responds) {}

  // A body without response (static, kinematic, asleep: zero inverse mass and inertia) is never
  // written: its velocity would only change by zero, and every contact with the ground would
  // otherwise write the ground's one slot, each waiting for the last.
  void store(const ContactConstraint& c, std::span<SolverBody> bodies) const {
    if (a_responds) {
      bodies[c.body_a].linear_velocity = va;
      bodies[c.body_a].angular_velocity = wa;
    }
    if (b_responds) {
      bodies[c.body_b].linear_velocity = vb;
      bodies[c.body_b].angular_velocity = wb;
    }
  }

  // Apply impulse l along unit direction d (on B; -l d on A) whose angular responses are ang_a and
  // ang_b (I^-1 (r x d) of each body).
  [[gnu::always_inline]] void apply_row(const Vec3& d, const Vec3& ang_a, const Vec3& ang_b, double l) {
    if (a_responds) {
      va -= (inverse_mass_a * l) * d;
      wa -= l * ang_a;
    }
    if (b_responds) {
      vb += (inverse_mass_b * l) * d;
      wb += l * ang_b;
    }
  }

  // Relative velocity along a row: d . (v_B - v_A) + r_b . w_B - r_a . w_A (r = anchor x d).
  [[gnu::always_inline]] double row_velocity(const Vec3& d, const Vec3& r_a, const Vec3& r_b) const {
    return d.dot(vb - va) + r_b.dot(wb) - r_a.dot(wa);
  }
};

// One normal row: the accumulated impulse moves by -m (scale vn + bias) - impulse_scale * lambda,
// clamped at 0 (Box2D's soft contact). Returns the impulse applied.
[[gnu::always_inline]] inline double solve_normal(const ContactConstraint& c, ContactPoint& p, PairMotion& m,
                                                  double bias, double mass_scale, double impulse_scale) {
  const double vn = m.row_velocity(c.normal, p.rn_a, p.rn_b);
  const double delta = -p.normal_mass * (mass_scale * vn + bias) - impulse_scale * p.normal_impulse;
  const double next = std::max(p.normal_impulse + delta, 0.0);
  const double applied = next - p.normal_impulse;
  p.normal_impulse = next;
  p.max_normal_impulse = std::max(p.max_normal_impulse, next);
  p.total_normal_impulse += applied;
  m.apply_row(c.normal, p.ang_a, p.ang_b, applied);
  return applied;
}

// Each point's current separation, n . (p_B - p_A) + adjusted with p = x + R r_local the surface
// points, from the normal turned into each body's frame once per pass: n . (R r) = (R^T n) . r.
struct PointGaps {
  Vec3 normal_in_a, normal_in_b;
  double centre_gap;
  PointGaps(const ContactConstraint& c, std::span<const SolverBody> bodies)
      : normal_in_a(bodies[c.body_a].rotation.transpose() * c.normal),
        normal_in_b(bodies[c.body_b].rotation.transpose() * c.normal),
        centre_gap(c.normal.dot(bodies[c.body_b].position) - c.normal.dot(bodies[c.body_a].position)) {}
  [[nodiscard]] double at(const ContactPoint& p) const {
    return p.adjusted_separation + centre_gap + (normal_in_b.dot(p.local_anchor_b) - normal_in_a.dot(p.local_anchor_a));
  }
};

// Apply the friction impulse f (x along tangent 0, y along tangent 1) at the friction centre.
[[gnu::always_inline]] inline void apply_friction(const ContactConstraint& c, PairMotion& m, const Eigen::Vector2d& f) {
  m.apply_row(c.tangents[0], c.ang_ta[0], c.ang_tb[0], f.x());
  m.apply_row(c.tangents[1], c.ang_ta[1], c.ang_tb[1], f.y());
}
// Apply the twist impulse t about the normal.
[[gnu::always_inline]] inline void apply_twist(const ContactConstraint& c, PairMotion& m, double t) {
  if (m.a_responds) m.wa -= t * c.twist_a;
  if (m.b_responds) m.wb += t * c.twist_b;
}

}  // namespace

Softness make_softness(double hertz, double damping_ratio, double h) {
  if (hertz == 0) return {0, 1, 0};
  const double omega = 2 * std::numbers::pi * hertz;
  const double a1 = 2 * damping_ratio + h * omega;
  const double a2 = h * omega * a1;
  const double a3 = 1 / (1 + a2);
  return {omega / a1, a2 * a3, a3};
}

std::array<Vec3, 2> tangent_basis(const Vec3& n) {
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z());
  const double b = n.x() * n.y() * a;
  return {Vec3(1 + sign * n.x() * n.x() * a, sign * b, -sign * n.x()), Vec3(b, sign + n.y() * n.y() * a, -n.y())};
}

void prepare_contact(ContactConstraint& c, std::span<const SolverBody> bodies, double speculative_distance) {
  const SolverBody& a = bodies[c.body_a];
  const SolverBody& b = bodies[c.body_b];
  c.a_responds = a.inverse_mass != 0 || !a.inverse_inertia.isZero(0);
  c.b_responds = b.inverse_mass != 0 || !b.inverse_inertia.isZero(0);
  c.tangents = tangent_basis(c.normal);
  // Friction centre: the mean of the points, those with a gap fading out over the speculative
  // distance so that the centre moves smoothly as points come and go (Box3D's weighting).
  Vec3 centre_a = Vec3::Zero(), centre_b = Vec3::Zero();
  double weight_sum = 0;
  for (int i = 0; i < c.count; ++i) {
    ContactPoint& p = c.points[i];
    p.anchor_a = p.position - a.position;
    p.anchor_b = p.position - b.position;
    const Vec3 half_gap = 0.5 * p.separation * c.normal;
    p.local_anchor_a = a.rotation.transpose() * (p.anchor_a - half_gap);
    p.local_anchor_b = b.rotation.transpose() * (p.anchor_b + half_gap);
    p.adjusted_separation = p.separation - (c.normal.dot(b.position + b.rotation * p.local_anchor_b) -
                                            c.normal.dot(a.position + a.rotation * p.local_anchor_a));
    p.rn_a = p.anchor_a.cross(c.normal);
    p.rn_b = p.anchor_b.cross(c.normal);
    p.ang_a = a.inverse_inertia * p.rn_a;
    p.ang_b = b.inverse_inertia * p.rn_b;
    const double k = a.inverse_mass + b.inverse_mass + p.rn_a.dot(p.ang_a) + p.rn_b.dot(p.ang_b);
    p.normal_mass = k > 0 ? 1.0 / k : 0.0;
    const Vec3 dv = point_velocity(b, p.anchor_b) - point_velocity(a, p.anchor_a);
    p.approach_speed = -dv.dot(c.normal);
    p.max_normal_impulse = 0;
    p.total_normal_impulse = 0;
    const double weight =
        speculative_distance > 0 ? std::clamp(2.0 - p.separation / speculative_distance, 1e-3, 1.0) : 1.0;
    centre_a += weight * p.anchor_a;
    centre_b += weight * p.anchor_b;
    weight_sum += weight;
  }
  c.centre_a = centre_a / weight_sum;
  c.centre_b = centre_b / weight_sum;
  for (int i = 0; i < c.count; ++i) c.points[i].lever_arm = (c.points[i].anchor_a - c.centre_a).norm();
  // Coupled tangent mass at the centre: K_ij = (1/mA + 1/mB) d_ij + (rA x t_i) IA^-1 (rA x t_j) + (B).
  for (int k = 0; k < 2; ++k) {
    c.rt_a[k] = c.centre_a.cross(c.tangents[k]);
    c.rt_b[k] = c.centre_b.cross(c.tangents[k]);
    c.ang_ta[k] = a.inverse_inertia * c.rt_a[k];
    c.ang_tb[k] = b.inverse_inertia * c.rt_b[k];
  }
  Eigen::Matrix2d kt;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      kt(i, j) =
          (i == j ? a.inverse_mass + b.inverse_mass : 0.0) + c.rt_a[i].dot(c.ang_ta[j]) + c.rt_b[i].dot(c.ang_tb[j]);
  const double det = kt.determinant();
  c.tangent_mass = det > 0 ? Eigen::Matrix2d(kt.inverse()) : Eigen::Matrix2d::Zero();
  c.twist_a = a.inverse_inertia * c.normal;
  c.twist_b = b.inverse_inertia * c.normal;
  const double kw = c.normal.dot(c.twist_a) + c.normal.dot(c.twist_b);
  c.twist_mass = kw > 0 ? 1.0 / kw : 0.0;
  c.total_friction_impulse.setZero();
  c.total_twist_impulse = 0;
}

void warm_start_contact(ContactConstraint& c, std::span<SolverBody> bodies) {
  PairMotion m(c, bodies);
  for (int i = 0; i < c.count; ++i) {
    ContactPoint& p = c.points[i];
    m.apply_row(c.normal, p.ang_a, p.ang_b, p.normal_impulse);
    p.total_normal_impulse += p.normal_impulse;
  }
  apply_friction(c, m, c.friction_impulse);
  apply_twist(c, m, c.twist_impulse);
  m.store(c, bodies);
  c.total_twist_impulse += c.twist_impulse;
  c.total_friction_impulse += c.friction_impulse.x() * c.tangents[0] + c.friction_impulse.y() * c.tangents[1];
}

void measure_approach(ContactConstraint& c, std::span<const SolverBody> bodies) {
  const PairMotion m(c, bodies);
  for (int i = 0; i < c.count; ++i) {
    ContactPoint& p = c.points[i];
    p.approach_speed = std::max(p.approach_speed, -m.row_velocity(c.normal, p.rn_a, p.rn_b));
  }
}

void solve_contact(ContactConstraint& c, std::span<SolverBody> bodies, double inverse_h, bool use_bias,
                   double max_push_velocity) {
  PairMotion m(c, bodies);
  const PointGaps gaps(c, bodies);
  double total_normal = 0;
  double twist_limit = 0;
  for (int i = 0; i < c.count; ++i) {
    ContactPoint& p = c.points[i];
    const double s = gaps.at(p);
    if (s > 0) {
      solve_normal(c, p, m, s * inverse_h, 1, 0);  // speculative: close the gap within the substep, no more
    } else if (use_bias) {
      const Softness& soft = c.softness;
      solve_normal(c, p, m, std::max(soft.mass_scale * soft.bias_rate * s, -max_push_velocity), soft.mass_scale,
                   soft.impulse_scale);
    } else {
      solve_normal(c, p, m, 0, 1, 0);
    }
    total_normal += p.normal_impulse;
    twist_limit += p.lever_arm * p.normal_impulse;
  }
  // Twist friction about the normal.
  {
    const double spin = c.normal.dot(m.wb - m.wa);
    const double limit = c.friction * twist_limit;
    const double next = std::clamp(c.twist_impulse - c.twist_mass * spin, -limit, limit);
    apply_twist(c, m, next - c.twist_impulse);
    c.total_twist_impulse += next - c.twist_impulse;
    c.twist_impulse = next;
  }
  // Coulomb friction at the centre, the tangent impulse clamped to the friction disc.
  {
    const Eigen::Vector2d vt(m.row_velocity(c.tangents[0], c.rt_a[0], c.rt_b[0]),
                             m.row_velocity(c.tangents[1], c.rt_a[1], c.rt_b[1]));
    Eigen::Vector2d next = c.friction_impulse - c.tangent_mass * vt;
    const double limit = c.friction * total_normal;
    const double norm = next.norm();
    if (norm > limit) next *= norm > 0 ? limit / norm : 0.0;
    const Eigen::Vector2d delta = next - c.friction_impulse;
    c.friction_impulse = next;
    c.total_friction_impulse += delta.x() * c.tangents[0] + delta.y() * c.tangents[1];
    apply_friction(c, m, delta);
  }
  m.store(c, bodies);
}

void push_off_supported(const ContactConstraint& c, std::span<SolverBody> bodies, bool supported_is_a, double inverse_h,
                        bool use_bias, double max_push_velocity) {
  PairMotion m(c, bodies);
  const PointGaps gaps(c, bodies);
  const double inverse_mass = supported_is_a ? m.inverse_mass_b : m.inverse_mass_a;
  // Impulse l along row direction d (rows r = anchor x d, angular responses ang = I^-1 r) on the
  // moving body alone: its own effective mass along the row, and the push.
  const auto own_mass = [&](const Vec3& r_a, const Vec3& ang_a, const Vec3& r_b, const Vec3& ang_b) {
    return supported_is_a ? inverse_mass + r_b.dot(ang_b) : inverse_mass + r_a.dot(ang_a);
  };
  const auto push = [&](const Vec3& d, const Vec3& ang_a, const Vec3& ang_b, double l) {
    if (supported_is_a) {
      m.vb += (inverse_mass * l) * d;
      m.wb += l * ang_b;
    } else {
      m.va -= (inverse_mass * l) * d;
      m.wa -= l * ang_a;
    }
  };
  double pushed = 0;  // the normal impulse applied, N s
  for (int i = 0; i < c.count; ++i) {
    const ContactPoint& p = c.points[i];
    const double s = gaps.at(p);
    // The least normal velocity of B relative to A at the point.
    const double target =
        s > 0 ? -s * inverse_h : (use_bias ? std::min(-c.softness.bias_rate * s, max_push_velocity) : 0.0);
    const double vn = m.row_velocity(c.normal, p.rn_a, p.rn_b);
    if (vn >= target) continue;
    const double k = own_mass(p.rn_a, p.ang_a, p.rn_b, p.ang_b);
    if (!(k > 0)) continue;
    const double l = (target - vn) / k;
    pushed += l;
    push(c.normal, p.ang_a, p.ang_b, l);
  }
  // The push's own friction: the pushes at points off the centre turn the body, and a turn slides
  // its contact face; within the friction cone of what was pushed, the sliding they left at the
  // friction centre is taken out again.
  if (pushed > 0 && c.friction > 0) {
    Eigen::Vector2d applied = Eigen::Vector2d::Zero();
    for (int j = 0; j < 2; ++j) {
      const double k = own_mass(c.rt_a[j], c.ang_ta[j], c.rt_b[j], c.ang_tb[j]);
      if (k > 0) applied[j] = -m.row_velocity(c.tangents[j], c.rt_a[j], c.rt_b[j]) / k;
    }
    const double limit = c.friction * pushed;
    if (const double n = applied.norm(); n > limit) applied *= limit / n;
    for (int j = 0; j < 2; ++j) push(c.tangents[j], c.ang_ta[j], c.ang_tb[j], applied[j]);
  }
  m.store(c, bodies);
}

void apply_restitution(ContactConstraint& c, std::span<SolverBody> bodies, double threshold) {
  if (c.restitution == 0) return;
  PairMotion m(c, bodies);
  for (int i = 0; i < c.count; ++i) {
    ContactPoint& p = c.points[i];
    if (p.approach_speed < threshold || p.max_normal_impulse == 0) continue;
    solve_normal(c, p, m, -c.restitution * p.approach_speed, 1, 0);
  }
  m.store(c, bodies);
}

}  // namespace shatter
