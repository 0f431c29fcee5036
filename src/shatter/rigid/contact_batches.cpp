// Contact constraints solved four at a time (see contact_batches.h).
#include "shatter/rigid/contact_batches.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>

#include "shatter/core/lanes.h"
#include "shatter/core/simd.h"

namespace shatter {

// Four values per field, one per constraint of a batch (core/lanes.h: the baseline and AVX2 passes
// give the same bits). Vectors live only inside the passes and in WideContact.
static_assert(ContactBatches::kLanes == 4);

// Outside the anonymous namespace: WideContact (declared in contact_batches.h) holds these.
struct Lane3 {
  Lanes x, y, z;
};
static_assert(alignof(Lanes) == 32 && alignof(Lane3) == 32);

[[gnu::always_inline]] inline Lanes dot(const Lane3& a, const Lane3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// One point slot of four constraints (zeros where a constraint has fewer points: no mass, no
// impulse). The fields are those of ContactPoint the passes read or write.
struct WidePoint {
  Lanes adjusted_separation;
  Lane3 local_anchor_a, local_anchor_b;
  Lane3 rn_a, rn_b, ang_a, ang_b;
  Lanes normal_mass, normal_impulse, lever_arm, approach_speed, max_normal_impulse, total_normal_impulse;
};

// Four constraints (zeros in empty lanes). The fields are those of ContactConstraint the passes read
// or write, plus the bodies' inverse masses.
struct WideContact {
  std::array<Index, ContactBatches::kLanes> body_a{}, body_b{};
  LaneMask a_responds, b_responds;  // -1 where the lane's body takes impulses (and is written back)
  Lanes inverse_mass_a, inverse_mass_b;
  Lane3 normal;
  std::array<Lane3, 2> tangents;
  Lanes friction, bias_rate, mass_scale, impulse_scale;
  Lanes tangent_mass[2][2];
  std::array<Lane3, 2> rt_a, rt_b, ang_ta, ang_tb;
  Lane3 twist_a, twist_b;
  Lanes twist_mass;
  Lanes friction_impulse[2];
  Lanes twist_impulse;
  Lane3 total_friction_impulse;
  Lanes total_twist_impulse;
  std::array<WidePoint, 4> points;
  int count = 0;  // the most points of any lane
};

namespace {

void set_lane(Lane3& to, int lane, const Vec3& v) {
  to.x[lane] = v.x();
  to.y[lane] = v.y();
  to.z[lane] = v.z();
}
Vec3 get_lane(const Lane3& from, int lane) { return {from.x[lane], from.y[lane], from.z[lane]}; }

// Four vectors as lanes, built in registers. (Written lane by lane, a vector goes through memory, and
// loading it waits for its four scalar stores: that wait was the passes' largest cost.)
[[gnu::always_inline]] inline Lane3 gather(const Vec3& v0, const Vec3& v1, const Vec3& v2, const Vec3& v3) {
  return {Lanes{v0.x(), v1.x(), v2.x(), v3.x()}, Lanes{v0.y(), v1.y(), v2.y(), v3.y()},
          Lanes{v0.z(), v1.z(), v2.z(), v3.z()}};
}

const ContactPoint kNoPoint{};  // an empty point slot: no mass, no impulse

// Lane `lane` of w from constraint c: its first `slots` point slots (at least c.count; those past
// c.count get no mass and no impulse).
void pack(const ContactConstraint& c, std::span<const SolverBody> bodies, int lane, WideContact& w, int slots) {
  w.body_a[lane] = c.body_a;
  w.body_b[lane] = c.body_b;
  w.a_responds[lane] = c.a_responds ? -1 : 0;
  w.b_responds[lane] = c.b_responds ? -1 : 0;
  w.inverse_mass_a[lane] = bodies[c.body_a].inverse_mass;
  w.inverse_mass_b[lane] = bodies[c.body_b].inverse_mass;
  set_lane(w.normal, lane, c.normal);
  w.friction[lane] = c.friction;
  w.bias_rate[lane] = c.softness.bias_rate;
  w.mass_scale[lane] = c.softness.mass_scale;
  w.impulse_scale[lane] = c.softness.impulse_scale;
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) w.tangent_mass[i][j][lane] = c.tangent_mass(i, j);
    set_lane(w.tangents[i], lane, c.tangents[i]);
    set_lane(w.rt_a[i], lane, c.rt_a[i]);
    set_lane(w.rt_b[i], lane, c.rt_b[i]);
    set_lane(w.ang_ta[i], lane, c.ang_ta[i]);
    set_lane(w.ang_tb[i], lane, c.ang_tb[i]);
    w.friction_impulse[i][lane] = c.friction_impulse[i];
  }
  set_lane(w.twist_a, lane, c.twist_a);
  set_lane(w.twist_b, lane, c.twist_b);
  w.twist_mass[lane] = c.twist_mass;
  w.twist_impulse[lane] = c.twist_impulse;
  set_lane(w.total_friction_impulse, lane, c.total_friction_impulse);
  w.total_twist_impulse[lane] = c.total_twist_impulse;
  for (int k = 0; k < slots; ++k) {
    const ContactPoint& p = k < c.count ? c.points[k] : kNoPoint;
    WidePoint& q = w.points[k];
    q.adjusted_separation[lane] = p.adjusted_separation;
    set_lane(q.local_anchor_a, lane, p.local_anchor_a);
    set_lane(q.local_anchor_b, lane, p.local_anchor_b);
    set_lane(q.rn_a, lane, p.rn_a);
    set_lane(q.rn_b, lane, p.rn_b);
    set_lane(q.ang_a, lane, p.ang_a);
    set_lane(q.ang_b, lane, p.ang_b);
    q.normal_mass[lane] = p.normal_mass;
    q.normal_impulse[lane] = p.normal_impulse;
    q.lever_arm[lane] = p.lever_arm;
    q.approach_speed[lane] = p.approach_speed;
    q.max_normal_impulse[lane] = p.max_normal_impulse;
    q.total_normal_impulse[lane] = p.total_normal_impulse;
  }
  w.count = std::max(w.count, c.count);
}

// Lane `lane` of w back into constraint c: what the passes change.
void unpack(const WideContact& w, int lane, ContactConstraint& c) {
  for (int i = 0; i < 2; ++i) c.friction_impulse[i] = w.friction_impulse[i][lane];
  c.twist_impulse = w.twist_impulse[lane];
  c.total_friction_impulse = get_lane(w.total_friction_impulse, lane);
  c.total_twist_impulse = w.total_twist_impulse[lane];
  for (int k = 0; k < c.count; ++k) {
    const WidePoint& q = w.points[k];
    ContactPoint& p = c.points[k];
    p.normal_impulse = q.normal_impulse[lane];
    p.approach_speed = q.approach_speed[lane];
    p.max_normal_impulse = q.max_normal_impulse[lane];
    p.total_normal_impulse = q.total_normal_impulse[lane];
  }
}

// The velocities of the batch's bodies, lane by lane, for one pass (PairMotion of contact_solver.cpp
// four times over). Bodies without response get impulses times zero inverse mass and inertia, which
// leave them as they were, and are never written back.
struct WideMotion {
  Lane3 va, wa, vb, wb;

  [[gnu::always_inline]] WideMotion(const WideContact& w, std::span<const SolverBody> bodies) {
    const SolverBody& a0 = bodies[w.body_a[0]];
    const SolverBody& a1 = bodies[w.body_a[1]];
    const SolverBody& a2 = bodies[w.body_a[2]];
    const SolverBody& a3 = bodies[w.body_a[3]];
    const SolverBody& b0 = bodies[w.body_b[0]];
    const SolverBody& b1 = bodies[w.body_b[1]];
    const SolverBody& b2 = bodies[w.body_b[2]];
    const SolverBody& b3 = bodies[w.body_b[3]];
    va = gather(a0.linear_velocity, a1.linear_velocity, a2.linear_velocity, a3.linear_velocity);
    wa = gather(a0.angular_velocity, a1.angular_velocity, a2.angular_velocity, a3.angular_velocity);
    vb = gather(b0.linear_velocity, b1.linear_velocity, b2.linear_velocity, b3.linear_velocity);
    wb = gather(b0.angular_velocity, b1.angular_velocity, b2.angular_velocity, b3.angular_velocity);
  }

  [[gnu::always_inline]] void store(const WideContact& w, std::span<SolverBody> bodies) const {
    for (int l = 0; l < ContactBatches::kLanes; ++l) {
      if (w.a_responds[l] != 0) {
        bodies[w.body_a[l]].linear_velocity = get_lane(va, l);
        bodies[w.body_a[l]].angular_velocity = get_lane(wa, l);
      }
      if (w.b_responds[l] != 0) {
        bodies[w.body_b[l]].linear_velocity = get_lane(vb, l);
        bodies[w.body_b[l]].angular_velocity = get_lane(wb, l);
      }
    }
  }

  // Impulse l along d on B (-l d on A); ang_a, ang_b: I^-1 (r x d) of each body.
  [[gnu::always_inline]] void apply_row(const WideContact& w, const Lane3& d, const Lane3& ang_a, const Lane3& ang_b,
                                        const Lanes& l) {
    const Lanes la = w.inverse_mass_a * l;
    const Lanes lb = w.inverse_mass_b * l;
    va.x -= la * d.x;
    va.y -= la * d.y;
    va.z -= la * d.z;
    wa.x -= l * ang_a.x;
    wa.y -= l * ang_a.y;
    wa.z -= l * ang_a.z;
    vb.x += lb * d.x;
    vb.y += lb * d.y;
    vb.z += lb * d.z;
    wb.x += l * ang_b.x;
    wb.y += l * ang_b.y;
    wb.z += l * ang_b.z;
  }

  // d . (v_B - v_A) + r_b . w_B - r_a . w_A
  [[gnu::always_inline]] Lanes row_velocity(const Lane3& d, const Lane3& r_a, const Lane3& r_b) const {
    const Lanes dv = d.x * (vb.x - va.x) + d.y * (vb.y - va.y) + d.z * (vb.z - va.z);
    return dv + dot(r_b, wb) - dot(r_a, wa);
  }

  [[gnu::always_inline]] void apply_twist(const WideContact& w, const Lanes& t) {
    wa.x -= t * w.twist_a.x;
    wa.y -= t * w.twist_a.y;
    wa.z -= t * w.twist_a.z;
    wb.x += t * w.twist_b.x;
    wb.y += t * w.twist_b.y;
    wb.z += t * w.twist_b.z;
  }
};

// std::max / std::clamp lane by lane, with the same choice on ties.
#define SHATTER_LANE_MAX(a, b) ((a) < (b) ? (b) : (a))

[[gnu::always_inline]] inline void add_friction_total(WideContact& w, const Lanes& f0, const Lanes& f1) {
  w.total_friction_impulse.x += f0 * w.tangents[0].x + f1 * w.tangents[1].x;
  w.total_friction_impulse.y += f0 * w.tangents[0].y + f1 * w.tangents[1].y;
  w.total_friction_impulse.z += f0 * w.tangents[0].z + f1 * w.tangents[1].z;
}

// warm_start_contact on four constraints.
[[gnu::always_inline]] inline void warm_start_wide(WideContact& w, std::span<SolverBody> bodies) {
  WideMotion m(w, bodies);
  for (int k = 0; k < w.count; ++k) {
    WidePoint& p = w.points[k];
    m.apply_row(w, w.normal, p.ang_a, p.ang_b, p.normal_impulse);
    p.total_normal_impulse += p.normal_impulse;
  }
  m.apply_row(w, w.tangents[0], w.ang_ta[0], w.ang_tb[0], w.friction_impulse[0]);
  m.apply_row(w, w.tangents[1], w.ang_ta[1], w.ang_tb[1], w.friction_impulse[1]);
  m.apply_twist(w, w.twist_impulse);
  m.store(w, bodies);
  w.total_twist_impulse += w.twist_impulse;
  add_friction_total(w, w.friction_impulse[0], w.friction_impulse[1]);
}

// measure_approach on four constraints.
[[gnu::always_inline]] inline void measure_approach_wide(WideContact& w, std::span<const SolverBody> bodies) {
  const WideMotion m(w, bodies);
  for (int k = 0; k < w.count; ++k) {
    WidePoint& p = w.points[k];
    const Lanes approach = -m.row_velocity(w.normal, p.rn_a, p.rn_b);
    p.approach_speed = SHATTER_LANE_MAX(p.approach_speed, approach);
  }
}

struct PassArgs {
  double inverse_h;
  bool use_bias;
  double max_push_velocity;
};

// solve_contact on four constraints.
template <bool kAvx2>
[[gnu::always_inline]] inline void solve_wide(WideContact& w, std::span<SolverBody> bodies, const PassArgs& args) {
  WideMotion m(w, bodies);
  // The normal in each body's frame and the gap between the centres along it, lane by lane.
  std::array<Vec3, ContactBatches::kLanes> in_a, in_b;
  std::array<double, ContactBatches::kLanes> gaps;
  for (int l = 0; l < ContactBatches::kLanes; ++l) {
    const SolverBody& a = bodies[w.body_a[l]];
    const SolverBody& b = bodies[w.body_b[l]];
    const Vec3 n = get_lane(w.normal, l);
    in_a[l] = a.rotation.transpose() * n;
    in_b[l] = b.rotation.transpose() * n;
    gaps[l] = n.dot(b.position) - n.dot(a.position);
  }
  const Lane3 normal_in_a = gather(in_a[0], in_a[1], in_a[2], in_a[3]);
  const Lane3 normal_in_b = gather(in_b[0], in_b[1], in_b[2], in_b[3]);
  const Lanes centre_gap = {gaps[0], gaps[1], gaps[2], gaps[3]};
  const Lanes zero = Lanes{} * 0.0;
  const Lanes one = zero + 1.0;
  const Lanes inverse_h = zero + args.inverse_h;
  const Lanes min_push = zero - args.max_push_velocity;
  Lanes total_normal = zero;
  Lanes twist_limit = zero;
  for (int k = 0; k < w.count; ++k) {
    WidePoint& p = w.points[k];
    const Lanes s =
        p.adjusted_separation + centre_gap + (dot(normal_in_b, p.local_anchor_b) - dot(normal_in_a, p.local_anchor_a));
    // Speculative (a gap): close it within the substep, no more; else soft push-out (biased pass)
    // or nothing (relax).
    const LaneMask gap = s > zero;
    Lanes bias, mass_scale, impulse_scale;
    if (args.use_bias) {
      const Lanes push = w.mass_scale * w.bias_rate * s;
      bias = gap ? s * inverse_h : SHATTER_LANE_MAX(push, min_push);
      mass_scale = gap ? one : w.mass_scale;
      impulse_scale = gap ? zero : w.impulse_scale;
    } else {
      bias = gap ? s * inverse_h : zero;
      mass_scale = one;
      impulse_scale = zero;
    }
    const Lanes vn = m.row_velocity(w.normal, p.rn_a, p.rn_b);
    const Lanes delta = -p.normal_mass * (mass_scale * vn + bias) - impulse_scale * p.normal_impulse;
    const Lanes next = SHATTER_LANE_MAX(p.normal_impulse + delta, zero);
    const Lanes applied = next - p.normal_impulse;
    p.normal_impulse = next;
    p.max_normal_impulse = SHATTER_LANE_MAX(p.max_normal_impulse, next);
    p.total_normal_impulse += applied;
    m.apply_row(w, w.normal, p.ang_a, p.ang_b, applied);
    total_normal += p.normal_impulse;
    twist_limit += p.lever_arm * p.normal_impulse;
  }
  // Twist friction about the normal.
  {
    const Lanes spin = w.normal.x * (m.wb.x - m.wa.x) + w.normal.y * (m.wb.y - m.wa.y) + w.normal.z * (m.wb.z - m.wa.z);
    const Lanes limit = w.friction * twist_limit;
    const Lanes minus_limit = -limit;
    const Lanes raw = w.twist_impulse - w.twist_mass * spin;
    const Lanes next = raw < minus_limit ? minus_limit : (limit < raw ? limit : raw);  // std::clamp
    m.apply_twist(w, next - w.twist_impulse);
    w.total_twist_impulse += next - w.twist_impulse;
    w.twist_impulse = next;
  }
  // Coulomb friction at the centre, the tangent impulse clamped to the friction disc.
  {
    const Lanes vt0 = m.row_velocity(w.tangents[0], w.rt_a[0], w.rt_b[0]);
    const Lanes vt1 = m.row_velocity(w.tangents[1], w.rt_a[1], w.rt_b[1]);
    Lanes next0 = w.friction_impulse[0] - (w.tangent_mass[0][0] * vt0 + w.tangent_mass[0][1] * vt1);
    Lanes next1 = w.friction_impulse[1] - (w.tangent_mass[1][0] * vt0 + w.tangent_mass[1][1] * vt1);
    const Lanes limit = w.friction * total_normal;
    const Lanes squared = next0 * next0 + next1 * next1;
    const Lanes norm = lane_sqrt<kAvx2>(squared);
    const Lanes scale = norm > zero ? limit / norm : zero;  // lanes with norm 0 never use the quotient
    const LaneMask over = norm > limit;
    next0 = over ? next0 * scale : next0;
    next1 = over ? next1 * scale : next1;
    const Lanes delta0 = next0 - w.friction_impulse[0];
    const Lanes delta1 = next1 - w.friction_impulse[1];
    w.friction_impulse[0] = next0;
    w.friction_impulse[1] = next1;
    add_friction_total(w, delta0, delta1);
    m.apply_row(w, w.tangents[0], w.ang_ta[0], w.ang_tb[0], delta0);
    m.apply_row(w, w.tangents[1], w.ang_ta[1], w.ang_tb[1], delta1);
  }
  m.store(w, bodies);
}

#undef SHATTER_LANE_MAX

// Each pass twice: for AVX2, and for the baseline. Same source, same operations, same bits.
[[gnu::target("avx2")]] void warm_start_avx2(std::span<WideContact> batches, std::span<SolverBody> bodies) {
  for (WideContact& w : batches) warm_start_wide(w, bodies);
}
void warm_start_baseline(std::span<WideContact> batches, std::span<SolverBody> bodies) {
  for (WideContact& w : batches) warm_start_wide(w, bodies);
}
[[gnu::target("avx2")]] void measure_approach_avx2(std::span<WideContact> batches, std::span<const SolverBody> bodies) {
  for (WideContact& w : batches) measure_approach_wide(w, bodies);
}
void measure_approach_baseline(std::span<WideContact> batches, std::span<const SolverBody> bodies) {
  for (WideContact& w : batches) measure_approach_wide(w, bodies);
}
[[gnu::target("avx2")]] void solve_avx2(std::span<WideContact> batches, std::span<SolverBody> bodies,
                                        const PassArgs& args) {
  for (WideContact& w : batches) solve_wide<true>(w, bodies, args);
}
void solve_baseline(std::span<WideContact> batches, std::span<SolverBody> bodies, const PassArgs& args) {
  for (WideContact& w : batches) solve_wide<false>(w, bodies, args);
}

}  // namespace

ContactBatches::ContactBatches() = default;
ContactBatches::~ContactBatches() = default;
ContactBatches::ContactBatches(const ContactBatches&) = default;
ContactBatches::ContactBatches(ContactBatches&&) noexcept = default;
ContactBatches& ContactBatches::operator=(const ContactBatches&) = default;
ContactBatches& ContactBatches::operator=(ContactBatches&&) noexcept = default;

void ContactBatches::build(std::span<ContactConstraint* const> constraints, std::span<const SolverBody> bodies) {
  const std::size_t words = (bodies.size() + 63) / 64;
  used_.assign(kColours * words, 0);
  for (auto& c : colour_) c.clear();
  overflow_.clear();
  lanes_.clear();
  // A body is free in colour k when its bit is clear; bodies that take no impulses are free in all.
  auto free_in = [&](int k, Index body, bool responds) {
    return !responds || (used_[k * words + static_cast<std::size_t>(body) / 64] >> (body % 64) & 1U) == 0;
  };
  auto take = [&](int k, Index body, bool responds) {
    if (responds) used_[k * words + static_cast<std::size_t>(body) / 64] |= std::uint64_t{1} << (body % 64);
  };
  for (ContactConstraint* c : constraints) {
    int colour = -1;
    for (int k = 0; k < kColours && colour < 0; ++k)
      if (free_in(k, c->body_a, c->a_responds) && free_in(k, c->body_b, c->b_responds)) colour = k;
    if (colour < 0) {
      overflow_.push_back(c);
      continue;
    }
    take(colour, c->body_a, c->a_responds);
    take(colour, c->body_b, c->b_responds);
    colour_[colour].push_back(c);
  }
  std::size_t batches = 0;
  for (const auto& c : colour_) batches += (c.size() + kLanes - 1) / kLanes;
  wide_.assign(batches, WideContact{});
  sources_.assign(batches, {});
  batch_colour_.assign(batches, 0);
  std::size_t next = 0;
  for (int k = 0; k < kColours; ++k) {
    const auto& list = colour_[k];
    for (std::size_t first = 0; first < list.size(); first += kLanes, ++next) {
      WideContact& w = wide_[next];
      batch_colour_[next] = k;
      // Empty lanes read the first lane's bodies (never written: they do not respond there) and
      // carry zeros: no mass, no impulse.
      for (int l = 0; l < kLanes; ++l) {
        w.body_a[l] = list[first]->body_a;
        w.body_b[l] = list[first]->body_b;
      }
      for (int l = 0; l < kLanes && first + l < list.size(); ++l) {
        sources_[next][l] = list[first + l];
        pack(*list[first + l], bodies, l, w, list[first + l]->count);
      }
    }
  }
}

void ContactBatches::measure_approach(std::span<const SolverBody> bodies) {
  if (simd_isa() == SimdIsa::avx2)
    measure_approach_avx2(wide_, bodies);
  else
    measure_approach_baseline(wide_, bodies);
  for (ContactConstraint* c : overflow_) shatter::measure_approach(*c, bodies);
}

void ContactBatches::warm_start(std::span<SolverBody> bodies) {
  if (simd_isa() == SimdIsa::avx2)
    warm_start_avx2(wide_, bodies);
  else
    warm_start_baseline(wide_, bodies);
  for (ContactConstraint* c : overflow_) warm_start_contact(*c, bodies);
}

void ContactBatches::solve(std::span<SolverBody> bodies, double inverse_h, bool use_bias, double max_push_velocity) {
  const PassArgs args{inverse_h, use_bias, max_push_velocity};
  if (simd_isa() == SimdIsa::avx2)
    solve_avx2(wide_, bodies, args);
  else
    solve_baseline(wide_, bodies, args);
  for (ContactConstraint* c : overflow_) solve_contact(*c, bodies, inverse_h, use_bias, max_push_velocity);
}

std::size_t ContactBatches::lane_of(const ContactConstraint* c) {
  const auto by_address = [](const auto& x, const auto& y) { return std::less<>{}(x.first, y.first); };
  if (lanes_.empty() && !sources_.empty()) {
    for (std::size_t i = 0; i < sources_.size(); ++i)
      for (int l = 0; l < kLanes; ++l)
        if (sources_[i][l] != nullptr) lanes_.emplace_back(sources_[i][l], i * kLanes + l);
    std::sort(lanes_.begin(), lanes_.end(), by_address);
  }
  const auto it = std::lower_bound(lanes_.begin(), lanes_.end(), std::pair{c, std::size_t{0}}, by_address);
  return it != lanes_.end() && it->first == c ? it->second : static_cast<std::size_t>(-1);
}

void ContactBatches::pull(const ContactConstraint* c) {
  const std::size_t at = lane_of(c);
  if (at == static_cast<std::size_t>(-1)) return;  // solved one at a time, in place
  unpack(wide_[at / kLanes], static_cast<int>(at % kLanes), *sources_[at / kLanes][at % kLanes]);
}

void ContactBatches::reload(const ContactConstraint* c, std::span<const SolverBody> bodies) {
  const std::size_t at = lane_of(c);
  if (at == static_cast<std::size_t>(-1)) return;
  // Every point slot written: the lane may now have fewer points than it had.
  pack(*c, bodies, static_cast<int>(at % kLanes), wide_[at / kLanes],
       static_cast<int>(std::tuple_size_v<decltype(WideContact::points)>));
}

void ContactBatches::store() const {
  for (std::size_t i = 0; i < wide_.size(); ++i)
    for (int l = 0; l < kLanes; ++l)
      if (sources_[i][l] != nullptr) unpack(wide_[i], l, *sources_[i][l]);
}

}  // namespace shatter
