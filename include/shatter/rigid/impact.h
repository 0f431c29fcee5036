// Impact analysis (docs/method.md §2.7.1, docs/impacts.md): what one collision does to a body.
// Given the body (model and state) and the contacts of one impact as any rigid-body engine
// reports them (points, normals, impulses summed over the step, approach speeds), it
//   1. turns the impulse into a static load with Hertz's contact time (never the engine's step),
//   2. spreads the load over the surface nodes of each contact patch,
//   3. holds the body as the paper does (every tet beyond r_coll anchored) or by inertia relief,
//   4. solves the static equilibrium, and from its stresses
//   5. lets the rest shape absorb plastic deformation (dents) and cracks the body (fracture/),
//   6. returns the pieces as child bodies with exact mass properties that carry the parent's
//      motion (eq. 22), their crack faces marked.
// It knows nothing of the world: World calls it at each impact event, and any engine can.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/material.h"
#include "shatter/fracture/fracture.h"
#include "shatter/rigid/body.h"
#include "shatter/solve/static_solver.h"

namespace shatter {

/// One contact point of an impact, in world coordinates.
struct ImpactContact {
  Vec3 point = Vec3::Zero();    ///< contact point, m
  Vec3 normal = Vec3::UnitY();  ///< unit direction of the push on this body (into it)
  /// Normal impulse the body received here, N s (>= 0), summed over every substep and solver
  /// pass of the step (not the last pass's value).
  double normal_impulse = 0;
  double approach_speed = 0;  ///< closing speed along the normal before the solve, m/s
};

/// How the body is held for the static solve.
enum class ImpactHold : std::uint8_t {
  /// The paper: every tet whose centroid is farther than r_coll from all loaded contacts is held
  /// in place; the held far field stands in for the body's inertia. Where that is less than a
  /// twentieth of the tets (contacts along most of a long piece), inertia relief instead.
  anchor_far,
  /// Inertia relief (as in structural FEA codes): body forces -m_i (a + alpha x r_i) balance the
  /// load, and three far nodes are held against drift; their reactions are near zero.
  inertia_relief,
};

/// "anchor-far", "inertia-relief".
const char* to_string(ImpactHold hold);

/// The static solver's defaults with the warm start off (see ImpactSettings::solver).
StaticSolverOptions default_impact_solver_options();

/// The fracture defaults with branching cracks (see ImpactSettings::fracture).
FractureOptions default_impact_fracture_options();

/// Settings of analyze_impact.
struct ImpactSettings {
  /// Impacts slower than this (the largest approach speed of the contacts), m/s, are not
  /// analysed: resting and sliding contact never dents or breaks a body.
  double min_approach_speed = 1.0;
  ImpactHold hold = ImpactHold::anchor_far;
  /// r_coll = collision_radius x the body's radius (largest distance of a node from the centre
  /// of mass). When no tet lies beyond it, the tets beyond 80 % of the farthest centroid distance
  /// from the loads are held instead.
  double collision_radius = 0.5;
  /// Hertz's radius of curvature R = curvature_radius x the body's radius: by default the body
  /// meets the obstacle as a sphere of its own size would. (A smaller R means a softer, longer
  /// contact: the force grows as R^(1/5).)
  double curvature_radius = 1.0;
  /// Elastic constants of what the body hit, for Hertz's effective modulus; empty: the same
  /// material as the body's. Infinite E: a rigid obstacle.
  std::optional<Material> other_material;
  /// The load of a contact is spread over the surface vertices within max(Hertz contact radius,
  /// patch_edges x the local edge length, min_patch_radius x the body's radius) of it whose
  /// outward normal n satisfies n . push <= patch_facing (those not facing away from the push).
  /// A load on one node is a singularity whose stress grows with refinement; the floor in body
  /// units keeps the load, and so the break decision, from changing once the mesh is finer than it.
  double patch_edges = 1.0;
  double min_patch_radius = 0.1;
  double patch_facing = 0.25;
  /// Where the body or what it hit yields (a finite Material::yield_stress), the contact carries
  /// a mean pressure of at most hardness_factor x the smaller yield stress: Tabor's hardness of a
  /// fully plastic indentation, about 2.8-3 Y (Johnson, Contact Mechanics §6.2). Past it the
  /// contact follows Thornton's elastic-plastic law (elastic_plastic_impact), and the load is
  /// lowered by the ratio of its peak force to Hertz's for the same energy: a clay body landing
  /// spends the energy in flow over a wider patch instead of pressing harder. 0: Hertz alone.
  double hardness_factor = 2.8;
  /// The Hertz contact time is kept within [min_contact_time, max_contact_time], s.
  double min_contact_time = 1e-5;
  double max_contact_time = 0.05;
  /// Coefficient of restitution of the collision: the impulse J = (1 + e) m_eff v gives the
  /// effective mass.
  double restitution = 0;
  /// Fracture and plasticity (the accumulated plastic strain comes from the state). Cracks branch
  /// by default (CrackOptions::branch): a brittle body breaks into several pieces near the blow;
  /// and yielded tets' stresses are returned to the yield surface for the tensile criterion
  /// (CrackOptions::return_to_yield): ductile bodies dent, and tear only by plastic strain.
  FractureOptions fracture = default_impact_fracture_options();
  /// The static solve. Its stiffness goes by the body's model (TangentKind::by_model: projected
  /// for StVK, exact and projected on demand for the corotated and linear models). Its PCG warm
  /// start is off by default, so that an event's outcome depends
  /// only on the body and its contacts, not on the solver's history (replays and restored
  /// snapshots give the same bits); the pattern and symbolic analysis are reused either way.
  /// Newton iterations per load step, load halvings and Newton iterations in all are capped (12, 3
  /// and 60) to bound an impact's time: a solve that does not converge goes on with the fraction
  /// of the load it reached.
  StaticSolverOptions solver = default_impact_solver_options();
  /// Children lighter than this fraction of the parent's mass, or than min_fragment_mass (kg), are
  /// removed as debris (their mass is reported), and at most max_fragments children are kept, the
  /// heaviest.
  double min_fragment_fraction = 2e-3;
  double min_fragment_mass = 0;
  int max_fragments = 32;
};

/// A body that an impact made: the only child of a dented or cracked but whole body, or one
/// fragment of a broken one.
struct ImpactChild {
  std::shared_ptr<BodyModel> model;      ///< body frame centred on the child's centre of mass
  RigidState rigid;                      ///< pose (the parent's orientation) and eq. 22 velocities
  std::vector<double> plastic_strain;    ///< per child tet
  std::vector<double> tensile_strength;  ///< per child tet, Pa (empty when the parent's was)
  std::vector<Index> parent_tet;         ///< the parent's tet each child tet lies in (#tets)
  /// Per child tet, its parent tet when the cut and plasticity left it as it was (its corners are
  /// the parent's, bitwise), else -1 (#tets; empty: not known, and World rebuilds every hull).
  std::vector<Index> unchanged_parent_tet;
  /// Origin of the child's body frame in the parent's body frame, m: a node at x in the child's
  /// frame lay at x + origin in the parent's (x is the parent's position less origin, bitwise, for
  /// a node that neither the cut nor plasticity moved).
  Vec3 origin = Vec3::Zero();
};

/// What analyze_impact found and did.
struct ImpactResult {
  /// False when the contacts carry no impulse or are slower than min_approach_speed: nothing was
  /// solved and the body is unchanged.
  bool analysed = false;
  double approach_speed = 0;  ///< largest approach speed of the loaded contacts, m/s
  double impulse = 0;         ///< total normal impulse, N s
  double effective_mass = 0;  ///< impulse / ((1 + e) v), kg
  double contact_time = 0;    ///< Hertz contact time (clamped), s
  /// Mean contact pressure the contact yields at (ImpactSettings::hardness_factor), Pa; +inf when
  /// neither side yields.
  double limit_pressure = kInfinity;
  /// Peak force of the yielding contact over Hertz's, for the impact's energy (1: elastic); the
  /// load is Hertz's times this.
  double yield_scale = 1;
  double force = 0;                 ///< total static load, N (the peak of the impact)
  double patch_radius = 0;          ///< radius the load of each contact is spread over, m
  double collision_radius = 0;      ///< r_coll, m (0 when held by inertia relief)
  Vec3 load_point = Vec3::Zero();   ///< impulse-weighted contact point, world, m
  Index loaded_nodes = 0;           ///< nodes carrying load
  Index held_nodes = 0;             ///< nodes held
  StaticReport solve;               ///< the static solve
  double max_principal_stress = 0;  ///< largest principal stress over the tets, Pa
  double max_von_mises = 0;         ///< largest von Mises stress, Pa
  /// Signed display stress of each parent tet under the load (TetStress::display, Pa, #tets):
  /// tension positive, for the stress view (empty when nothing was solved).
  std::vector<double> display_stress;
  /// Largest principal stress of each parent tet under the load (TetStress::principal[0], Pa,
  /// #tets; empty when nothing was solved).
  std::vector<double> principal_stress;
  bool dented = false;             ///< plasticity changed the rest shape
  std::vector<CrackEvent> cracks;  ///< cracks cut, in order
  /// Empty: the body is unchanged (maybe with more plastic strain, see plastic_strain). One: the
  /// body goes on with a new model (dented or cracked but whole). More: it broke into these.
  std::vector<ImpactChild> children;
  std::vector<double> plastic_strain;  ///< per parent tet after the event (when children is empty)
  Index debris_count = 0;              ///< fragments removed by the debris rules
  double debris_mass = 0;              ///< their mass, kg
  double solve_ms = 0;                 ///< static solve, ms
  double fracture_ms = 0;              ///< stresses, plasticity, cracks and children, ms
};

/// The impact analysis of one body (see the file comment). `state.rigid` is the body's motion
/// after the collision response (its children inherit it); contacts are world quantities of this
/// body only. Reuses and fills state.solver. Errors: sizes of the state that do not match the
/// model, non-finite contacts.
Result<ImpactResult> analyze_impact(const BodyModel& model, BodyState& state, std::span<const ImpactContact> contacts,
                                    const ImpactSettings& settings = {});

/// Cut a body along a plane through it (the viewer's slice tool, a saw): every tet the plane
/// crosses is split along it, and the pieces become children as after a crack (exact mass, eq. 22
/// motion, crack faces flagged, the debris rules of `settings`). The result holds one CrackEvent
/// and no solve; no children when the plane misses the body. `point` and `normal` are world.
/// Errors: a non-finite point or normal, a zero normal, a state that does not fit the model.
Result<ImpactResult> slice_body(const BodyModel& model, const BodyState& state, const Vec3& point, const Vec3& normal,
                                const ImpactSettings& settings = {});

/// A force pressed on a body's surface (the paper's tools: a press, a held force field), world.
struct SurfaceLoad {
  Vec3 point = Vec3::Zero();  ///< where it acts, m
  Vec3 force = Vec3::Zero();  ///< total force, N (its direction pushes into the body)
  double radius = 0;          ///< spread over at least this radius, m (0: the patch rule alone)
};

/// The same analysis for given forces instead of an impact: steps 2-6 of the file comment with
/// each force spread over its patch. A body pressed slowly is analysed with the force it feels
/// (no speed threshold). Errors as analyze_impact's, and non-finite loads or negative radii.
Result<ImpactResult> analyze_load(const BodyModel& model, BodyState& state, std::span<const SurfaceLoad> loads,
                                  const ImpactSettings& settings = {});

/// Hertz's effective modulus 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2, Pa (E2 = +inf: rigid).
double hertz_effective_modulus(const Material& a, const Material& b);

/// Hertz's impact of a sphere of radius R and mass m at speed v on a half-space (Johnson,
/// Contact Mechanics, §11.4): the largest approach delta = (15 m v^2 / (16 E* sqrt R))^(2/5), the
/// contact time 2.94 delta / v and the contact radius sqrt(R delta).
struct HertzImpact {
  double max_approach = 0;    ///< delta, m
  double contact_time = 0;    ///< s
  double contact_radius = 0;  ///< m
  double peak_force = 0;      ///< 4/3 E* sqrt(R) delta^(3/2), N
};
HertzImpact hertz_impact(double effective_mass, double speed, double radius, double effective_modulus);

/// Thornton's elastic-perfectly-plastic impact of the same sphere (C. Thornton, J. Appl. Mech. 64,
/// 1997): Hertz's law F = 4/3 E* sqrt(R) delta^(3/2) until the peak pressure 2 E* a / (pi R)
/// reaches the limit pressure p_y, at delta_y = R (pi p_y / (2 E*))^2; then
/// F = F_y + pi p_y R (delta - delta_y), so the mean pressure tends to p_y. The largest approach is
/// where the work of F equals the kinetic energy m v^2 / 2. With p_y = +inf (or never reached) it
/// is hertz_impact's delta and peak force.
struct ElasticPlasticImpact {
  double max_approach = 0;    ///< delta, m
  double yield_approach = 0;  ///< delta_y, m (+inf when p_y is)
  double contact_radius = 0;  ///< sqrt(R delta), m
  double peak_force = 0;      ///< F(delta), N
  bool yielded = false;       ///< delta > delta_y
};
ElasticPlasticImpact elastic_plastic_impact(double effective_mass, double speed, double radius,
                                            double effective_modulus, double limit_pressure);

}  // namespace shatter
