// Scene files and their runs (see scene.h and docs/scenes.md).
#include "shatter/scene/scene.h"
#include "shatter/scene/gltf.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <utility>

#include "shatter/core/clock.h"
#include "shatter/core/file_io.h"
#include "shatter/core/json_reader.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/meshing/mesh_shape.h"
#include "shatter/meshing/shape_json.h"
#include "shatter/scene/material_json.h"

namespace shatter {
namespace {

using json_input::Json;
using json_input::ObjectReader;
using json_input::Where;

// Scenes are small; a larger file is a mistake.
constexpr std::uint64_t kMaxSceneBytes = 16ULL << 20;
constexpr double kMaxDuration = 24 * 3600.0;   // s: a longer run is a mistake in the file
constexpr std::size_t kMaxSceneBodies = 4096;  // the world's default body budget
constexpr int kMaxSubsteps = 1000;

Result<double> read_in_range(const Json& value, const Where& where, double lo, double hi, const char* what) {
  SHATTER_TRY(v, json_input::read_number(value, where));
  if (!(*v >= lo && *v <= hi)) return where.error(std::string("expected ") + what + ", got " + value.dump());
  return *v;
}

// An integer in [lo, hi].
Result<int> read_int_in_range(const Json& value, const Where& where, int lo, int hi) {
  SHATTER_TRY(v, json_input::read_integer(value, where));
  if (*v < lo || *v > hi)
    return where.error("expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return static_cast<int>(*v);
}

Result<Quat> read_rotation(const Json& value, const Where& where) {
  ObjectReader r(value, where);
  if (!r.status().ok())
    return where.error("expected {\"axis\": [x, y, z], \"degrees\": angle}, got " + json_input::type_name(value));
  const Json* ja = r.get("axis");
  const Json* jd = r.get("degrees");
  SHATTER_TRY(done, r.finish());
  if (!ja) return where.key("axis").error("missing; expected [x, y, z], the axis to turn about");
  if (!jd) return where.key("degrees").error("missing; expected the angle in degrees");
  SHATTER_TRY(axis, json_input::read_vec3(*ja, where.key("axis")));
  if (!(axis->norm() > 0)) return where.key("axis").error("expected a non-zero axis");
  SHATTER_TRY(deg, json_input::read_number(*jd, where.key("degrees")));
  return Quat(Eigen::AngleAxisd(*deg * std::numbers::pi / 180.0, axis->normalized()));
}

// The impact keys a scene or a body may set, over `base`.
Result<ImpactSettings> read_impact(const Json& value, const Where& where, ImpactSettings base) {
  ObjectReader r(value, where);
  if (!r.status().ok())
    return where.error("expected an object of impact settings, got " + json_input::type_name(value));
  struct Num {
    const char* key;
    double* target;
    double lo, hi;
    const char* what;
  };
  Num nums[] = {
      {"min_approach_speed", &base.min_approach_speed, 0, 1e6, "a speed >= 0 (m/s)"},
      {"collision_radius", &base.collision_radius, 1e-3, 10, "a fraction of the body's radius in [0.001, 10]"},
      {"curvature_radius", &base.curvature_radius, 1e-3, 100, "a fraction of the body's radius in [0.001, 100]"},
      {"hardness_factor", &base.hardness_factor, 0, 100, "a multiple of the yield stress in [0, 100] (0: Hertz alone)"},
      {"min_fragment_fraction", &base.min_fragment_fraction, 0, 1, "a fraction of the body's mass in [0, 1]"},
      {"max_plastic_strain", &base.fracture.plasticity.max_plastic_strain, 0, 1e6, "a strain >= 0"},
      {"creep", &base.fracture.plasticity.creep, 0, 1, "a fraction in [0, 1]"},
  };
  for (const Num& n : nums)
    if (const Json* j = r.get(n.key)) {
      SHATTER_TRY(v, read_in_range(*j, where.key(n.key), n.lo, n.hi, n.what));
      *n.target = *v;
    }
  if (const Json* j = r.get("max_fragments")) {
    SHATTER_TRY(v, read_int_in_range(*j, where.key("max_fragments"), 1, 4096));
    base.max_fragments = *v;
  }
  if (const Json* j = r.get("max_cracks")) {
    SHATTER_TRY(v, read_int_in_range(*j, where.key("max_cracks"), 0, 64));
    base.fracture.crack.max_cracks = *v;
  }
  if (const Json* j = r.get("hold")) {
    SHATTER_TRY(v, json_input::read_string(*j, where.key("hold")));
    if (*v == "anchor-far")
      base.hold = ImpactHold::anchor_far;
    else if (*v == "inertia-relief")
      base.hold = ImpactHold::inertia_relief;
    else
      return where.key("hold").error("expected \"anchor-far\" or \"inertia-relief\", got \"" + *v + "\"");
  }
  SHATTER_TRY(done, r.finish());
  return base;
}

// A body's "deformable": true, false, or an object of DeformableSettings keys.
Result<std::optional<DeformableSettings>> read_deformable(const Json& value, const Where& where) {
  if (value.is_boolean()) return value.get<bool>() ? std::optional(DeformableSettings{}) : std::nullopt;
  ObjectReader r(value, where);
  if (!r.status().ok())
    return where.error("expected true, false or an object of deformable settings, got " + json_input::type_name(value));
  DeformableSettings d;
  if (const Json* j = r.get("mass_damping")) {
    SHATTER_TRY(v, read_in_range(*j, where.key("mass_damping"), 0, 1e6, "a Rayleigh alpha >= 0 (1/s)"));
    d.mass_damping = *v;
  }
  if (const Json* j = r.get("stiffness_damping")) {
    SHATTER_TRY(v, read_in_range(*j, where.key("stiffness_damping"), 0, 1e3, "a Rayleigh beta in [0, 1000] (s)"));
    d.stiffness_damping = *v;
  }
  if (const Json* j = r.get("contact_stiffness")) {
    SHATTER_TRY(v, read_in_range(*j, where.key("contact_stiffness"), 1, 1e12, "a factor in [1, 1e12]"));
    d.contact_stiffness = *v;
  }
  if (const Json* j = r.get("max_newton_iterations")) {
    SHATTER_TRY(v, read_int_in_range(*j, where.key("max_newton_iterations"), 1, 1000));
    d.max_newton_iterations = *v;
  }
  if (const Json* j = r.get("substeps")) {
    SHATTER_TRY(v, read_int_in_range(*j, where.key("substeps"), 1, 1000));
    d.substeps = *v;
  }
  SHATTER_TRY(done, r.finish());
  return std::optional(d);
}

Result<SurfaceMaterial> read_surface(ObjectReader& r, const Where& where, SurfaceMaterial s) {
  if (const Json* j = r.get("friction")) {
    SHATTER_TRY(v, read_in_range(*j, where.key("friction"), 0, 100, "a friction coefficient >= 0"));
    s.friction = *v;
  }
  if (const Json* j = r.get("restitution")) {
    SHATTER_TRY(v, read_in_range(*j, where.key("restitution"), 0, 1, "a restitution in [0, 1]"));
    s.restitution = *v;
  }
  return s;
}

std::string resolve(const std::string& base_dir, const std::string& path) {
  const std::filesystem::path p(path);
  return p.is_absolute() ? path : (std::filesystem::path(base_dir) / p).lexically_normal().string();
}

Result<SceneBody> read_body(const Json& value, const Where& where, const Scene& scene,
                            const std::map<std::string, Material>& materials, const std::string& base_dir,
                            std::size_t index) {
  ObjectReader r(value, where);
  if (!r.status().ok()) return where.error("expected an object describing a body, got " + json_input::type_name(value));
  SceneBody b;
  b.name = "body" + std::to_string(index);
  b.impact = scene.world.impact;
  for (const char* key :
       {"name", "mesh", "shape", "refine", "material", "model", "type", "position", "rotation", "height", "velocity",
        "angular_velocity", "friction", "restitution", "breakable", "impact", "deformable", "array", "appear"})
    (void)r.get(key);
  SHATTER_TRY(known, r.finish());
  if (const Json* j = r.get("name")) {
    SHATTER_TRY(v, json_input::read_string(*j, where.key("name")));
    b.name = *v;
  }
  const Json* jm = r.get("mesh");
  const Json* js = r.get("shape");
  if ((jm != nullptr) == (js != nullptr))
    return where.error(jm ? "give either \"mesh\" or \"shape\", not both"
                          : "missing \"mesh\" (a volume mesh file) or \"shape\" (a shape file or object)");
  if (jm) {
    SHATTER_TRY(v, json_input::read_string(*jm, where.key("mesh")));
    b.mesh_path = resolve(base_dir, *v);
  } else if (js->is_object()) {  // a shape written in the scene, as in a shape file
    b.shape_text = js->dump();
    b.shape_path = scene.file + ": " + where.key("shape").path;
    auto shape = parse_shape_json(b.shape_text, b.shape_path, {.base_dir = base_dir, .load_surface = {}});
    if (!shape) return make_error(shape.error().to_string());
  } else {
    SHATTER_TRY(v, json_input::read_string(*js, where.key("shape")));
    b.shape_path = resolve(base_dir, *v);
  }
  if (const Json* j = r.get("refine")) {
    if (!js) return where.key("refine").error("only shape files can be refined (this body gives a mesh)");
    SHATTER_TRY(v, read_in_range(*j, where.key("refine"), 0.01, 1000, "a factor in [0.01, 1000]"));
    b.refine = *v;
  }
  const Json* jmat = r.get("material");
  if (!jmat)
    return where.key("material").error("missing; expected a preset name, a name from \"materials\" or an object");
  if (jmat->is_string() && materials.contains(jmat->get<std::string>())) {
    b.material = materials.at(jmat->get<std::string>());
  } else {
    SHATTER_TRY(m, read_material_json(*jmat, where.key("material")));
    b.material = std::move(*m);
  }
  if (const Json* j = r.get("model")) {
    SHATTER_TRY(v, json_input::read_string(*j, where.key("model")));
    auto kind = parse_model_kind(*v);
    if (!kind.ok()) return where.key("model").error(kind.error().message);
    b.model = *kind;
  }
  if (const Json* j = r.get("type")) {
    SHATTER_TRY(v, json_input::read_string(*j, where.key("type")));
    if (*v == "dynamic")
      b.type = BodyType::dynamic;
    else if (*v == "static")
      b.type = BodyType::static_body;
    else if (*v == "kinematic")
      b.type = BodyType::kinematic;
    else
      return where.key("type").error("expected \"dynamic\", \"static\" or \"kinematic\", got \"" + *v + "\"");
  }
  if (const Json* j = r.get("position")) {
    SHATTER_TRY(v, json_input::read_vec3(*j, where.key("position")));
    b.position = *v;
  }
  if (const Json* j = r.get("rotation")) {
    SHATTER_TRY(v, read_rotation(*j, where.key("rotation")));
    b.rotation = *v;
  }
  if (const Json* j = r.get("height")) {
    SHATTER_TRY(v, read_in_range(*j, where.key("height"), 0, 1e6, "a height >= 0 (m) above the ground"));
    b.height = *v;
  }
  if (const Json* j = r.get("velocity")) {
    SHATTER_TRY(v, json_input::read_vec3(*j, where.key("velocity")));
    b.velocity = *v;
  }
  if (const Json* j = r.get("angular_velocity")) {
    SHATTER_TRY(v, json_input::read_vec3(*j, where.key("angular_velocity")));
    b.angular_velocity = *v;
  }
  SHATTER_TRY(surface, read_surface(r, where, {}));
  b.surface = *surface;
  if (const Json* j = r.get("breakable")) {
    SHATTER_TRY(v, json_input::read_bool(*j, where.key("breakable")));
    b.breakable = *v;
  }
  if (const Json* j = r.get("impact")) {
    SHATTER_TRY(v, read_impact(*j, where.key("impact"), b.impact));
    b.impact = *v;
  }
  if (const Json* j = r.get("deformable")) {
    SHATTER_TRY(v, read_deformable(*j, where.key("deformable")));
    if (*v && b.type != BodyType::dynamic)
      return where.key("deformable").error("only a dynamic body can be deformable");
    b.deformable = *v;
  }
  if (const Json* j = r.get("appear")) {
    SHATTER_TRY(v, read_in_range(*j, where.key("appear"), 0, kMaxDuration, "a time >= 0 (s)"));
    b.appear = *v;
  }
  return b;
}

// A body's "array": {"count": [nx, ny, nz], "spacing": [dx, dy, dz]} makes nx * ny * nz copies
// named "<name>.<k>" (k from 0, x fastest), each moved by (i dx, j dy, l dz). Without it, the body.
Result<std::vector<SceneBody>> read_array_copies(const Json& value, const Where& where, const SceneBody& body) {
  const Json* ja = value.is_object() && value.contains("array") ? &value.at("array") : nullptr;
  if (!ja) return std::vector<SceneBody>{body};
  const Where w = where.key("array");
  ObjectReader r(*ja, w);
  if (!r.status().ok()) return w.error("expected {\"count\": [nx, ny, nz], \"spacing\": [dx, dy, dz]}");
  const Json* jc = r.get("count");
  const Json* jsp = r.get("spacing");
  SHATTER_TRY(known, r.finish());
  if (!jc) return w.key("count").error("missing; expected [nx, ny, nz], copies along x, y and z");
  if (!jsp) return w.key("spacing").error("missing; expected [dx, dy, dz], m between copies");
  SHATTER_TRY(arr, json_input::read_array(*jc, w.key("count")));
  if ((*arr)->size() != 3) return w.key("count").error("expected three integers [nx, ny, nz]");
  std::array<std::int64_t, 3> n{};
  for (std::size_t k = 0; k < 3; ++k) {
    SHATTER_TRY(v, json_input::read_integer((**arr)[k], w.key("count").index(k)));
    if (*v < 1 || *v > static_cast<std::int64_t>(kMaxSceneBodies))
      return w.key("count").index(k).error("expected an integer in [1, " + std::to_string(kMaxSceneBodies) + "]");
    n[k] = *v;
  }
  if (n[0] * n[1] * n[2] > static_cast<std::int64_t>(kMaxSceneBodies))
    return w.key("count").error("more than " + std::to_string(kMaxSceneBodies) + " copies");
  SHATTER_TRY(spacing, json_input::read_vec3(*jsp, w.key("spacing")));
  std::vector<SceneBody> out;
  for (std::int64_t l = 0; l < n[2]; ++l)
    for (std::int64_t j = 0; j < n[1]; ++j)
      for (std::int64_t i = 0; i < n[0]; ++i) {
        SceneBody c = body;
        c.name = body.name + "." + std::to_string(out.size());
        const Vec3 shift(static_cast<double>(i) * spacing->x(), static_cast<double>(j) * spacing->y(),
                         static_cast<double>(l) * spacing->z());
        c.position += shift;
        if (c.height) *c.height += shift.y();
        out.push_back(std::move(c));
      }
  return out;
}

Result<SceneAction> read_action(const Json& value, const Where& where, const std::vector<SceneBody>& bodies) {
  ObjectReader r(value, where);
  if (!r.status().ok())
    return where.error("expected an object describing an action, got " + json_input::type_name(value));
  for (const char* key : {"time", "type", "body", "point", "impulse", "force", "speed", "radius", "duration"})
    (void)r.get(key);
  SHATTER_TRY(known, r.finish());
  SceneAction a;
  const Json* jt = r.get("time");
  if (!jt) return where.key("time").error("missing; expected the time of the action, s");
  SHATTER_TRY(t, read_in_range(*jt, where.key("time"), 0, kMaxDuration, "a time >= 0 (s)"));
  a.time = *t;
  const Json* jk = r.get("type");
  if (!jk) return where.key("type").error("missing; expected \"strike\", \"press\" or \"impulse\"");
  SHATTER_TRY(kind, json_input::read_string(*jk, where.key("type")));
  if (*kind == "strike")
    a.kind = SceneAction::Kind::strike;
  else if (*kind == "press")
    a.kind = SceneAction::Kind::press;
  else if (*kind == "impulse")
    a.kind = SceneAction::Kind::impulse;
  else
    return where.key("type").error("expected \"strike\", \"press\" or \"impulse\", got \"" + *kind + "\"");
  const Json* jb = r.get("body");
  if (!jb) return where.key("body").error("missing; expected the name of a body");
  SHATTER_TRY(name, json_input::read_string(*jb, where.key("body")));
  const auto it = std::find_if(bodies.begin(), bodies.end(), [&](const SceneBody& b) { return b.name == *name; });
  if (it == bodies.end()) {
    std::vector<std::string> names;
    names.reserve(bodies.size());
    for (const SceneBody& b : bodies) names.push_back(b.name);
    const std::string near = json_input::nearest(*name, names);
    return where.key("body").error("no body is named \"" + *name + "\"" +
                                   (near.empty() ? "" : " (did you mean \"" + near + "\"?)"));
  }
  a.body = static_cast<std::size_t>(it - bodies.begin());
  if (const Json* j = r.get("point")) {
    SHATTER_TRY(v, json_input::read_vec3(*j, where.key("point")));
    a.point = *v;
    a.point_given = true;
  }
  const bool press = a.kind == SceneAction::Kind::press;
  const char* vector_key = press ? "force" : "impulse";
  const char* other_key = press ? "impulse" : "force";
  if (r.get(other_key))
    return where.key(other_key).error(std::string("a ") + *kind + " takes \"" + vector_key + "\", not \"" + other_key +
                                      "\"");
  const Json* jv = r.get(vector_key);
  if (!jv) return where.key(vector_key).error(std::string("missing; expected [x, y, z] in ") + (press ? "N" : "N s"));
  SHATTER_TRY(v, json_input::read_vec3(*jv, where.key(vector_key)));
  if (!(v->norm() > 0)) return where.key(vector_key).error("expected a non-zero vector");
  a.vector = *v;
  const Json* js = r.get("speed");
  if (a.kind == SceneAction::Kind::strike) {
    if (!js) return where.key("speed").error("missing; expected the hammer's speed, m/s (> 0)");
    SHATTER_TRY(s, json_input::read_positive(*js, where.key("speed")));
    a.speed = *s;
  } else if (js) {
    return where.key("speed").error("only a strike has a speed");
  }
  const Json* jr = r.get("radius");
  const Json* jd = r.get("duration");
  if (jr) {
    if (a.kind == SceneAction::Kind::impulse) return where.key("radius").error("only a press or a strike has a radius");
    SHATTER_TRY(s, read_in_range(*jr, where.key("radius"), 0, 1e3, "a radius >= 0 (m)"));
    a.radius = *s;
  }
  if (press) {
    if (!jd) return where.key("duration").error("missing; expected how long the press is held, s");
    SHATTER_TRY(s, read_in_range(*jd, where.key("duration"), 0, kMaxDuration, "a duration >= 0 (s)"));
    a.duration = *s;
  } else if (jd) {
    return where.key("duration").error("only a press has a duration");
  }
  return a;
}

}  // namespace

Result<Scene> parse_scene(std::string_view text, const std::string& file, const std::string& base_dir) {
  SHATTER_TRY(doc, json_input::parse_json(text, file));
  const Where root{&file, ""};
  ObjectReader r(*doc, root);
  if (!r.status().ok()) return r.status().error();
  Scene scene;
  scene.file = file;
  scene.name = std::filesystem::path(file).stem().string();
  r.allow({"description"});
  for (const char* key :
       {"name", "world", "duration", "threads", "ground", "impact", "materials", "bodies", "actions", "output"})
    (void)r.get(key);
  SHATTER_TRY(known, r.finish());
  if (const Json* j = r.get("name")) {
    SHATTER_TRY(v, json_input::read_string(*j, root.key("name")));
    scene.name = *v;
  }
  if (const Json* jw = r.get("world")) {
    const Where w = root.key("world");
    ObjectReader wr(*jw, w);
    if (!wr.status().ok()) return w.error("expected an object of world settings, got " + json_input::type_name(*jw));
    if (const Json* j = wr.get("time_step")) {
      SHATTER_TRY(v, read_in_range(*j, w.key("time_step"), 1e-6, 1, "a step in [1e-6, 1] s"));
      scene.world.time_step = *v;
    }
    if (const Json* j = wr.get("substeps")) {
      SHATTER_TRY(v, read_int_in_range(*j, w.key("substeps"), 1, kMaxSubsteps));
      scene.world.substeps = *v;
    }
    if (const Json* j = wr.get("gravity")) {
      SHATTER_TRY(v, json_input::read_vec3(*j, w.key("gravity")));
      scene.world.gravity = *v;
    }
    if (const Json* j = wr.get("contact_mode")) {
      SHATTER_TRY(v, json_input::read_string(*j, w.key("contact_mode")));
      if (*v == "convex-pieces")
        scene.world.contact_mode = ContactMode::convex_pieces;
      else if (*v == "tet-vertices")
        scene.world.contact_mode = ContactMode::tet_vertices;
      else
        return w.key("contact_mode").error("expected \"convex-pieces\" or \"tet-vertices\", got \"" + *v + "\"");
    }
    if (const Json* j = wr.get("contact_reuse")) {
      SHATTER_TRY(v, read_in_range(*j, w.key("contact_reuse"), 0, 0.1, "a distance in [0, 0.1] m (0: never)"));
      scene.world.contact_reuse_distance = *v;
    }
    if (const Json* j = wr.get("impacts")) {
      SHATTER_TRY(v, json_input::read_bool(*j, w.key("impacts")));
      scene.world.enable_impacts = *v;
    }
    if (const Json* j = wr.get("seed")) {
      SHATTER_TRY(v, json_input::read_integer(*j, w.key("seed")));
      if (*v < 0) return w.key("seed").error("expected an integer >= 0");
      scene.world.seed = static_cast<std::uint64_t>(*v);
    }
    SHATTER_TRY(done, wr.finish());
  }
  if (const Json* j = r.get("duration")) {
    SHATTER_TRY(v, read_in_range(*j, root.key("duration"), 0, kMaxDuration, "a duration in [0, 86400] s"));
    scene.duration = *v;
  }
  if (const Json* j = r.get("threads")) {
    SHATTER_TRY(v, json_input::read_integer(*j, root.key("threads")));
    if (*v < 0 || *v > 1024) return root.key("threads").error("expected an integer in [0, 1024] (0: all cores)");
    scene.threads = static_cast<int>(*v);
  }
  if (const Json* jg = r.get("ground")) {
    const Where w = root.key("ground");
    if (jg->is_boolean()) {
      scene.ground = jg->get<bool>();
    } else {
      ObjectReader gr(*jg, w);
      if (!gr.status().ok())
        return w.error("expected true, false or {\"height\": y, ...}, got " + json_input::type_name(*jg));
      if (const Json* j = gr.get("height")) {
        SHATTER_TRY(v, json_input::read_number(*j, w.key("height")));
        scene.ground_height = *v;
      }
      SHATTER_TRY(s, read_surface(gr, w, {}));
      scene.ground_surface = *s;
      SHATTER_TRY(done, gr.finish());
    }
  }
  if (const Json* j = r.get("impact")) {
    SHATTER_TRY(v, read_impact(*j, root.key("impact"), scene.world.impact));
    scene.world.impact = *v;
  }
  std::map<std::string, Material> materials;
  if (const Json* jm = r.get("materials")) {
    const Where w = root.key("materials");
    if (!jm->is_object()) return w.error("expected an object of named materials, got " + json_input::type_name(*jm));
    for (const auto& [name, value] : jm->items()) {
      SHATTER_TRY(m, read_material_json(value, w.key(name)));
      materials[name] = std::move(*m);
    }
  }
  const Json* jb = r.get("bodies");
  if (!jb) return root.key("bodies").error("missing; expected an array of bodies");
  {
    const Where w = root.key("bodies");
    SHATTER_TRY(arr, json_input::read_array(*jb, w));
    if ((*arr)->empty()) return w.error("expected at least one body");
    for (std::size_t i = 0; i < (*arr)->size(); ++i) {
      SHATTER_TRY(b, read_body((**arr)[i], w.index(i), scene, materials, base_dir, i));
      SHATTER_TRY(copies, read_array_copies((**arr)[i], w.index(i), *b));
      for (SceneBody& copy : *copies) {
        for (const SceneBody& other : scene.bodies)
          if (other.name == copy.name) return w.index(i).key("name").error("a second body named \"" + copy.name + "\"");
        if (scene.bodies.size() >= kMaxSceneBodies)
          return w.index(i).error("more than " + std::to_string(kMaxSceneBodies) + " bodies in the scene");
        scene.bodies.push_back(std::move(copy));
      }
    }
  }
  if (const Json* ja = r.get("actions")) {
    const Where w = root.key("actions");
    SHATTER_TRY(arr, json_input::read_array(*ja, w));
    for (std::size_t i = 0; i < (*arr)->size(); ++i) {
      SHATTER_TRY(a, read_action((**arr)[i], w.index(i), scene.bodies));
      scene.actions.push_back(*a);
    }
    // By time; actions at the same time keep the file's order.
    std::vector<std::size_t> order(scene.actions.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
      const double tx = scene.actions[x].time, ty = scene.actions[y].time;
      return tx != ty ? tx < ty : x < y;
    });
    std::vector<SceneAction> sorted;
    sorted.reserve(order.size());
    for (const std::size_t i : order) sorted.push_back(scene.actions[i]);
    scene.actions = std::move(sorted);
  }
  if (const Json* jo = r.get("output")) {
    const Where w = root.key("output");
    ObjectReader orr(*jo, w);
    if (!orr.status().ok()) return w.error("expected an object of output settings, got " + json_input::type_name(*jo));
    if (const Json* j = orr.get("frames_per_second")) {
      SHATTER_TRY(v, read_in_range(*j, w.key("frames_per_second"), 0, 10000, "a rate in [0, 10000] (0: no frames)"));
      scene.output.frames_per_second = *v;
    }
    if (const Json* j = orr.get("surfaces")) {
      SHATTER_TRY(v, json_input::read_string(*j, w.key("surfaces")));
      if (*v != "ply" && *v != "obj" && *v != "stl" && !v->empty())
        return w.key("surfaces").error("expected \"ply\", \"obj\", \"stl\" or \"\" (none), got \"" + *v + "\"");
      scene.output.surfaces = *v;
    }
    for (const auto& [key, target] :
         {std::pair{"vtu", &scene.output.vtu}, std::pair{"gltf", &scene.output.gltf},
          std::pair{"events", &scene.output.events}, std::pair{"summary", &scene.output.summary}})
      if (const Json* j = orr.get(key)) {
        SHATTER_TRY(v, json_input::read_bool(*j, w.key(key)));
        *target = *v;
      }
    SHATTER_TRY(done, orr.finish());
  }
  return scene;
}

Result<Scene> read_scene(const std::string& path) {
  SHATTER_TRY(text, read_file(path, kMaxSceneBytes));
  return parse_scene(*text, path, std::filesystem::path(path).parent_path().string());
}

Result<SceneWorld> build_scene(const Scene& scene) {
  SceneWorld out;
  out.world = std::make_unique<World>(scene.world);
  World& w = *out.world;
  if (scene.ground)
    out.ground = w.add_plane({.normal = Vec3::UnitY(), .offset = scene.ground_height}, scene.ground_surface);
  // Bodies that share a file, material and model share one model (and one set of convex pieces).
  std::map<std::string, std::shared_ptr<const TetMesh>> meshes;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const SceneBody& b = scene.bodies[i];
    const std::string what = scene.file + ": body \"" + b.name + "\"";
    const std::string key =
        b.mesh_path.empty() ? b.shape_path + b.shape_text + "@" + std::to_string(b.refine) : b.mesh_path;
    std::shared_ptr<const TetMesh> mesh = meshes[key];
    if (!mesh) {
      if (!b.mesh_path.empty()) {
        auto read = read_mesh(b.mesh_path);
        if (!read) return make_error(what + ": " + read.error().to_string());
        mesh = std::make_shared<const TetMesh>(std::move(read->mesh));
      } else {
        auto shape = b.shape_text.empty()
                         ? read_shape_json(b.shape_path)
                         : parse_shape_json(b.shape_text, b.shape_path,
                                            {.base_dir = std::filesystem::path(scene.file).parent_path().string(),
                                             .load_surface = {}});
        if (!shape) return make_error(what + ": " + shape.error().to_string());
        MeshShapeDef def;
        def.stuffing.edge_length = shape->edge_length / std::cbrt(b.refine);
        def.stuffing.target_tets =
            static_cast<std::int64_t>(std::llround(static_cast<double>(shape->target_tets) * b.refine));
        if (def.stuffing.edge_length <= 0 && def.stuffing.target_tets <= 0) def.stuffing.target_tets = 2000;
        auto meshed = mesh_shape(shape->sdf, def, b.shape_path);
        if (!meshed) return make_error(what + ": " + meshed.error().to_string());
        mesh = std::make_shared<const TetMesh>(std::move(meshed->mesh));
      }
      meshes[key] = mesh;
    }
    // Place the mesh, then move it to its height above the ground.
    TetMesh placed = *mesh;
    for (Vec3& p : placed.positions) p = b.rotation * p + b.position;
    if (b.height) {
      double lowest = std::numeric_limits<double>::infinity();
      for (const Vec3& p : placed.positions) lowest = std::min(lowest, p.y());
      const double dy = scene.ground_height + *b.height - lowest;
      for (Vec3& p : placed.positions) p.y() += dy;
    }
    RigidState rigid;
    auto model = make_body_model(placed, b.material, b.model, &rigid);
    if (!model) return make_error(what + ": " + model.error().to_string());
    rigid.linear_velocity = b.velocity;
    rigid.angular_velocity = b.angular_velocity;
    BodyDef def{.type = b.type,
                .rigid = rigid,
                .surface = b.surface,
                .breakable = b.breakable,
                .impact = std::make_shared<const ImpactSettings>(b.impact),
                .deformable = b.deformable};
    auto shared = std::make_shared<const BodyModel>(std::move(*model));
    if (b.appear > 0) {  // added by apply_due_actions when its time comes
      out.bodies.push_back(BodyId{});
      out.pending.push_back({.body = i, .model = std::move(shared), .def = def});
      continue;
    }
    auto id = w.add_body(std::move(shared), def);
    if (!id) return make_error(what + ": " + id.error().to_string());
    out.bodies.push_back(*id);
  }
  return out;
}

namespace {

// All live tet bodies of the world as one mesh at their poses, with the body slot, the parent
// slot and the plastic strain per tet and the rest (material) coordinates per node.
Result<void> write_frame(const std::string& path, const World& w) {
  TetMesh mesh;
  MeshField body{"body", 1, {}}, parent{"parent", 1, {}}, plastic{"plastic_strain", 1, {}}, rest{"rest", 3, {}},
      stress{"display_stress", 1, {}}, principal{"max_principal", 1, {}};
  for (Index slot = 0; slot < w.body_count(); ++slot) {
    const BodyId id = w.body_id(slot);
    const BodyModel* m = w.model(id);
    if (w.removed(id) || !m) continue;
    const RigidState& r = w.rigid_state(id);
    const Mat3 R = r.orientation.toRotationMatrix();
    const auto base = static_cast<Index>(mesh.positions.size());
    for (const Vec3& p : m->mesh.positions) {
      mesh.positions.emplace_back(r.position + R * p);
      const Vec3 q = m->material_origin + p;
      rest.values.insert(rest.values.end(), {q.x(), q.y(), q.z()});
    }
    const std::span<const double> strain = w.plastic_strain(id);
    const std::span<const double> display = w.display_stress(id);
    const std::span<const double> sigma1 = w.principal_stress(id);
    for (std::size_t e = 0; e < m->mesh.tets.size(); ++e) {
      const TetIndices& t = m->mesh.tets[e];
      mesh.tets.push_back({t[0] + base, t[1] + base, t[2] + base, t[3] + base});
      body.values.push_back(static_cast<double>(slot));
      parent.values.push_back(static_cast<double>(w.parent(id).index));
      plastic.values.push_back(e < strain.size() ? strain[e] : 0.0);
      stress.values.push_back(e < display.size() ? display[e] : 0.0);
      principal.values.push_back(e < sigma1.size() ? sigma1[e] : 0.0);
    }
  }
  MeshWriteOptions options;
  options.binary = true;
  options.fields.tet_fields = {std::move(body), std::move(parent), std::move(plastic), std::move(stress),
                               std::move(principal)};
  options.fields.node_fields = {std::move(rest)};
  return write_mesh(path, mesh, options);
}

// The surfaces of all live tet bodies at their poses, with the body slot and the crack flag of
// each triangle (PLY face properties).
Result<void> write_surfaces(const std::string& path, const World& w) {
  TriSurface all;
  std::vector<std::int32_t> body, crack;
  for (Index slot = 0; slot < w.body_count(); ++slot) {
    const BodyId id = w.body_id(slot);
    if (w.removed(id) || !w.model(id)) continue;
    const BodySurface surf = w.surface(id);
    const auto base = static_cast<Index>(all.positions.size());
    all.positions.insert(all.positions.end(), surf.positions.begin(), surf.positions.end());
    for (std::size_t t = 0; t < surf.triangles.size(); ++t) {
      const TriIndices& tri = surf.triangles[t];
      all.triangles.push_back({tri[0] + base, tri[1] + base, tri[2] + base});
      body.push_back(static_cast<std::int32_t>(slot));
      crack.push_back(surf.crack_face[t]);
    }
  }
  SurfaceWriteOptions options;
  options.binary = true;
  options.face_values = {{"body", std::move(body)}, {"crack", std::move(crack)}};
  return write_surface(path, all, options);
}

Json vec_json(const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }

Json id_json(const BodyId& id) { return id.index; }

// One JSON line per event of the step, each with the time at the end of the step, s.
void collect_events(const StepEvents& ev, double time, std::vector<std::string>& lines) {
  for (const ImpactRecord& e : ev.impacts)
    lines.push_back(Json{
        {"time", time},
        {"type", "impact"},
        {"body", id_json(e.body)},
        {"other", id_json(e.other)},
        {"point", vec_json(e.point)},
        {"approach_speed", e.approach_speed},
        {"impulse", e.impulse},
        {"contact_time", e.contact_time},
        {"force", e.force},
        {"yield_scale", e.yield_scale},
        {"max_principal_stress", e.max_principal_stress},
        {"max_von_mises", e.max_von_mises},
        {"converged", e.converged},
        {"load_fraction", e.load_fraction},
        {"newton_iterations", e.newton_iterations},
        {"dented", e.dented},
        {"cracks", e.cracks},
        {"fragments", e.fragments},
        {"debris_count", e.debris_count},
        {"debris_mass",
         e.debris_mass}}.dump());
  for (const CrackRecord& c : ev.cracks)
    lines.push_back(Json{
        {"time", time},
        {"type", "crack"},
        {"body", id_json(c.body)},
        {"origin", vec_json(c.origin)},
        {"normal", vec_json(c.normal)},
        {"radius", c.radius},
        {"stress",
         c.stress}}.dump());
  for (const FragmentRecord& f : ev.fragments)
    lines.push_back(Json{
        {"time", time},
        {"type", "fragment"},
        {"parent", id_json(f.parent)},
        {"body", id_json(f.body)},
        {"mass",
         f.mass}}.dump());
  for (const BodyId& id : ev.removed)
    lines.push_back(Json{{"time", time}, {"type", "removed"}, {"body", id_json(id)}}.dump());
}

std::string hex64(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

}  // namespace

Result<void> apply_due_actions(const Scene& scene, SceneWorld& built, std::size_t& next_action) {
  World& w = *built.world;
  const double dt = w.settings().time_step;
  for (const SceneWorld::Pending& p : built.pending) {
    BodyId& id = built.bodies[p.body];
    if (id.index >= 0 && w.valid(id)) continue;  // there already
    if (!(scene.bodies[p.body].appear < w.time() + 0.5 * dt)) continue;
    auto added = w.add_body(p.model, p.def);
    if (!added)
      return make_error(scene.file + ": body \"" + scene.bodies[p.body].name + "\" at " +
                        Json(scene.bodies[p.body].appear).dump() + " s: " + added.error().message);
    id = *added;
  }
  while (next_action < scene.actions.size() && scene.actions[next_action].time < w.time() + 0.5 * dt) {
    const SceneAction& a = scene.actions[next_action++];
    const BodyId id = built.bodies[a.body];
    if (id.index < 0 || !w.valid(id) || w.removed(id)) continue;  // not there yet, or broken before
    Vec3 point = a.point;
    if (!a.point_given) {  // the surface point the vector first meets
      const BodySurface surf = w.surface(id);
      const Vec3 dir = a.vector.normalized();
      double best = std::numeric_limits<double>::infinity();
      for (const Vec3& p : surf.positions)
        if (p.dot(dir) < best) {
          best = p.dot(dir);
          point = p;
        }
    }
    Result<void> done;
    switch (a.kind) {
      case SceneAction::Kind::strike: done = w.strike(id, point, a.vector, a.speed, a.radius); break;
      case SceneAction::Kind::press: done = w.press(id, point, a.vector, a.radius, a.duration); break;
      case SceneAction::Kind::impulse: done = w.apply_impulse(id, a.vector, point); break;
    }
    if (!done) return make_error(scene.file + ": action at " + Json(a.time).dump() + " s: " + done.error().message);
  }
  return {};
}

namespace {

// Frames of an earlier, longer run in `out`/frames (frame_<k>.vtu, surface_<k>.*, k >= `count`)
// are removed when `batch` commits, so the folder holds one run.
void remove_stale_frames(OutputBatch& batch, const std::string& out, std::size_t count) {
  std::error_code ec;
  const std::filesystem::path dir = std::filesystem::path(out) / "frames";
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::size_t k = 0;
    char rest[16] = {};
    if ((std::sscanf(name.c_str(), "frame_%zu.%15s", &k, rest) == 2 ||
         std::sscanf(name.c_str(), "surface_%zu.%15s", &k, rest) == 2) &&
        k >= count)
      batch.remove_on_commit(it->path().string());
  }
}

}  // namespace

Result<RunSummary> run_scene(const Scene& scene, const RunOptions& options) {
  const auto t_start = Clock::now();
  SHATTER_TRY(built, build_scene(scene));
  World& w = *built->world;
  RunSummary s;
  const double duration = options.duration.value_or(scene.duration);
  const double dt = scene.world.time_step;
  const auto total_steps = static_cast<std::int64_t>(std::llround(duration / dt));
  const bool write = !options.out_dir.empty();
  // Frames: the ParaView series (and surfaces) and the glTF animation sample the same times.
  const bool frames = write && (scene.output.vtu || scene.output.gltf) && scene.output.frames_per_second > 0;
  const bool vtu = frames && scene.output.vtu;
  GltfRecorder gltf;
  std::vector<std::string> event_lines;
  std::size_t frame_count = 0;
  double last_frame_time = -1;  // s
  // The run's outputs are replaced all together or not at all: every file goes to a temporary
  // beside its target (the series and event log are rewritten at every frame, each time a new
  // temporary), and all are renamed into place when the run ends, also when it is stopped. A
  // run that fails, or a process that is killed, leaves every earlier file as it was.
  std::optional<OutputBatch> batch;
  if (write) {
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(options.out_dir) / (vtu ? "frames" : ""), ec);
    if (ec) return file_error(options.out_dir, "cannot create the output folder: " + ec.message());
    batch.emplace();
  }
  // Names of bodies for the summary: the scene's, and "<parent>.<k>" for fragments.
  std::map<Index, std::string> names;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i)
    if (built->bodies[i].index >= 0) names[built->bodies[i].index] = scene.bodies[i].name;

  const std::string out = options.out_dir;
  PvdSeries series(out + "/scene.pvd");
  auto write_events = [&]() -> Result<void> {
    if (!scene.output.events) return {};
    const auto t0 = Clock::now();
    std::string text;
    for (const std::string& line : event_lines) text += line + "\n";
    SHATTER_TRY(ok, write_file_atomic(out + "/events.jsonl", text));
    s.output_ms += ms_since(t0);
    return {};
  };
  double next_frame = 0;
  auto maybe_frame = [&](bool force) -> Result<void> {
    if (!frames) return {};
    const double t = w.time();
    if (!force && t + 0.5 * dt < next_frame) return {};
    const auto t0 = Clock::now();
    if (vtu) {
      char name[64];
      std::snprintf(name, sizeof name, "frames/frame_%06zu.vtu", frame_count);
      SHATTER_TRY(ok, write_frame(out + "/" + name, w));
      SHATTER_TRY(listed, series.add(t, name));
      if (!scene.output.surfaces.empty()) {
        char surface_name[64];
        std::snprintf(surface_name, sizeof surface_name, "frames/surface_%06zu.%s", frame_count,
                      scene.output.surfaces.c_str());
        SHATTER_TRY(wrote, write_surfaces(out + "/" + surface_name, w));
      }
    }
    if (scene.output.gltf) gltf.add_frame(w);
    ++frame_count;
    last_frame_time = t;
    next_frame = static_cast<double>(frame_count) / scene.output.frames_per_second;
    s.output_ms += ms_since(t0);
    return write_events();
  };
  if (write) {
    SHATTER_TRY(first, maybe_frame(true));
  }

  std::size_t next_action = 0;
  while (s.steps < total_steps) {
    if (options.stop && options.stop->load()) {
      s.stopped = true;
      break;
    }
    SHATTER_TRY(acted, apply_due_actions(scene, *built, next_action));
    for (std::size_t i = 0; i < scene.bodies.size(); ++i)  // bodies that appeared
      if (built->bodies[i].index >= 0 && !names.contains(built->bodies[i].index))
        names[built->bodies[i].index] = scene.bodies[i].name;
    w.step();
    ++s.steps;
    const StepStats& st = w.stats();
    s.rigid_ms += st.broad_phase_ms + st.narrow_phase_ms + st.solver_ms;
    s.impact_ms += st.impact_ms;
    s.deformable_ms += st.deformable_ms;
    const StepEvents& ev = w.events();
    s.impacts += static_cast<Index>(ev.impacts.size());
    s.cracks += static_cast<Index>(ev.cracks.size());
    s.fragments += static_cast<Index>(ev.fragments.size());
    for (const ImpactRecord& e : ev.impacts) {
      s.debris_mass += e.debris_mass;
      if (e.load_fraction < 1.0) ++s.impacts_partly_solved;
    }
    std::map<Index, int> child_count;
    for (const FragmentRecord& f : ev.fragments)
      names[f.body.index] = names[f.parent.index] + "." + std::to_string(++child_count[f.parent.index]);
    if (write && scene.output.events) collect_events(ev, w.time(), event_lines);
    if (write) {
      SHATTER_TRY(framed, maybe_frame(false));
    }
    if (options.progress) options.progress(w.time(), s.steps, w.live_body_count() - (scene.ground ? 1 : 0));
  }
  s.simulated_time = w.time();
  s.bodies = w.live_body_count() - (scene.ground ? 1 : 0);
  s.state_hash = w.state_hash();
  if (write) {
    if (frames && last_frame_time + 0.5 * dt < w.time()) {
      SHATTER_TRY(last, maybe_frame(true));
    }
    SHATTER_TRY(listed, write_events());
    if (vtu) s.files.push_back(out + "/scene.pvd");
    if (frames && scene.output.gltf) {
      const auto t0 = Clock::now();
      SHATTER_TRY(glb, write_file_atomic(out + "/scene.glb", gltf.glb()));
      s.output_ms += ms_since(t0);
      s.files.push_back(out + "/scene.glb");
    }
    if (scene.output.events) s.files.push_back(out + "/events.jsonl");
    if (scene.output.summary) {
      Json bodies = Json::array();
      for (Index slot = 0; slot < w.body_count(); ++slot) {
        const BodyId id = w.body_id(slot);
        const BodyModel* m = w.model(id);
        if (!m || w.removed(id)) continue;
        const RigidState& r = w.rigid_state(id);
        bodies.push_back({{"id", slot},
                          {"name", names[slot]},
                          {"parent", w.parent(id).index},
                          {"mass", m->mass.mass},
                          {"tets", m->mesh.num_tets()},
                          {"position", vec_json(r.position)},
                          {"orientation",
                           Json::array({r.orientation.w(), r.orientation.x(), r.orientation.y(), r.orientation.z()})}});
      }
      s.wall_ms = ms_since(t_start);
      const Json summary{{"scene", scene.name},
                         {"file", scene.file},
                         {"steps", s.steps},
                         {"simulated_time", s.simulated_time},
                         {"stopped", s.stopped},
                         {"bodies", bodies},
                         {"live_bodies", s.bodies},
                         {"fragments_born", s.fragments},
                         {"impacts", s.impacts},
                         {"impacts_partly_solved", s.impacts_partly_solved},
                         {"cracks", s.cracks},
                         {"debris_mass", s.debris_mass},
                         {"frames", frame_count},
                         {"timings_ms",
                          {{"rigid", s.rigid_ms},
                           {"impacts", s.impact_ms},
                           {"deformable", s.deformable_ms},
                           {"output", s.output_ms},
                           {"wall", s.wall_ms}}},
                         {"state_hash", hex64(s.state_hash)}};
      SHATTER_TRY(ok, write_file_atomic(out + "/summary.json", summary.dump(2) + "\n"));
      s.files.push_back(out + "/summary.json");
    }
    remove_stale_frames(*batch, out, frame_count);
    SHATTER_TRY(committed, batch->commit());
  }
  s.wall_ms = ms_since(t_start);
  return s;
}

}  // namespace shatter
