// Contact response: a soft-step solver after Box2D v3 and Box3D (Catto, "Solver2D", 2024;
// docs/method.md §2.8). Each step is split into substeps; per substep the bodies take gravity,
// each contact point records how fast it is closing (measure_approach, before any impulse of the
// substep), the contacts are warm-started with the impulses they carried, solved once with a soft
// position bias (a spring of `contact_hertz` and damping ratio `damping_ratio`, push-out capped at
// `max_push_velocity`), the positions are integrated, and the contacts are solved once more without
// bias (relax). After the substeps one restitution pass restores the bounce of contacts that
// approached faster than `restitution_threshold`. Contacts with a gap (speculative) remove only the
// approach that would close the gap within a substep, so nothing passes through at any speed the
// detection covers.
//
// Friction acts at the manifold's friction centre, not per point (as Box3D does): one 2D tangent
// impulse with its coupled 2x2 effective mass, bounded by mu times the manifold's total normal
// impulse, and one twist impulse about the normal bounded by mu times the sum of each point's normal
// impulse times its lever arm. Per-point friction solved point after point pushes a box sideways
// and turns it a little each pass; a tall stack then sways.
//
// The functions here work on flat arrays the world fills; the world owns the loop, and solves most
// constraints four at a time with the same formulas (contact_batches.h).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "shatter/core/types.h"

namespace shatter {

/// Soft constraint coefficients for one substep length (Box2D's b2Softness).
struct Softness {
  double bias_rate = 0;      ///< 1/s: bias velocity per metre of overlap
  double mass_scale = 1;     ///< scales the effective mass
  double impulse_scale = 0;  ///< fraction of the accumulated impulse relaxed away
};

/// Coefficients of a spring of `hertz` and `damping_ratio` integrated implicitly over `h` seconds.
/// hertz == 0 gives a rigid constraint with no bias.
Softness make_softness(double hertz, double damping_ratio, double h);

/// The velocity state of one body during a step.
struct SolverBody {
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s
  Vec3 angular_velocity = Vec3::Zero();  ///< world, rad/s
  double inverse_mass = 0;               ///< 1/kg (0: static or kinematic)
  Mat3 inverse_inertia = Mat3::Zero();   ///< world, at the start of the step, 1/(kg m^2)
  Vec3 position = Vec3::Zero();          ///< current centre of mass, m
  Mat3 rotation = Mat3::Identity();      ///< current orientation
};

/// One point of a contact constraint.
struct ContactPoint {
  /// World point at the start of the step, midway across the gap between the surfaces, m.
  Vec3 position = Vec3::Zero();
  double separation = 0;  ///< along the normal at the start of the step, m (< 0 overlap)
  // Set by prepare_contact from position and separation:
  Vec3 anchor_a = Vec3::Zero();  ///< position's world offset from A's centre of mass, m (the rows' lever arm)
  Vec3 anchor_b = Vec3::Zero();  ///< the same for B
  /// The point of A's surface, position - separation/2 normal, in A's frame at the step's start
  /// (static and kinematic bodies included), m. The solver follows the separation with the two
  /// surface points: position itself lies up to half a speculative gap off each body, and a
  /// spinning body would carry that point, not its surface.
  Vec3 local_anchor_a = Vec3::Zero();
  Vec3 local_anchor_b = Vec3::Zero();  ///< B's point, position + separation/2 normal, in B's frame
  /// separation - n . (on_B - on_A) at the start, from the surface points as stored (round-off):
  /// the separation now is n . (on_B - on_A) now plus this (Box2D's adjusted separation), m.
  double adjusted_separation = 0;
  double normal_mass = 0;  ///< effective mass along the normal, kg
  // The normal row's Jacobian and response, fixed over the step (the anchors and the world inverse
  // inertias are): v_n = n . (v_B - v_A) + rn_b . w_B - rn_a . w_A, and an impulse l n turns
  // A by -l ang_a and B by +l ang_b.
  Vec3 rn_a = Vec3::Zero();   ///< anchor_a x normal, m
  Vec3 rn_b = Vec3::Zero();   ///< anchor_b x normal, m
  Vec3 ang_a = Vec3::Zero();  ///< I_A^-1 rn_a, 1/(kg m)
  Vec3 ang_b = Vec3::Zero();  ///< I_B^-1 rn_b, 1/(kg m)
  double normal_impulse = 0;  ///< accumulated (warm start), N s
  double lever_arm = 0;       ///< distance to the friction centre, m (twist bound)
  /// Fastest approach (minus the relative normal velocity, m/s, > 0 approaching) met at the start
  /// of the step or of any of its substeps (measure_approach): the impact speed.
  double approach_speed = 0;
  double max_normal_impulse = 0;  ///< largest accumulated normal impulse in the step, N s
  /// Everything applied along the normal during the step, over all substeps and passes (warm
  /// starts included), N s.
  double total_normal_impulse = 0;
  std::uint32_t feature = 0;  ///< feature pair id (warm-start matching)
};

/// One manifold as the solver sees it: bodies, one normal from A to B, up to 4 points.
struct ContactConstraint {
  Index body_a = -1;  ///< solver body index (the static body slot for static shapes)
  Index body_b = -1;
  Vec3 normal = Vec3::UnitY();                                 ///< world, from A to B
  std::array<Vec3, 2> tangents{Vec3::UnitX(), Vec3::UnitZ()};  ///< orthonormal with the normal
  double friction = 0.6;                                       ///< Coulomb coefficient (static = dynamic)
  double restitution = 0;                                      ///< coefficient of restitution
  Softness softness;  ///< from the world's contact spring (stiffer with static bodies)
  /// Whether impulses change A's (B's) velocity: false for a body with zero inverse mass and
  /// inertia (static, kinematic, asleep), which the solver then never writes (prepare_contact).
  bool a_responds = true;
  bool b_responds = true;
  std::array<ContactPoint, 4> points{};
  int count = 0;
  // Friction at the friction centre (the points' mean, gaps weighted down).
  Vec3 centre_a = Vec3::Zero();                            ///< world offset from A's centre of mass, m
  Vec3 centre_b = Vec3::Zero();                            ///< the same for B
  Eigen::Matrix2d tangent_mass = Eigen::Matrix2d::Zero();  ///< inverse of the 2x2 tangent K, kg
  std::array<Vec3, 2> rt_a{};    ///< centre_a x tangent k, m (the tangent rows' Jacobians, as rn_a)
  std::array<Vec3, 2> rt_b{};    ///< centre_b x tangent k, m
  std::array<Vec3, 2> ang_ta{};  ///< I_A^-1 rt_a[k]
  std::array<Vec3, 2> ang_tb{};  ///< I_B^-1 rt_b[k]
  Vec3 twist_a = Vec3::Zero();   ///< I_A^-1 normal (the twist row's response)
  Vec3 twist_b = Vec3::Zero();   ///< I_B^-1 normal
  double twist_mass = 0;         ///< about the normal, kg m^2
  Eigen::Vector2d friction_impulse = Eigen::Vector2d::Zero();  ///< accumulated, along the tangents, N s
  double twist_impulse = 0;                                    ///< accumulated, about the normal, N m s
  /// Friction applied on B during the step, over all substeps and passes, world, N s.
  Vec3 total_friction_impulse = Vec3::Zero();
  /// Twist applied on B about the normal during the step, N m s (A takes the opposite).
  double total_twist_impulse = 0;
};

/// Settings of the solver.
struct ContactSolverSettings {
  double contact_hertz = 30;         ///< contact spring, Hz (capped at an eighth of the substep rate)
  double damping_ratio = 10;         ///< contact spring damping ratio (over-damped: no bounce from the push-out)
  double max_push_velocity = 3;      ///< largest push-out speed, m/s
  double restitution_threshold = 1;  ///< approach speed below which contacts do not bounce, m/s
  /// Shock propagation: a body at least this many times heavier than a body it presses into that
  /// body's support (something that does not move: static, kinematic or asleep) is stopped by it as
  /// by a wall (push_off_supported, after each pass, with the friction of that push). 0: off. A
  /// block 10 to 100 times heavier than a piece on the ground, landing on it at 1 to 5 m/s, drives
  /// it at most 0.39 mm into the ground, against up to 38 mm without (the piece is 4 cm thick).
  double shock_mass_ratio = 4;
  /// A body pressed into its support (a static, kinematic or sleeping body) by a dynamic body at
  /// least this many times heavier meets that support with the softer spring of contacts between
  /// dynamic bodies. Under the stiff spring one Gauss-Seidel pass leaves the light body's contacts
  /// unconverged and the pair rocks: a 10 cm box three times as dense as the box under it rocked
  /// at 29 mm/s and 0.3 rad/s for as long as it stayed awake (docs/method.md, "Heavy on light").
  /// 0: off.
  double pressed_mass_ratio = 1.5;
  /// Relax passes per substep beyond the one every body takes, at most, for the bodies of an
  /// island (bodies joined by contacts) where a dynamic body presses a dynamic body into its
  /// support and is at least twice shock_mass_ratio times heavier: one there, and one more each
  /// time the ratio doubles (off with shock propagation). A pass of Gauss-Seidel moves momentum
  /// slowly across such a contact: a 10 cm box 20 times as dense as the box under it rocked at up to
  /// 24 mm/s with the one pass, 8.9 with two more, and stacks of 50 and 100 times never fell asleep
  /// (docs/method.md, "Heavy on light"). 0: none.
  int mass_ratio_relax_passes = 3;
  /// A dynamic body at least this many times heavier than the other body of a contact is met as a
  /// wall: the contact takes the stiffer spring of contacts with static and kinematic bodies (twice
  /// the hertz, half the damping). For scenes with heavy spinning machinery: a piece swept along
  /// by a rotor 50 times its density goes into it half as far (docs/method.md, "No tunnelling").
  /// Off (0) by default: a heavy box resting on a light one creeps more with it (median 16 → 19
  /// mm in 10 s over 24 stacks of 3 to 100 times the mass).
  double wall_mass_ratio = 0;
};

/// Fill the constraint's derived data once per step, from points whose position and separation
/// the caller set: anchors, tangents, friction centre, effective masses, approach speeds. Keeps
/// the warm-start impulses the caller put in and zeroes the step totals. `speculative_distance`
/// (m) fades points with a gap out of the friction centre.
void prepare_contact(ContactConstraint& c, std::span<const SolverBody> bodies, double speculative_distance);

/// Shock propagation (Guendelman, Bridson and Fedkiw 2003) for a heavy body pressing a light one
/// into what supports it: the supported body (A when `supported_is_a`, else B) is taken as
/// immovable, and only the other body's velocity changes, so that no point approaches: a point
/// with a gap may close it within the substep; an overlapping one, with `use_bias`, separates at
/// the push-out speed of the soft contact (capped at max_push_velocity), else at zero. One
/// Gauss-Seidel pass moves momentum through a light body only in proportion to its share of the
/// mass: a 14 kg block landing at 3 m/s on a 1.4 kg piece on the ground drove it 6 mm into the
/// ground, a 41 kg one 29 mm (docs/method.md, "No tunnelling"). The pushes at points off the
/// friction centre turn the body, which slides its face: the sliding they leave there is taken out
/// again within the friction cone of the pushed impulse (without it, a box 3 to 100 times heavier
/// than the box it rests on crept 32 mm in 10 s, median of 24 stacks, and 4 of them fell off:
/// World.AHeavyBoxRestsOnALightOne).
/// The impulses are not accumulated: nothing warm-starts from them, and the step's totals for
/// impacts do not count them.
void push_off_supported(const ContactConstraint& c, std::span<SolverBody> bodies, bool supported_is_a, double inverse_h,
                        bool use_bias, double max_push_velocity);

/// Raise each point's approach speed to the closing speed of the bodies' velocities now (reads
/// them only). Called at each substep's start, before any of its impulses: the velocities are then
/// the last substep's relaxed ones plus gravity. Measured during the biased pass instead, the
/// approach would include the push-out that the pass gives overlapping pieces (up to the push-out
/// cap at the next contact of a pushed body), which the relax pass takes out again. A resting
/// contact reads the substep's gravity, g h (0.02 m/s at 8 substeps of 1/60 s): far below the
/// default restitution and impact thresholds (1 m/s); thresholds below it would make resting
/// bodies with restitution bounce.
void measure_approach(ContactConstraint& c, std::span<const SolverBody> bodies);

/// Apply the accumulated impulses (warm start), adding them to the step totals.
void warm_start_contact(ContactConstraint& c, std::span<SolverBody> bodies);

/// One pass over the constraint: normals, twist, then friction. `use_bias`: push out overlap
/// softly (the substep's first pass); otherwise only speculative gaps are honoured (relax).
void solve_contact(ContactConstraint& c, std::span<SolverBody> bodies, double inverse_h, bool use_bias,
                   double max_push_velocity);

/// After the substeps: restore the normal velocity -e v0 where the approach was faster than the
/// threshold and the contact carried load.
void apply_restitution(ContactConstraint& c, std::span<SolverBody> bodies, double threshold);

/// Two unit tangents completing unit n to a right-handed frame, continuous in n except at n.z = -1
/// (Duff et al. 2017, "Building an orthonormal basis, revisited").
std::array<Vec3, 2> tangent_basis(const Vec3& n);

}  // namespace shatter
