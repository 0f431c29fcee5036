// One body of the simulation split as MuJoCo splits mjModel and mjData: BodyModel is what never
// changes between events (rest mesh and its topology, material, FEM rest data, lumped masses, exact
// mass properties); BodyState is what changes (rigid pose and velocities, accumulated plastic strain,
// time-averaged stress, the static solver's cached pattern and factorization). Functions read
// (const BodyModel&, BodyState&); an impact changes the model only through the two documented
// updates below: a plastic update in place, or a new model per fragment after a cut.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/constitutive.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fem/material.h"
#include "shatter/fracture/crack.h"
#include "shatter/fracture/plasticity.h"
#include "shatter/mesh/mass_properties.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/mesh/topology.h"
#include "shatter/solve/static_solver.h"

namespace shatter {

/// The constant data of one body. The rest mesh is in the body frame: its centre of mass is the
/// origin (make_body_model moves it there), so world positions are x = position + R(orientation) r.
struct BodyModel {
  TetMesh mesh;         ///< rest mesh, body frame, m
  TetFaces faces;       ///< unique faces, face adjacency, boundary faces of `mesh`
  TriSurface surface;   ///< boundary triangles (outward) over the boundary nodes
  FemModel fem;         ///< material, model kind, per-tet rest data, lumped node masses
  MassProperties mass;  ///< exact, about the centre of mass (the body-frame origin)
  /// Per triangle of `surface`: 1 where the face was opened by a crack (the inside of the
  /// material shows there), 0 on the original surface (#triangles).
  std::vector<std::uint8_t> crack_face;
  /// Where the body-frame origin lies in the coordinates of the mesh the body was first made
  /// from, m: rest coordinates for solid textures are material_origin + r, the same in every
  /// fragment of that body.
  Vec3 material_origin = Vec3::Zero();
};

/// Rigid motion of a body (docs/method.md §2.7, eq. 23).
struct RigidState {
  Vec3 position = Vec3::Zero();          ///< centre of mass in the world, m
  Quat orientation = Quat::Identity();   ///< body to world rotation (unit)
  Vec3 linear_velocity = Vec3::Zero();   ///< of the centre of mass, m/s
  Vec3 angular_velocity = Vec3::Zero();  ///< world frame, rad/s
};

/// The changing data of one body.
struct BodyState {
  RigidState rigid;                    ///< pose and velocities
  std::vector<double> plastic_strain;  ///< accumulated equivalent plastic strain (#tets)
  /// Tensile strength per tet, Pa (#tets; empty: the material's), e.g. sample_tensile_strengths.
  std::vector<double> tensile_strength;
  std::optional<StressHistory> stress_history;  ///< time-averaged stress (#tets), when used
  /// Pattern and factorization kept between impacts (a cache, shared by copies of the state;
  /// make_body_state creates it, and an impact makes one when it is null).
  std::shared_ptr<StaticSolver> solver;
};

/// Build a body from a rest mesh given in the world: the mesh is validated (no validate_mesh error,
/// positively oriented tets, positive volume), moved into the body frame, and its model built.
/// `rigid` receives the pose that puts the body where the mesh was (position = centre of mass,
/// orientation identity).
/// Errors: an invalid mesh or material, a mesh with no tets.
Result<BodyModel> make_body_model(const TetMesh& world_mesh, const Material& material,
                                  ModelKind model = ModelKind::stvk, RigidState* rigid = nullptr);

/// A fresh state: the given rigid motion, no plastic strain, no stress history, an empty solver.
BodyState make_body_state(const BodyModel& model, const RigidState& rigid = {});

/// A digest of what a body's surface looks like: boundary positions and triangles, crack flags and
/// the rest-coordinate origin (xxHash64). Equal for models that draw the same, so viewers and
/// exporters can tell a changed model (a dent, a crack) from one seen before.
std::uint64_t surface_hash(const BodyModel& model);

/// World positions of the body's nodes at its pose (m, #nodes).
std::vector<Vec3> world_positions(const BodyModel& model, const RigidState& rigid);

/// Follow a plastic event (apply_plasticity on this body) in place: the new rest positions, the
/// boundary surface and the plastic strain; tets, node masses and the mass are kept (mass is
/// conserved). The centre of mass and inertia follow the new shape at the kept mass, and the body
/// frame is re-centred on the new centre of mass (rigid.position moves with it so no node jumps),
/// so every tet's FEM rest data is recomputed. Returns the re-centring, m (in the old body frame):
/// the new rest positions less it are the new body-frame positions (zero when no node moved).
Vec3 apply_plastic_update(BodyModel& model, BodyState& state, const PlasticResult& plastic);

}  // namespace shatter
