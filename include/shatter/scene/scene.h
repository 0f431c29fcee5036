// Scenes (docs/scenes.md): a JSON file that says what is where, made of what, moving how, what
// happens when, and what to write out; and the run that simulates it and writes its outputs
// (`shatter run`).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/constitutive.h"
#include "shatter/fem/material.h"
#include "shatter/rigid/impact.h"
#include "shatter/world/world.h"

namespace shatter {

/// One body of a scene.
struct SceneBody {
  std::string name;        ///< unique in the scene ("body<k>" when not given)
  std::string mesh_path;   ///< a volume mesh file (resolved against the scene file's folder)
  std::string shape_path;  ///< or a shape file (JSON), meshed when the scene is built
  std::string shape_text;  ///< or a shape written in the scene (shape_path then names where, for messages)
  double refine = 1;       ///< shape files: about this many times the file's tets
  Material material;
  ModelKind model = ModelKind::stvk;
  BodyType type = BodyType::dynamic;
  /// Placement of the mesh: world = rotation x (mesh point) + position.
  Vec3 position = Vec3::Zero();
  Quat rotation = Quat::Identity();
  /// When set, the body is moved up or down so that its lowest point is this high above the
  /// ground, m (after the rotation; overrides position's height).
  std::optional<double> height;
  Vec3 velocity = Vec3::Zero();          ///< of the centre of mass, m/s
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s
  SurfaceMaterial surface;
  bool breakable = true;
  ImpactSettings impact;  ///< the scene's impact settings with this body's overrides
  /// Full FEM dynamics (BodyDef::deformable); empty: rigid between impacts.
  std::optional<DeformableSettings> deformable;
  /// The body enters the world at this time, s, as placed (a drop or a throw later in the run);
  /// 0: from the start.
  double appear = 0;
};

/// Something that happens at a time.
struct SceneAction {
  enum class Kind : std::uint8_t { strike, press, impulse };
  Kind kind = Kind::strike;
  double time = 0;             ///< s
  std::size_t body = 0;        ///< index into Scene::bodies
  Vec3 point = Vec3::Zero();   ///< world point, m (at the body's pose at that time: see docs/scenes.md)
  bool point_given = false;    ///< false: the body's surface point nearest to the side the vector comes from
  Vec3 vector = Vec3::Zero();  ///< strike and impulse: N s; press: N
  double speed = 0;            ///< strike: the hammer's speed, m/s
  double radius = 0;           ///< press, strike: the smallest patch radius, m
  double duration = 0;         ///< press: s
};

/// What a run writes.
struct SceneOutput {
  double frames_per_second = 30;  ///< ParaView frames (0: none)
  bool vtu = true;                ///< frames/frame_<k>.vtu and scene.pvd
  /// Also the bodies' surfaces at each frame, frames/surface_<k>.<surfaces>: "ply" (with face
  /// properties body and crack), "obj" or "stl"; "" for none.
  std::string surfaces;
  /// scene.glb: the run as a glTF 2.0 animation at the same frames (docs/scenes.md#gltf).
  bool gltf = false;
  bool events = true;   ///< events.jsonl
  bool summary = true;  ///< summary.json
};

/// A parsed scene file.
struct Scene {
  std::string file;  ///< path it was read from (for messages)
  std::string name;
  WorldSettings world;
  double duration = 2;  ///< simulated seconds
  int threads = 0;      ///< 0: all cores
  bool ground = true;   ///< a ground plane at y = ground_height
  double ground_height = 0;
  SurfaceMaterial ground_surface;
  std::vector<SceneBody> bodies;
  std::vector<SceneAction> actions;  ///< by time (stable)
  SceneOutput output;
};

/// Parse a scene held in memory; relative paths start from `base_dir`. Every mistake is an error
/// naming the file, the JSON path and what was expected; unknown keys name the nearest known key.
Result<Scene> parse_scene(std::string_view text, const std::string& file, const std::string& base_dir = ".");
/// Read and parse a scene file.
Result<Scene> read_scene(const std::string& path);

/// A scene built into a world.
struct SceneWorld {
  std::unique_ptr<World> world;
  /// The id of each scene body; index -1 for a body that has not appeared yet.
  std::vector<BodyId> bodies;
  BodyId ground;  ///< index -1 without a ground
  /// What a body that appears later is added with (index into bodies; empty model: added).
  struct Pending {
    std::size_t body = 0;
    std::shared_ptr<const BodyModel> model;
    BodyDef def;
  };
  std::vector<Pending> pending;
};
/// Read the meshes (or mesh the shapes), make the models and add everything to a new world.
/// Errors name the body and its file.
Result<SceneWorld> build_scene(const Scene& scene);

/// Add the bodies due to appear by the end of the next step, then apply the scene's actions due by
/// then, from `next_action` on (it moves past them): run_scene, `shatter render` and the viewer
/// step a scene this way. An action on a body that broke before, or has not appeared, is skipped.
/// Errors: an action or a body the world refuses (names the time).
Result<void> apply_due_actions(const Scene& scene, SceneWorld& built, std::size_t& next_action);

/// Settings of run_scene.
struct RunOptions {
  std::string out_dir;                      ///< where the outputs go ("": none)
  std::optional<double> duration;           ///< instead of the scene's
  const std::atomic<bool>* stop = nullptr;  ///< set (e.g. on Ctrl-C) to stop after the current step
  /// Called after every step with the simulated time, steps done, live bodies.
  std::function<void(double time, std::int64_t steps, Index live_bodies)> progress;
};

/// How a run went.
struct RunSummary {
  std::int64_t steps = 0;
  double simulated_time = 0;  ///< s
  bool stopped = false;       ///< stopped early (RunOptions::stop)
  Index bodies = 0;           ///< live bodies at the end (the ground not counted)
  Index fragments = 0;        ///< bodies born from fractures over the run
  Index impacts = 0;          ///< impact analyses
  /// Impact analyses whose static solve carried only part of the load (ImpactRecord::load_fraction
  /// below 1: a soft StVK body's large dent, docs/impacts.md "Limits")
  Index impacts_partly_solved = 0;
  Index cracks = 0;
  double debris_mass = 0;    ///< kg
  double rigid_ms = 0;       ///< broad + narrow phase + solver, ms over the run
  double impact_ms = 0;      ///< impact analyses and replacements, ms
  double deformable_ms = 0;  ///< FEM steps of deformable bodies, ms
  double output_ms = 0;      ///< writing files, ms
  double wall_ms = 0;
  std::uint64_t state_hash = 0;    ///< World::state_hash at the end
  std::vector<std::string> files;  ///< outputs written
};

/// Simulate the scene and write its outputs (each file atomically: frames, the .pvd listing the
/// frames written so far, events.jsonl and summary.json rewritten as the run goes, so a run stopped
/// at any step leaves complete files). Errors: the scene cannot be built, an output cannot be
/// written.
Result<RunSummary> run_scene(const Scene& scene, const RunOptions& options = {});

}  // namespace shatter
