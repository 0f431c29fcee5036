// Shape JSON: parse a CSG tree into an Sdf, checking every value and naming its JSON path.
#include "shatter/meshing/shape_json.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "shatter/core/file_io.h"
#include "shatter/meshing/surface_sdf.h"

namespace shatter {
namespace {

using Json = nlohmann::json;

struct Parser {
  std::string file;
  const ShapeJsonOptions& options;

  Error error(const std::string& path, const std::string& message) const {
    Error e = field_error(path, message);
    e.file = file;
    return e;
  }

  Result<double> number(const Json& node, const std::string& path, const char* key, bool positive,
                        std::optional<double> fallback = std::nullopt) const {
    const std::string p = path.empty() ? std::string(key) : path + "." + key;
    if (!node.contains(key)) {
      if (fallback) return *fallback;
      return error(p, "missing; expected a number");
    }
    const Json& v = node.at(key);
    if (!v.is_number()) return error(p, "expected a number, got " + std::string(v.type_name()));
    const double x = v.get<double>();
    if (!std::isfinite(x)) return error(p, "expected a finite number");
    if (positive && !(x > 0)) return error(p, "expected a number > 0, got " + v.dump());
    return x;
  }

  Result<Vec3> vec3(const Json& node, const std::string& path, const char* key, bool positive,
                    std::optional<Vec3> fallback = std::nullopt) const {
    const std::string p = path.empty() ? std::string(key) : path + "." + key;
    if (!node.contains(key)) {
      if (fallback) return *fallback;
      return error(p, "missing; expected an array of 3 numbers");
    }
    const Json& v = node.at(key);
    if (!v.is_array() || v.size() != 3) return error(p, "expected an array of 3 numbers");
    Vec3 x;
    for (int i = 0; i < 3; ++i) {
      if (!v[i].is_number()) return error(p + "[" + std::to_string(i) + "]", "expected a number");
      x[i] = v[i].get<double>();
      if (!std::isfinite(x[i])) return error(p + "[" + std::to_string(i) + "]", "expected a finite number");
      if (positive && !(x[i] > 0)) return error(p + "[" + std::to_string(i) + "]", "expected a number > 0");
    }
    return x;
  }

  Result<std::vector<Vec2>> polygon(const Json& node, const std::string& path, const char* key,
                                    bool revolution) const {
    const std::string p = path.empty() ? std::string(key) : path + "." + key;
    if (!node.contains(key)) return error(p, "missing; expected an array of [x, y] points");
    const Json& v = node.at(key);
    if (!v.is_array()) return error(p, "expected an array of [x, y] points");
    std::vector<Vec2> pts;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const std::string pi = p + "[" + std::to_string(i) + "]";
      if (!v[i].is_array() || v[i].size() != 2 || !v[i][0].is_number() || !v[i][1].is_number())
        return error(pi, "expected a point [x, y] of 2 numbers");
      pts.emplace_back(v[i][0].get<double>(), v[i][1].get<double>());
    }
    auto ok = check_polygon(pts, revolution, p);
    if (!ok) return error(ok.error().field, ok.error().message);
    return pts;
  }

  Result<Sdf> node(const Json& j, const std::string& path) const {
    if (!j.is_object()) return error(path, "expected an object with a \"type\"");
    if (!j.contains("type") || !j.at("type").is_string())
      return error(path + ".type", "missing; expected one of sphere, box, cylinder, capsule, cone, torus, "
                                   "ellipsoid, revolution, extrusion, surface, union, difference, "
                                   "intersection, smooth_union");
    const std::string type = j.at("type").get<std::string>();
    std::set<std::string> allowed = {"type", "translate", "rotate", "scale", "comment"};
    auto allow = [&](std::initializer_list<const char*> keys) {
      for (const char* k : keys) allowed.insert(k);
    };
    Sdf s;
    if (type == "sphere") {
      allow({"radius"});
      SHATTER_TRY(r, number(j, path, "radius", true));
      s = Sdf::sphere(*r);
    } else if (type == "box") {
      allow({"size"});
      SHATTER_TRY(v, vec3(j, path, "size", true));
      s = Sdf::box(0.5 * *v);
    } else if (type == "cylinder" || type == "capsule" || type == "cone") {
      allow({"radius", "height"});
      SHATTER_TRY(r, number(j, path, "radius", true));
      SHATTER_TRY(hh, number(j, path, "height", true));
      s = type == "cylinder" ? Sdf::cylinder(*r, 0.5 * *hh)
          : type == "capsule" ? Sdf::capsule(*r, 0.5 * *hh)
                              : Sdf::cone(*r, *hh);
    } else if (type == "torus") {
      allow({"major_radius", "minor_radius"});
      SHATTER_TRY(big, number(j, path, "major_radius", true));
      SHATTER_TRY(small, number(j, path, "minor_radius", true));
      if (!(*small < *big)) return error(path + ".minor_radius", "expected minor_radius < major_radius");
      s = Sdf::torus(*big, *small);
    } else if (type == "ellipsoid") {
      allow({"radii"});
      SHATTER_TRY(v, vec3(j, path, "radii", true));
      s = Sdf::ellipsoid(*v);
    } else if (type == "revolution") {
      allow({"profile"});
      SHATTER_TRY(poly, polygon(j, path, "profile", true));
      s = Sdf::revolution(std::move(*poly));
    } else if (type == "extrusion") {
      allow({"polygon", "depth"});
      SHATTER_TRY(poly, polygon(j, path, "polygon", false));
      SHATTER_TRY(d, number(j, path, "depth", true));
      s = Sdf::extrusion(std::move(*poly), 0.5 * *d);
    } else if (type == "surface") {
      allow({"file"});
      if (!j.contains("file") || !j.at("file").is_string())
        return error(path + ".file", "missing; expected the path of a closed surface (.obj, .ply, .stl)");
      if (!options.load_surface)
        return error(path + ".file", "surface files cannot be loaded here (no surface reader)");
      std::filesystem::path f = j.at("file").get<std::string>();
      if (f.is_relative() && !options.base_dir.empty()) f = std::filesystem::path(options.base_dir) / f;
      auto surf = options.load_surface(f.string());
      if (!surf) {
        Error e = surf.error();
        e.field = path + ".file";
        return e;
      }
      auto dist = SurfaceDistance::create(*surf, f.string());
      if (!dist) {
        Error e = dist.error();
        e.field = path + ".file";
        return e;
      }
      s = Sdf::surface(std::move(*dist));
    } else if (type == "union" || type == "difference" || type == "intersection" || type == "smooth_union") {
      allow({"children", "blend"});
      const std::string cp = path + ".children";
      if (!j.contains("children") || !j.at("children").is_array() || j.at("children").empty())
        return error(cp, "missing or empty; expected an array of shapes");
      std::vector<Sdf> children;
      const Json& c = j.at("children");
      for (std::size_t i = 0; i < c.size(); ++i) {
        SHATTER_TRY(child, node(c[i], cp + "[" + std::to_string(i) + "]"));
        children.push_back(std::move(*child));
      }
      if (type == "union") s = Sdf::unite(std::move(children));
      else if (type == "difference") s = Sdf::subtract(std::move(children));
      else if (type == "intersection") s = Sdf::intersect(std::move(children));
      else {
        SHATTER_TRY(k, number(j, path, "blend", true));
        s = Sdf::smooth_unite(std::move(children), *k);
      }
    } else {
      return error(path + ".type", "unknown shape type \"" + type + "\"; expected one of sphere, box, "
                   "cylinder, capsule, cone, torus, ellipsoid, revolution, extrusion, surface, union, "
                   "difference, intersection, smooth_union");
    }
    for (const auto& [key, value] : j.items())
      if (!allowed.count(key)) return error(path + "." + key, "unknown key for a " + type);
    // Transforms: scale, then rotate (degrees about X, then Y, then Z), then translate.
    SHATTER_TRY(t, vec3(j, path, "translate", false, Vec3::Zero()));
    SHATTER_TRY(r, vec3(j, path, "rotate", false, Vec3::Zero()));
    SHATTER_TRY(sc, number(j, path, "scale", true, 1.0));
    if (j.contains("translate") || j.contains("rotate") || j.contains("scale"))
      s = s.transformed(*t, rotation_from_euler_deg(*r), *sc);
    return s;
  }
};

}  // namespace

Result<ShapeFile> parse_shape_json(std::string_view text, const std::string& file_name,
                                   const ShapeJsonOptions& options) {
  Json j;
  try {
    j = Json::parse(text.begin(), text.end());
  } catch (const Json::parse_error& e) {
    Error err = file_error(file_name, std::string("invalid JSON: ") + e.what());
    return err;
  }
  Parser p{file_name, options};
  if (!j.is_object()) return p.error("", "expected a JSON object with a \"shape\"");
  for (const auto& [key, value] : j.items())
    if (key != "name" && key != "shape" && key != "edge_length" && key != "tets" && key != "grading" && key != "sharpen" &&
        key != "comment")
      return p.error(key, "unknown key; expected name, shape, edge_length, tets, grading, sharpen, comment");
  ShapeFile out;
  if (j.contains("name")) {
    if (!j.at("name").is_string()) return p.error("name", "expected a string");
    out.name = j.at("name").get<std::string>();
  }
  if (j.contains("edge_length")) {
    SHATTER_TRY(h, p.number(j, "", "edge_length", true));
    out.edge_length = *h;
  }
  if (j.contains("tets")) {
    const Json& t = j.at("tets");
    if (!t.is_number_integer() || t.get<std::int64_t>() <= 0) return p.error("tets", "expected an integer > 0");
    out.target_tets = t.get<std::int64_t>();
  }
  if (j.contains("grading")) {
    const Json& g = j.at("grading");
    if (!g.is_number() || !(g.get<double>() >= 0) || !std::isfinite(g.get<double>()))
      return p.error("grading", "expected a number >= 0");
    out.grading = g.get<double>();
  }
  if (j.contains("sharpen")) {
    if (!j.at("sharpen").is_boolean()) return p.error("sharpen", "expected true or false");
    out.sharpen = j.at("sharpen").get<bool>();
  }
  if (!j.contains("shape")) return p.error("shape", "missing; expected a shape object");
  SHATTER_TRY(s, p.node(j.at("shape"), "shape"));
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
