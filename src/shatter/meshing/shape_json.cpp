// Shape JSON: parse a CSG tree into an Sdf, checking every value and naming its JSON path (the
// strict reader of core/json_reader.h: type and range checks, unknown keys, file + path errors).
#include "shatter/meshing/shape_json.h"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "shatter/core/file_io.h"
#include "shatter/core/json_reader.h"
#include "shatter/meshing/surface_sdf.h"

namespace shatter {
namespace {

using json_input::Json;
using json_input::ObjectReader;
using json_input::Where;

constexpr const char* kShapeTypes =
    "sphere, box, cylinder, capsule, cone, torus, ellipsoid, revolution, extrusion, surface, union, difference, "
    "intersection, smooth_union";

// The value at `key`, or an error "missing; expected <expected>" at its path.
Result<const Json*> required(ObjectReader& r, std::string_view key, const std::string& expected) {
  const Json* v = r.get(key);
  if (!v) return r.where().key(key).error("missing; expected " + expected);
  return v;
}

// A required length (m) or other strictly positive number.
Result<double> positive(ObjectReader& r, std::string_view key) {
  SHATTER_TRY(v, required(r, key, "a number > 0"));
  return json_input::read_positive(**v, r.where().key(key));
}

// A required [x, y, z] of positive numbers (sizes, radii; m).
Result<Vec3> positive_vec3(ObjectReader& r, std::string_view key) {
  SHATTER_TRY(v, required(r, key, "an array of 3 numbers [x, y, z], each > 0"));
  return json_input::read_positive_vec3(**v, r.where().key(key));
}

// A required closed polygon of [x, y] points (m); for a revolution the points are (r, y), r >= 0.
Result<std::vector<Vec2>> polygon(ObjectReader& r, std::string_view key, bool revolution) {
  SHATTER_TRY(v, required(r, key, "an array of [x, y] points"));
  const Where w = r.where().key(key);
  SHATTER_TRY(arr, json_input::read_array(**v, w));
  std::vector<Vec2> pts;
  pts.reserve((*arr)->size());
  for (std::size_t i = 0; i < (*arr)->size(); ++i) {
    SHATTER_TRY(p, json_input::read_vec2((**arr)[i], w.index(i)));
    pts.push_back(*p);
  }
  if (auto ok = check_polygon(pts, revolution, w.path); !ok) {
    Error e = std::move(ok.error());  // names the path (and the point) already; add the file
    e.file = *w.file;
    return e;
  }
  return pts;
}

// Loads {"type": "surface", "file": ...}; errors of the surface itself name the surface file and
// this node's "file" path.
Result<Sdf> surface(ObjectReader& r, const ShapeJsonOptions& options) {
  SHATTER_TRY(v, required(r, "file", "the path of a closed surface (.obj, .ply, .stl)"));
  const Where w = r.where().key("file");
  SHATTER_TRY(name, json_input::read_string(**v, w));
  if (!options.load_surface) return w.error("surface files cannot be loaded here (no surface reader)");
  std::filesystem::path f = *name;
  if (f.is_relative() && !options.base_dir.empty()) f = std::filesystem::path(options.base_dir) / f;
  auto surf = options.load_surface(f.string());
  if (!surf) {
    Error e = std::move(surf.error());
    e.field = w.path;
    return e;
  }
  auto dist = SurfaceDistance::create(*surf, f.string());
  if (!dist) {
    Error e = std::move(dist.error());
    e.field = w.path;
    return e;
  }
  return Sdf::surface(std::move(*dist));
}

Result<Sdf> node(const Json& j, const Where& where, const ShapeJsonOptions& options) {
  ObjectReader r(j, where);
  if (!r.status().ok()) return r.status().error();
  // Every node may carry transforms and a comment; the type decides the other keys.
  const Json* jtranslate = r.get("translate");
  const Json* jrotate = r.get("rotate");
  const Json* jscale = r.get("scale");
  r.allow({"comment"});
  SHATTER_TRY(jtype, required(r, "type", std::string("one of ") + kShapeTypes));
  SHATTER_TRY(type_read, json_input::read_string(**jtype, where.key("type")));
  const std::string& type = *type_read;
  Sdf s;
  if (type == "sphere") {
    SHATTER_TRY(radius, positive(r, "radius"));
    s = Sdf::sphere(*radius);
  } else if (type == "box") {
    SHATTER_TRY(size, positive_vec3(r, "size"));
    s = Sdf::box(0.5 * *size);
  } else if (type == "cylinder" || type == "capsule" || type == "cone") {
    SHATTER_TRY(radius, positive(r, "radius"));
    SHATTER_TRY(height, positive(r, "height"));
    s = type == "cylinder"  ? Sdf::cylinder(*radius, 0.5 * *height)
        : type == "capsule" ? Sdf::capsule(*radius, 0.5 * *height)
                            : Sdf::cone(*radius, *height);
  } else if (type == "torus") {
    SHATTER_TRY(big, positive(r, "major_radius"));
    SHATTER_TRY(small, positive(r, "minor_radius"));
    if (!(*small < *big)) return where.key("minor_radius").error("expected minor_radius < major_radius");
    s = Sdf::torus(*big, *small);
  } else if (type == "ellipsoid") {
    SHATTER_TRY(radii, positive_vec3(r, "radii"));
    s = Sdf::ellipsoid(*radii);
  } else if (type == "revolution") {
    SHATTER_TRY(profile, polygon(r, "profile", true));
    s = Sdf::revolution(std::move(*profile));
  } else if (type == "extrusion") {
    SHATTER_TRY(poly, polygon(r, "polygon", false));
    SHATTER_TRY(depth, positive(r, "depth"));
    s = Sdf::extrusion(std::move(*poly), 0.5 * *depth);
  } else if (type == "surface") {
    SHATTER_TRY(surf, surface(r, options));
    s = std::move(*surf);
  } else if (type == "union" || type == "difference" || type == "intersection" || type == "smooth_union") {
    const Where wc = where.key("children");
    const Json* jc = r.get("children");
    if (!jc || (jc->is_array() && jc->empty())) return wc.error("missing or empty; expected an array of shapes");
    SHATTER_TRY(arr, json_input::read_array(*jc, wc));
    std::vector<Sdf> children;
    for (std::size_t i = 0; i < (*arr)->size(); ++i) {
      SHATTER_TRY(child, node((**arr)[i], wc.index(i), options));
      children.push_back(std::move(*child));
    }
    if (type == "union")
      s = Sdf::unite(std::move(children));
    else if (type == "difference")
      s = Sdf::subtract(std::move(children));
    else if (type == "intersection")
      s = Sdf::intersect(std::move(children));
    else {
      SHATTER_TRY(blend, positive(r, "blend"));
      s = Sdf::smooth_unite(std::move(children), *blend);
    }
    // "blend" is accepted (and unused) on the plain operations too, so that a smooth_union
    // becomes a union by changing its type alone.
    r.allow({"blend"});
  } else {
    return where.key("type").error("unknown shape type \"" + type + "\"; expected one of " + kShapeTypes);
  }
  SHATTER_TRY(done, r.finish());
  // Transforms: scale, then rotate (degrees about X, then Y, then Z), then translate (m).
  if (jtranslate || jrotate || jscale) {
    Vec3 translate = Vec3::Zero(), rotate = Vec3::Zero();
    double scale = 1.0;
    if (jtranslate) {
      SHATTER_TRY(t, json_input::read_vec3(*jtranslate, where.key("translate")));
      translate = *t;
    }
    if (jrotate) {
      SHATTER_TRY(d, json_input::read_vec3(*jrotate, where.key("rotate")));
      rotate = *d;
    }
    if (jscale) {
      SHATTER_TRY(k, json_input::read_positive(*jscale, where.key("scale")));
      scale = *k;
    }
    s = s.transformed(translate, rotation_from_euler_deg(rotate), scale);
  }
  return s;
}

}  // namespace

Result<ShapeFile> parse_shape_json(std::string_view text, const std::string& file_name,
                                   const ShapeJsonOptions& options) {
  auto doc = json_input::parse_json(text, file_name);
  if (!doc) {
    // Shape files report a syntax error as "file: invalid JSON: ... (line N)" (the form the CLI
    // prints and its tests match), so the line goes into the message rather than "file:N:".
    Error e = std::move(doc.error());
    if (e.line >= 0) e.message += " (line " + std::to_string(e.line) + ")";
    e.line = -1;
    return e;
  }
  // A whole-file error, without a field (not "(top level)").
  if (!doc->is_object())
    return file_error(file_name, "expected a JSON object with a \"shape\", got " + json_input::type_name(*doc));
  const Where root{&file_name, ""};
  ObjectReader r(*doc, root);
  const Json* jname = r.get("name");
  const Json* jedge = r.get("edge_length");
  const Json* jtets = r.get("tets");
  const Json* jgrading = r.get("grading");
  const Json* jsharpen = r.get("sharpen");
  const Json* jshape = r.get("shape");
  r.allow({"comment"});
  // Unknown keys first: a misspelt "shape" reads better as a typo than as a missing key.
  SHATTER_TRY(done, r.finish());
  ShapeFile out;
  if (jname) {
    SHATTER_TRY(name, json_input::read_string(*jname, root.key("name")));
    out.name = std::move(*name);
  }
  if (jedge) {
    SHATTER_TRY(h, json_input::read_positive(*jedge, root.key("edge_length")));
    out.edge_length = *h;
  }
  if (jtets) {
    const Where w = root.key("tets");
    SHATTER_TRY(n, json_input::read_integer(*jtets, w));
    if (*n <= 0) return w.error("expected an integer > 0, got " + std::to_string(*n));
    out.target_tets = *n;
  }
  if (jgrading) {
    SHATTER_TRY(g, json_input::read_non_negative(*jgrading, root.key("grading")));
    out.grading = *g;
  }
  if (jsharpen) {
    SHATTER_TRY(sharpen, json_input::read_bool(*jsharpen, root.key("sharpen")));
    out.sharpen = *sharpen;
  }
  if (!jshape) return root.key("shape").error("missing; expected a shape object");
  SHATTER_TRY(s, node(*jshape, root.key("shape"), options));
  out.sdf = std::move(*s);
  return out;
}

Result<ShapeFile> read_shape_json(const std::string& path, SurfaceLoader load_surface) {
  SHATTER_TRY(text, read_file(path));
  ShapeJsonOptions options;
  options.base_dir = std::filesystem::path(path).parent_path().string();
  options.load_surface = std::move(load_surface);
  return parse_shape_json(*text, path, options);
}

}  // namespace shatter
