// The world: bodies, their contacts and the fixed step that moves them (docs/method.md §2.7-2.8).
// Between impacts every body is rigid. A step of `time_step` seconds is split into `substeps`:
// each substep applies gravity, solves the contacts softly, moves the bodies and relaxes (see
// rigid/contact_solver.h); a restitution pass ends the step. Collisions are found with the paper's
// uniform grid over body boxes, then per pair either between the bodies' convex pieces (hulls of
// clusters of their own tets, the default) or, in the paper's mode, vertices against tets.
//
// Bodies are dynamic (a tet mesh with a material: mass and inertia exact from the tets), kinematic
// (moved by the user at a set velocity) or static (planes, hulls, tet meshes). Bodies that stay
// still for a while fall asleep by islands and cost nothing until touched, pushed or woken.
//
// Results are the same on any thread count: pairs come sorted from the broad phase, the narrow
// phase writes per pair, and the solver runs in a fixed order. save() / restore() copy the whole
// changing state (poses, velocities, sleep, contact caches, exclusions); state_hash() digests it.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <vector>

#include "shatter/collide/broad_phase.h"
#include "shatter/collide/contact.h"
#include "shatter/collide/convex_decomposition.h"
#include "shatter/collide/convex_hull.h"
#include "shatter/collide/tet_contact.h"
#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/rigid/body.h"
#include "shatter/rigid/contact_batches.h"
#include "shatter/rigid/contact_solver.h"
#include "shatter/rigid/impact.h"
#include "shatter/rigid/integrate.h"
#include "shatter/solve/dynamic_solver.h"

namespace shatter {

/// A body of a world: its slot and which body has held that slot. Slots are never renumbered; a
/// slot is given to a new body only after restore() went back to before its body was made, and
/// the generation then tells the two apart, so a stale id is caught (World::valid).
struct BodyId {
  Index index = -1;              ///< slot in the world
  std::uint32_t generation = 0;  ///< bodies that held the slot before this one
  friend bool operator==(const BodyId&, const BodyId&) = default;
  friend auto operator<=>(const BodyId&, const BodyId&) = default;
};

/// How a body moves.
enum class BodyType : std::uint8_t {
  static_body,  ///< never moves (infinite mass)
  kinematic,    ///< moves at the velocity the user sets (infinite mass)
  dynamic,      ///< moved by gravity and contacts
};

/// Which narrow phase tet bodies use with each other.
enum class ContactMode : std::uint8_t {
  convex_pieces,  ///< hulls of clusters of the body's tets, separating-axis manifolds (default)
  tet_vertices,   ///< the paper: vertices in tets, plus boundary edges through boundary triangles
};

/// Collision filtering: bodies a and b may touch when (a.group & b.mask) and (b.group & a.mask).
struct CollisionFilter {
  std::uint32_t group = 1;           ///< bits this body belongs to
  std::uint32_t mask = 0xffffffffU;  ///< bits it collides with
};

/// Surface properties. A pair uses the geometric mean of the frictions (Box2D's rule) and the
/// larger restitution.
struct SurfaceMaterial {
  double friction = 0.6;     ///< Coulomb coefficient, >= 0
  double restitution = 0.0;  ///< coefficient of restitution, 0..1
};

/// Full FEM dynamics for one body (docs/dynamics.md): its nodes move by implicit Euler (the paper's
/// eq. 18-20) instead of rigidly, so it bends, squashes and rings. For soft or small bodies; impacts
/// neither dent nor break it. Ground, static and kinematic bodies push its nodes (penalty contact
/// with friction); with other dynamic bodies it exchanges impulses through the contact solver, where
/// it takes part as a rigid body of its own mass at its best-fit pose (docs/dynamics.md, "In a
/// world").
struct DeformableSettings {
  double mass_damping = 0;         ///< Rayleigh alpha, 1/s (also slows free flight)
  double stiffness_damping = 0;    ///< Rayleigh beta, s
  double contact_stiffness = 1e4;  ///< penalty of its node contacts (DynamicSolverOptions::contact_stiffness)
  int max_newton_iterations = 50;  ///< per step
  /// FEM steps per world step. Implicit Euler damps what it cannot resolve: a rubber ball landing
  /// in a contact shorter than the step does not bounce; more substeps let it (docs/dynamics.md).
  int substeps = 1;
};

/// Everything to create a body besides its shape.
struct BodyDef {
  BodyType type = BodyType::dynamic;
  RigidState rigid;  ///< pose and velocities (static bodies ignore the velocities)
  SurfaceMaterial surface;
  CollisionFilter filter;
  bool can_sleep = true;
  bool awake = true;  ///< start awake (false: asleep until touched)
  /// Impacts dent and break this body (dynamic tet bodies only); false: it stays as it is.
  bool breakable = true;
  /// Impact settings of this body (and of the fragments it breaks into); null: the world's.
  std::shared_ptr<const ImpactSettings> impact;
  /// Simulate this dynamic tet body with full FEM dynamics (not breakable then); empty: rigid
  /// between impacts, the paper's hybrid scheme.
  std::optional<DeformableSettings> deformable;
};

/// Settings of a world.
struct WorldSettings {
  double time_step = 1.0 / 60.0;  ///< fixed step, s
  /// Solver substeps per step. 8 (Box2D and Box3D use 4) because the contact spring can be at most
  /// an eighth of the substep rate, and a stack's sag under its own weight is g / (2 pi f)^2 per
  /// level: 8 substeps allow 60 Hz, a tenth of a millimetre per level of 0.5 m boxes (docs/performance.md).
  int substeps = 8;
  Vec3 gravity{0, -9.81, 0};                           ///< m/s^2 (Y up)
  ContactSolverSettings contact{.contact_hertz = 60};  ///< contact spring, push-out cap, restitution threshold
  ContactMode contact_mode = ContactMode::convex_pieces;
  DecompositionOptions decomposition;  ///< convex pieces of tet bodies
  /// Contacts are made for gaps up to this plus the distance the pair can close within a step, m.
  double speculative_distance = 0.004;
  /// Speed limits of dynamic rigid bodies, enforced every substep after gravity and again after
  /// the contact solve, before the positions move (Jolt's 500 m/s; PhysX's 100 rad/s). Past them
  /// the contacts, found once per step, cannot hold a body: a small piece driven by a large tool
  /// force, or spinning through most of a turn within a step, would pass through the ground. The
  /// velocities at the end of a step (after the relax and restitution passes) may exceed them;
  /// the next substep scales them back. m/s, > 0 (infinity: no limit).
  double max_linear_speed = 500;
  /// Largest rotation of a dynamic rigid body in one step, rad, > 0: a quarter turn, 94 rad/s at
  /// 1/60 s. A body turning further within a step brings points into contact that the step's
  /// manifolds, found at its start, do not hold (docs/method.md, "No tunnelling").
  double max_rotation = 0.5 * std::numbers::pi;
  /// A pair whose bodies moved less than this relative to each other since its contacts were found
  /// keeps them, moved with the bodies, instead of colliding its shapes again (Jolt's body-pair
  /// cache), m. Contacts are then made for gaps this much wider, so that none is missed meanwhile.
  /// 0: collide every awake pair every step.
  double contact_reuse_distance = 0.001;
  bool enable_sleep = true;
  double time_to_sleep = 0.5;    ///< s a whole island must stay slow before it sleeps
  double sleep_velocity = 0.01;  ///< m/s: |v| + |w| r below this counts as slow
  /// Smallest number of body pairs for a parallel narrow phase, and of moving bodies for a
  /// parallel integration: a parallel region only pays for a few hundred microseconds of work.
  /// Results do not depend on them (nor on the thread count).
  std::int64_t parallel_min_pairs = 512;
  std::int64_t parallel_min_bodies = 2048;
  /// The contact solve steps groups of islands (bodies joined by contacts) through all substeps
  /// side by side, a group on one thread: groups of at least this many moving bodies, an island
  /// never split. Results do not depend on it.
  std::int64_t solve_group_bodies = 64;
  /// The broad phase's grid runs on each body's box grown by this fraction of its largest extent,
  /// and the pairs it finds serve, filtered by the boxes of the step, until some box leaves its
  /// grown box: bodies at rest skip the grid. Results do not depend on it.
  double broad_phase_growth = 0.05;
  /// Impact events (docs/impacts.md): a pair of bodies whose contacts first carry an impulse at an
  /// approach speed of at least impact.min_approach_speed opens an event, which stays open until
  /// the pair no longer touches. Each breakable body of a new event is analysed once
  /// (analyze_impact) at the end of the step, and goes on dented, or is replaced by its fragments.
  bool enable_impacts = true;
  ImpactSettings impact;  ///< for bodies without their own
  /// What planes, boxes and hulls are made of, for Hertz's effective modulus (stone).
  Material obstacle_material{.name = "stone",
                             .youngs_modulus = 30e9,
                             .poisson_ratio = 0.2,
                             .density = 2500,
                             .tensile_strength = kInfinity,
                             .yield_stress = kInfinity,
                             .fracture_toughness = kInfinity};
  /// Debris: in a world, ImpactSettings::min_fragment_fraction is taken of the mass of the body
  /// the user added (not of the piece that breaks again), so repeated chipping stops at a size.
  /// Budget of the world: once it holds this many bodies (removed ones included, as ids
  /// are never reused), impacts still dent bodies but no longer crack them.
  Index max_bodies = 4096;
  /// Seed of the world's random draws: the per-tet tensile strengths of bodies whose material has a
  /// Weibull modulus (sample_tensile_strengths), drawn for the n-th body added from seed and n. The
  /// same seed gives the same world; another seed, other flaws and other cracks.
  std::uint64_t seed = 0;
};

/// One impact analysis of one body (a row of StepEvents::impacts).
struct ImpactRecord {
  BodyId body;                ///< the body analysed
  BodyId other;               ///< the body it hit (the lowest slot when several events opened at once)
  double time = 0;            ///< end of the step, s
  Vec3 point = Vec3::Zero();  ///< impulse-weighted contact point, world, m
  double approach_speed = 0;  ///< m/s
  double impulse = 0;         ///< N s
  double contact_time = 0;    ///< s
  double force = 0;           ///< static load, N
  /// The load over the elastic (Hertz) load: below 1 where the contact yields (ImpactResult)
  double yield_scale = 1;
  /// r_coll, m: with the anchor-far hold, every node farther than this from the load was held
  /// (0 for inertia relief and slices)
  double collision_radius = 0;
  double max_principal_stress = 0;  ///< Pa
  double max_von_mises = 0;         ///< Pa
  bool converged = false;           ///< the static solve converged
  /// Fraction of the load the returned equilibrium carries (1 when converged; less when Newton
  /// could not follow the whole load, docs/impacts.md "Limits"): stresses, dents and cracks come
  /// from that equilibrium. 0 when not even the smallest load step converged: the body was then
  /// analysed at its rest shape and neither dents nor cracks.
  double load_fraction = 0;
  int newton_iterations = 0;  ///< of the static solve, over all its load steps
  bool dented = false;        ///< the rest shape changed
  Index cracks = 0;           ///< cracks cut
  Index fragments = 0;        ///< bodies it was replaced by (0: it goes on itself)
  Index debris_count = 0;     ///< fragments removed as debris
  double debris_mass = 0;     ///< kg
  double solve_ms = 0;        ///< static solve, ms
  double fracture_ms = 0;     ///< stresses, plasticity, cracks, children, ms
};

/// One crack (a row of StepEvents::cracks).
struct CrackRecord {
  BodyId body;                  ///< the body that cracked
  Vec3 origin = Vec3::Zero();   ///< a point of the crack plane, world, m
  Vec3 normal = Vec3::UnitX();  ///< the plane's normal, world
  double radius = 0;            ///< r_frac, m
  double stress = 0;            ///< largest principal stress at the origin, Pa
};

/// A body born from a fracture (a row of StepEvents::fragments).
struct FragmentRecord {
  BodyId parent;    ///< removed body it came from
  BodyId body;      ///< the new body
  double mass = 0;  ///< kg
};

/// What happened in the last step, in a deterministic order (by body id).
struct StepEvents {
  std::vector<ImpactRecord> impacts;
  std::vector<CrackRecord> cracks;
  std::vector<FragmentRecord> fragments;
  std::vector<BodyId> removed;  ///< bodies replaced by their fragments
};

/// Where a contact's manifold was found: the pair's relative placement then, and its points on
/// each body. While the pair has moved less than WorldSettings::contact_reuse_distance relative
/// to each other since, the narrow phase moves these points with the bodies instead of colliding
/// the shapes again.
struct ContactOrigin {
  Vec3 offset = Vec3::Zero();        ///< B's centre of mass in A's frame, m
  Quat rotation = Quat::Identity();  ///< B's orientation relative to A's (q_A^-1 q_B)
  /// Gap up to which the pair's contacts were made, m; < 0: not to be reused (a shape changed).
  double margin = -1;
  Vec3 normal_a = Vec3::UnitY();  ///< the normal in A's frame
  std::array<Vec3, 4> point_a{Vec3::Zero(), Vec3::Zero(), Vec3::Zero(),
                              Vec3::Zero()};  ///< each point's end on A's surface, A's frame, m
  std::array<Vec3, 4> point_b{Vec3::Zero(), Vec3::Zero(), Vec3::Zero(),
                              Vec3::Zero()};  ///< and on B's surface, B's frame, m
};

/// A contact between two bodies (one manifold), with what the solver did in the last step.
struct Contact {
  Index body_a = -1;             ///< slot of body A (World::body_id gives its id); body_a < body_b
  Index body_b = -1;             ///< slot of body B
  Index piece_a = -1;            ///< convex piece of A (-1: a plane or the tet mode)
  Index piece_b = -1;            ///< convex piece of B
  ContactConstraint constraint;  ///< normal, points, impulses (summed over the step), approach speeds
  SatCache sat;                  ///< separating-axis cache of the piece pair
  ContactOrigin origin;          ///< where the manifold was found (for reuse)
};

class WorldSnapshot;

/// A body's boundary at its pose (World::surface).
struct BodySurface {
  std::vector<Vec3> positions;           ///< world, m (#vertices)
  std::vector<Vec3> rest;                ///< rest coordinates for solid textures, m (#vertices)
  std::vector<TriIndices> triangles;     ///< outward (#triangles)
  std::vector<std::uint8_t> crack_face;  ///< 1 where a crack opened the face (#triangles)
};

/// Counts of the last step, for benchmarks and tests.
struct StepStats {
  std::int64_t awake_bodies = 0;
  std::int64_t body_pairs = 0;    ///< pairs from the broad phase (and planes)
  bool grid_kept = false;         ///< the broad phase kept the grid's pairs (WorldSettings::broad_phase_growth)
  std::int64_t reused_pairs = 0;  ///< of them, pairs that kept their contacts (contact_reuse_distance)
  std::int64_t contacts = 0;      ///< manifolds solved
  std::int64_t contact_points = 0;
  std::int64_t islands = 0;
  std::int64_t solve_groups = 0;  ///< groups of islands the contact solve stepped side by side
  double broad_phase_ms = 0;      ///< wall time of each part
  double narrow_phase_ms = 0;
  double solver_ms = 0;
  double impact_ms = 0;                           ///< impact analyses and body replacement
  std::int64_t impacts = 0;                       ///< bodies analysed
  double deformable_ms = 0;                       ///< FEM steps of deformable bodies
  std::int64_t deformable_newton_iterations = 0;  ///< summed over the deformable bodies
  std::int64_t deformable_unconverged = 0;        ///< deformable bodies whose step did not converge
};

class World {
 public:
  explicit World(const WorldSettings& settings = {});

  /// A tet body. Its convex pieces (or its tet-contact shape) are built from the model's mesh.
  /// Errors: a model without mass for a dynamic body; a mesh whose pieces cannot be built.
  Result<BodyId> add_body(std::shared_ptr<const BodyModel> model, const BodyDef& def);
  /// A static or kinematic convex body given by its hull (in its own frame, placed by def.rigid).
  /// Errors: a dynamic def (a hull has no material: give a tet body instead).
  Result<BodyId> add_hull(ConvexHull hull, const BodyDef& def);
  /// A static box of the given half extents, m, centred at def.rigid.position.
  Result<BodyId> add_box(const Vec3& half_extents, const BodyDef& def);
  /// A static plane (the ground): solid below `plane.normal . x = plane.offset`.
  BodyId add_plane(const Plane& plane, const SurfaceMaterial& surface = {}, const CollisionFilter& filter = {});

  // Ids. Every accessor below checks its id and stops the program with a message on an invalid
  // one (as Box2D asserts); the calls that change a body return an error instead.
  /// Whether the id names a body of this world now (removed bodies stay valid: their last state
  /// can be read).
  [[nodiscard]] bool valid(BodyId id) const {
    return id.index >= 0 && id.index < body_count() && bodies_[id.index].generation == id.generation;
  }
  /// The id of the body in a slot (0 <= slot < body_count()).
  [[nodiscard]] BodyId body_id(Index slot) const;

  /// Advance by one time step.
  void step();

  // Bodies.
  [[nodiscard]] Index body_count() const { return static_cast<Index>(bodies_.size()); }
  [[nodiscard]] BodyType body_type(BodyId id) const { return body(id).type; }
  [[nodiscard]] const RigidState& rigid_state(BodyId id) const { return body(id).rigid; }
  [[nodiscard]] const RigidInertia& inertia(BodyId id) const { return body(id).inertia; }
  /// The tet model of a body (null for planes and hulls). For a deformable body its mesh and
  /// surface positions are the current deformed shape in the body frame (world x = position +
  /// R(orientation) r, with the best-fit pose); its `fem` part keeps the rest state. Ask again after
  /// each step: a step may give it a new copy (while a snapshot holds the old one).
  [[nodiscard]] const BodyModel* model(BodyId id) const { return body(id).model.get(); }
  /// Whether the body is simulated with full FEM dynamics (BodyDef::deformable).
  [[nodiscard]] bool deformable(BodyId id) const { return body(id).deform.has_value(); }
  /// World node positions (m) and velocities (m/s) of a deformable body (empty for others).
  [[nodiscard]] std::span<const Vec3> node_positions(BodyId id) const;
  [[nodiscard]] std::span<const Vec3> node_velocities(BodyId id) const;
  /// The convex pieces of a body (body frame).
  [[nodiscard]] std::span<const ConvexHull> pieces(BodyId id) const;
  /// The plane of a plane body (world), null for other bodies.
  [[nodiscard]] const Plane* plane(BodyId id) const {
    const Body& b = body(id);
    return b.shape && b.shape->is_plane ? &b.shape->plane : nullptr;
  }
  [[nodiscard]] bool awake(BodyId id) const { return body(id).awake; }
  /// Set pose and velocities (wakes the body). A deformable body moves rigidly to the new pose,
  /// keeping its deformation, and its nodes take the rigid motion's velocities. Errors: an invalid
  /// or removed id, a non-finite state.
  Result<void> set_rigid_state(BodyId id, const RigidState& rigid);
  /// An impulse J (N s) at world point p (wakes the body; nothing for static and kinematic
  /// bodies; a deformable body takes it on its nodes near p). Errors: an invalid or removed id, non-finite values.
  Result<void> apply_impulse(BodyId id, const Vec3& impulse, const Vec3& point);
  /// Wake a body (its island follows at the next step). Errors: an invalid or removed id.
  Result<void> wake(BodyId id);
  // Tools (the paper's interactive tools, through the same analysis as impacts).
  /// A hammer blow: the impulse J (N s, world) at world point `point` changes the body's motion
  /// now, and at the end of the next step the body is analysed as an impact of |J| along J at
  /// `speed` (m/s, the hammer's): it may dent or break like a body that hit something. `radius`
  /// (m) is the hammer's face: the load is spread over at least that radius (0: the contact
  /// patch of Hertz's theory alone). Errors: an invalid or removed id, non-finite values, a speed
  /// <= 0, a negative radius.
  Result<void> strike(BodyId id, const Vec3& point, const Vec3& impulse, double speed, double radius = 0);
  /// A press: `force` (N, world, pushing into the body) at world point `point`, spread over at
  /// least `radius` (m), held for `duration` seconds (at least one step). Each step it pushes the
  /// body by force x step and, when the body is breakable, analyses it under that force: clay dents
  /// further while it is held, glass cracks once the force is enough. It ends early when the body
  /// breaks. Errors as strike's, and a negative radius or duration.
  Result<void> press(BodyId id, const Vec3& point, const Vec3& force, double radius, double duration);

  /// A saw: cut the body at once along the plane through `point` with `normal` (world). Its pieces
  /// replace it as after a fracture (slice_body): exact masses, the body's motion, crack faces,
  /// siblings kept apart until they separate. The crack and the fragments are added to events()
  /// (with an impact record of no impulse), there at once and among the next step's events.
  /// Returns the number of pieces (0: the plane misses
  /// the body, which stays as it is). Errors: an invalid or removed id, a body that is not a
  /// dynamic tet body, a non-finite point or normal, a zero normal.
  Result<Index> slice(BodyId id, const Vec3& point, const Vec3& normal);

  /// Whether the body was replaced by its fragments (it then takes no further part).
  [[nodiscard]] bool removed(BodyId id) const { return body(id).removed; }
  /// The body a fragment broke from (index -1 for bodies the user added).
  [[nodiscard]] BodyId parent(BodyId id) const;
  /// Accumulated plastic strain per tet of the body's current model (empty for planes and hulls).
  [[nodiscard]] std::span<const double> plastic_strain(BodyId id) const { return body(id).plastic_strain; }
  /// Tensile strength per tet of the body's current model, Pa: drawn when the body was added, for a
  /// material with a Weibull modulus (WorldSettings::seed), and carried into fragments; empty when
  /// every tet has the material's.
  [[nodiscard]] std::span<const double> tensile_strength(BodyId id) const { return body(id).tensile_strength; }
  /// Signed display stress per tet of the body's current model under its last impact or tool load
  /// (Pa; tension positive, compression negative: the paper's Fig. 7), carried into fragments;
  /// empty until the body is first analysed. For display only: it is not part of the state hash.
  [[nodiscard]] std::span<const double> display_stress(BodyId id) const { return body(id).display_stress; }
  /// Largest principal stress per tet under the same load (Pa, tension positive), kept and carried
  /// like display_stress; display only.
  [[nodiscard]] std::span<const double> principal_stress(BodyId id) const { return body(id).principal_stress; }
  /// The body's boundary surface at its pose: world positions, triangles, crack flags and rest
  /// coordinates for solid textures (empty for planes and hulls).
  [[nodiscard]] BodySurface surface(BodyId id) const;
  /// Number of bodies not removed.
  [[nodiscard]] Index live_body_count() const;
  /// A world box around the body at its pose: its body-frame box turned and boxed again, so not
  /// tight for a turned body (infinite for planes).
  [[nodiscard]] Aabb bounds(BodyId id) const;

  // Pairs.
  /// a and b never touch. Errors: an invalid id, or a == b.
  Result<void> exclude_pair(BodyId a, BodyId b);
  /// a and b do not touch until the narrow phase first finds them apart (siblings of one crack).
  /// Errors: an invalid id, or a == b.
  Result<void> exclude_until_apart(BodyId a, BodyId b);

  /// Contacts of the last step, sorted by (body_a, body_b, piece_a, piece_b).
  [[nodiscard]] std::span<const Contact> contacts() const { return contacts_; }
  [[nodiscard]] const StepStats& stats() const { return stats_; }
  /// Impacts, cracks, fragments and removals of the last step, after those of the calls made
  /// before it (slice): read once after each step, every event is seen once. A call's events are
  /// there at once too, and stay until the step after the next.
  [[nodiscard]] const StepEvents& events() const { return events_; }
  [[nodiscard]] const WorldSettings& settings() const { return settings_; }
  [[nodiscard]] std::int64_t step_count() const { return step_count_; }
  /// Simulated time, s.
  [[nodiscard]] double time() const { return static_cast<double>(step_count_) * settings_.time_step; }

  // State.
  /// The whole changing state (bodies with their current models, contacts, exclusions, open
  /// impact events); cheap: models and shapes are shared, not copied.
  [[nodiscard]] WorldSnapshot save() const;
  /// Resume from a snapshot of this world, taken before or after any number of fractures.
  /// Errors: an empty snapshot or one of another world.
  Result<void> restore(const WorldSnapshot& snapshot);
  /// xxHash64 of poses, velocities, sleep state, plastic strains, removals, contact caches,
  /// exclusions and open impact events.
  [[nodiscard]] std::uint64_t state_hash() const;

  /// Total kinetic energy of the dynamic bodies, J.
  [[nodiscard]] double kinetic_energy() const;

  struct State;  ///< what a snapshot holds (world.cpp)

 private:
  struct Shape {
    std::vector<ConvexHull> pieces;              ///< body frame
    std::vector<std::vector<Index>> piece_tets;  ///< the tets each piece covers (tet bodies)
    std::vector<TetContactShape> tet;            ///< 0 or 1 (the paper's mode)
    bool is_plane = false;
    Plane plane;        ///< world
    Aabb local_bounds;  ///< body frame
    double radius = 0;  ///< farthest point from the centre of mass, m
  };
  struct Body {
    BodyType type = BodyType::dynamic;
    std::shared_ptr<const BodyModel> model;
    std::shared_ptr<const Shape> shape;  ///< set with set_shape, which copies the next three
    // The shape's box, radius and kind beside the pose: the broad phase reads them for every body
    // every step, and following `shape` there cost a cache miss per body.
    Aabb local_bounds;
    double radius = 0;
    bool is_plane = false;
    RigidInertia inertia;
    RigidState rigid;
    /// The presses on a rigid body for the coming step, world frame (push_tools): applied in every
    /// substep, as gravity is, and cleared before the next step's. N, N m.
    Vec3 press_force = Vec3::Zero();
    Vec3 press_torque = Vec3::Zero();
    bool pressed = false;
    SurfaceMaterial surface;
    CollisionFilter filter;
    bool can_sleep = true;
    bool awake = true;
    double sleep_time = 0;
    bool removed = false;
    bool breakable = true;
    Index parent = -1;
    double root_mass = 0;  ///< mass of the body the user added that this one broke from, kg
    std::uint32_t generation = 0;
    std::shared_ptr<const ImpactSettings> impact;
    std::vector<double> plastic_strain;    ///< per tet of model
    std::vector<double> tensile_strength;  ///< per tet of model, Pa (empty: the material's)
    std::vector<double> display_stress;    ///< per tet of model under the last load, Pa (display only)
    std::vector<double> principal_stress;  ///< per tet under the last load, Pa (display only)
    std::shared_ptr<StaticSolver> solver;  ///< kept between impacts
    /// Full FEM dynamics (BodyDef::deformable). `model` is then the body's own copy, its positions
    /// kept at the deformed shape (copied before a change while a snapshot shares it).
    struct Deformation {
      int substeps = 1;                  ///< FEM steps per world step (the solver's time step is the world's over this)
      std::shared_ptr<BodyModel> model;  ///< the body's model (Body::model)
      DynamicState nodes;                ///< world
      std::shared_ptr<const std::vector<Vec3>> rest;  ///< rest node positions, body frame
      std::shared_ptr<DynamicSolver> solver;          ///< pattern cache, kept between steps
      double patch_radius = 0;  ///< contact impulses are spread over the surface nodes this close, m
      double max_speed = 0;     ///< fastest node, m/s
      Aabb box;                 ///< around the nodes, world
    };
    std::optional<Deformation> deform;
  };
  struct PairRef {
    Index a, b;
  };

  Index add(const BodyDef& def, std::shared_ptr<const Shape> shape, std::shared_ptr<const BodyModel> model = {});
  /// The body of a valid id (stops the program on an invalid one).
  [[nodiscard]] const Body& body(BodyId id) const;
  void wake_slot(Index slot);
  static void set_shape(Body& b, std::shared_ptr<const Shape> shape);
  [[nodiscard]] Aabb slot_bounds(Index slot) const;
  /// The slot of a valid, not removed id, or an error naming `what` was called.
  [[nodiscard]] Result<Index> live_slot(BodyId id, const char* what) const;
  /// The paper's contact shape (in that mode), bounds and radius of a tet model's shape.
  void finish_tet_shape(Shape& shape, const BodyModel& model) const;
  /// The impact settings of `body` against `other` (null: an obstacle), with the world's debris
  /// budget applied.
  [[nodiscard]] ImpactSettings impact_settings(const Body& body, const Material* other) const;
  /// What analyze_impact reads of a body.
  static BodyState impact_state(const Body& body);
  /// Drop the contacts and open events of removed bodies.
  void forget_removed();
  /// Convex pieces (and the paper's contact shape) of a tet model.
  [[nodiscard]] Result<std::shared_ptr<const Shape>> make_tet_shape(const BodyModel& model) const;
  /// The shape of a model added by the user: built once per process for each model and settings
  /// and shared by every world that adds it (the decomposition of a large body takes a while).
  [[nodiscard]] Result<std::shared_ptr<const Shape>> shared_tet_shape(
      const std::shared_ptr<const BodyModel>& model) const;
  /// Pieces over the given clusters of the model's tets (a dent moves nodes; a fragment keeps its
  /// parent's clusters, cut to the tets it has). A cluster with a hull in `moved` (empty, or one
  /// per cluster, null where none) takes that hull moved by `shift` instead of building one.
  [[nodiscard]] Result<std::shared_ptr<const Shape>> shape_from_clusters(
      std::vector<std::vector<Index>> clusters, const BodyModel& model,
      const std::vector<const ConvexHull*>& moved = {}, const Vec3& shift = Vec3::Zero()) const;
  /// A fragment's pieces from its parent's: its tets grouped by the parent piece their parent tet
  /// lay in. A piece whose tets the cut and plasticity all left unchanged
  /// (ImpactChild::unchanged_parent_tet) keeps its parent's hull, moved into the child's frame.
  [[nodiscard]] Result<std::shared_ptr<const Shape>> inherit_shape(const Shape& parent, const ImpactChild& child) const;
  void process_impacts();
  /// The collision shape of one child of body `slot`'s impact result `r`: a dented body's clusters
  /// over its new nodes, a cracked body's pieces inherited.
  [[nodiscard]] Result<std::shared_ptr<const Shape>> child_shape(Index slot, const ImpactResult& r,
                                                                 const ImpactChild& child) const;
  /// Replace body id by the outcome of its impact analysis; records the events. `shapes`: one per
  /// child of r, as child_shape gives them (empty: built here).
  void apply_impact(Index id, Index other, ImpactResult& r,
                    std::vector<Result<std::shared_ptr<const Shape>>> shapes = {});
  [[nodiscard]] double motion_bound(const Body& b) const;
  void find_pairs(std::vector<PairRef>& pairs);
  void narrow_phase(const std::vector<PairRef>& pairs);
  void update_islands_and_wake();
  void solve();
  void update_sleep();
  /// One FEM step of every awake deformable body, after the contact solver.
  void step_deformables();
  /// Obstacles of a deformable body's nodes: planes, static and kinematic bodies near it.
  [[nodiscard]] DynamicObstacles deformable_obstacles(Index slot) const;
  /// Add impulse J at world point p to a deformable body's surface nodes near p: their momentum
  /// changes by exactly J. Returns the moment about c the spread misses of (p - c) x J, for
  /// turn_nodes (which adds up several such moments in one pass over the nodes).
  [[nodiscard]] Vec3 spread_impulse(Index slot, const Vec3& impulse, const Vec3& point);
  /// Turn a deformable body's nodes rigidly so that their angular momentum changes by H (N m s).
  void turn_nodes(Index slot, const Vec3& moment);
  /// Pose, velocities and box of a deformable body from its nodes; its model's positions follow.
  void fit_deformable(Index slot);
  [[nodiscard]] bool pair_excluded(Index a, Index b) const;

  WorldSettings settings_;
  std::vector<Body> bodies_;
  std::vector<Contact> contacts_;                  ///< sorted by key
  std::vector<std::array<Index, 2>> excluded_;     ///< sorted slot pairs
  std::vector<std::array<Index, 2>> until_apart_;  ///< sorted slot pairs
  /// An impact event: a pair that started touching fast enough, until it stops touching. Its
  /// impulses are summed until the pair stops approaching (a collision the solver resolves over
  /// two steps counts whole), then each breakable body of it is analysed once.
  struct OpenImpact {
    std::array<Index, 2> pair{};
    int steps = 0;          ///< steps it has been open
    bool analysed = false;  ///< its analysis is done
    double approach = 0;    ///< fastest approach of its points, m/s
    struct Point {
      Vec3 local_a, local_b;    ///< the point in A's and B's body frames, m
      Vec3 normal_a, normal_b;  ///< the push on A and on B, in their body frames
      double impulse = 0;       ///< N s
      double approach = 0;      ///< m/s
    };
    std::vector<Point> points;
  };
  std::vector<OpenImpact> open_impacts_;  ///< sorted by pair
  /// A strike waiting for its analysis, or a press being held.
  struct Tool {
    Index body = -1;
    bool strike = false;
    Vec3 local_point = Vec3::Zero();  ///< in the body frame, m
    Vec3 vector = Vec3::Zero();       ///< strike: impulse, N s; press: force, N (world)
    double speed = 0;                 ///< strike: m/s
    double radius = 0;                ///< press, strike: smallest patch radius, m
    double remaining = 0;             ///< press: s left
  };
  std::vector<Tool> tools_;  ///< in the order given
  void push_tools();
  void process_tools();
  std::int64_t step_count_ = 0;
  std::uint64_t world_id_ = 0;              ///< tells this world's snapshots from others'
  std::vector<std::uint32_t> generations_;  ///< generations issued per slot (not part of the state)
  StepStats stats_;
  StepEvents events_;
  /// Sizes of events_'s lists when the last step ended (impacts, cracks, fragments, removed):
  /// what came after is from calls between steps, kept for the next step's events.
  std::array<std::size_t, 4> step_events_end_{};
  void advance();  ///< the step's work (step() keeps the events right around it)
  BroadPhase broad_phase_;
  // Scratch kept between steps.
  std::vector<Aabb> boxes_;
  /// The boxes the grid last ran on (each body's box grown by a margin) and the pairs it found:
  /// while every body's box stays inside its grown box, those pairs hold every pair of
  /// overlapping boxes (find_pairs).
  std::vector<Aabb> grown_boxes_;
  std::vector<PairRef> grown_pairs_;
  std::vector<double> bounds_;  ///< per body: motion_bound at the step's start, m (find_pairs; narrow_phase)
  /// Per body, how much farther than its own motion_bound it may be pushed within the step by the
  /// bodies its box overlaps (m): added to its reach toward planes (find_pairs).
  std::vector<double> pushed_;
  std::vector<PairRef> pairs_;
  std::vector<std::vector<Contact>> pair_contacts_;
  std::vector<std::array<std::size_t, 2>> old_ranges_;  ///< per pair: its contacts_ of the last step
  /// per pair of the narrow phase: 1 its contacts kept and moved, not found afresh; 2 none gathered
  std::vector<char> pair_reused_;
  std::vector<std::size_t> pair_offsets_;  ///< per pair: where its contacts go in next_contacts_
  /// The contacts of one pair found in an earlier step, moved with the bodies into `out`.
  void move_kept_contacts(std::span<const Contact> old, Contact* out) const;
  std::vector<Contact> next_contacts_;  ///< the narrow phase's output buffer (swapped with contacts_)
  std::vector<SolverBody> solver_bodies_;
  /// Moving bodies joined by their constraints (islands, with the moving kinematic bodies they
  /// touch), packed in body order into groups that World::solve steps through all substeps at once.
  struct SolveGroup {
    std::vector<Index> moving;  ///< awake non-static bodies, by slot
    /// Relax passes per substep beyond the one every group takes (components with widely
    /// different masses: ContactSolverSettings::mass_ratio_relax_passes).
    int extra_relax_passes = 0;
    std::vector<ContactConstraint*> constraints;  ///< in the order of contacts_
    ContactBatches batches;
    /// Shock propagation this step (ContactSolverSettings::shock_mass_ratio): the constraints whose
    /// lighter body is pressed into its support, with whether that body is A; then the
    /// constraints of those bodies with their support, with whether the support is A; in the
    /// order of contacts_.
    std::vector<std::pair<ContactConstraint*, bool>> shock;
    std::vector<std::pair<ContactConstraint*, bool>> shock_support;
    /// The contacts between a piece of a rigid dynamic body and a plane or a piece of another
    /// rigid body (static, kinematic or dynamic), in the order of contacts_: found again within
    /// the step when one of the pair's moving bodies turns far (refresh_contacts).
    std::vector<Contact*> refreshable;
    /// Per refreshable contact that is its pair's first: its two bodies' World::spun_ when the
    /// pair's contacts were last found, and the time into the step then, s (zeros: at the step's
    /// start).
    std::vector<std::array<double, 3>> turn_base;
    /// Contacts made within the step for points that found no place in the step's; a deque, so
    /// that the solver's pointers to them hold. Merged into contacts_ after the solve.
    std::deque<Contact> made;
  };
  std::vector<SolveGroup> solve_groups_;  ///< the first solve_group_count_ are this step's
  /// Per solver body, the sum of the normals (into it) of its contacts with bodies that take no
  /// impulses (set per step for the moving bodies by build_solve_groups; the tests of a press into
  /// the supports: shock propagation, pressed_mass_ratio, mass_ratio_relax_passes).
  std::vector<Vec3> support_normal_;
  /// Per solver body, whether a heavier dynamic body presses it into its support this step
  /// (ContactSolverSettings::pressed_mass_ratio): its contacts with the support take the softer
  /// spring (set per step for the moving bodies).
  std::vector<std::uint8_t> pressed_into_support_;
  std::size_t solve_group_count_ = 0;
  std::vector<Index> solve_parent_;
  /// Whether the solver moves the body this step (awake and not static; kinematic bodies included).
  static bool moves_in_solve(const Body& b) { return b.awake && b.type != BodyType::static_body; }
  /// Whether a contact of these bodies takes the stiffer spring of contacts with static and
  /// kinematic bodies (ContactSolverSettings::wall_mass_ratio).
  [[nodiscard]] bool wall_like(const Body& a, const Body& b) const;
  /// The spring of a contact between the bodies in slots a and b this step: the stiffer one when
  /// wall_like, unless the dynamic body is pressed into the other by a heavier body
  /// (pressed_into_support_).
  [[nodiscard]] Softness contact_softness(Index a, Index b, const Softness& soft, const Softness& static_soft) const;
  void build_solve_groups(std::span<Contact* const> active, std::span<const Index> moving);
  void solve_group(SolveGroup& group, double h, double inverse_h);
  /// Within a group's step, after `elapsed` seconds of it: the refreshable contacts of each pair
  /// with a moving body that has turned far since they were found, found again at the poses now
  /// (docs/method.md, "No tunnelling"). `soft`: the softness of contacts between two dynamic
  /// bodies; `static_soft`: of the others.
  void refresh_contacts(SolveGroup& group, double elapsed, const Softness& soft, const Softness& static_soft);
  /// Per moving body: the angle it turned in this step so far (rad, the sum of |ω| h).
  std::vector<double> spun_;
  /// Scratch of World::solve: the contacts made within the step, and contacts_ merged with them.
  std::vector<Contact> made_buffer_;
  std::vector<Contact> merge_buffer_;
  std::vector<Index> island_parent_;
  std::vector<Index> island_of_;
};

/// A saved world state (World::save); restore it into the world it came from.
class WorldSnapshot {
 public:
  /// Whether it holds a state.
  [[nodiscard]] bool empty() const { return !state_; }

 private:
  friend class World;
  std::shared_ptr<const World::State> state_;
};

}  // namespace shatter
