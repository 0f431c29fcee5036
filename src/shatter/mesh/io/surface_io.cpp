// Triangle surfaces: OBJ, PLY (ASCII / binary LE / binary BE) and STL (ASCII / binary) read and
// written; polygons are fan-triangulated on read; STL vertices are welded where exactly equal.
// Binary PLY and STL are written little-endian (append_binary(..., big_endian = false)).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <ostream>
#include <string>
#include <unordered_map>

#include "shatter/core/file_io.h"
#include "shatter/mesh/io/io_util.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/scalar_type.h"
#include "shatter/mesh/io/text_cursor.h"

namespace shatter {
namespace {

using io::ByteCursor;
using io::Scalar;
using io::ScalarType;
using io::TextCursor;

Result<void> check_surface(const TriSurface& s, const SurfaceWriteOptions& options) {
  const auto n = static_cast<std::int64_t>(s.positions.size());
  for (std::size_t t = 0; t < s.triangles.size(); ++t)
    for (Index v : s.triangles[t])
      if (v < 0 || v >= n)
        return make_error("surface triangle " + std::to_string(t) + " uses vertex " + std::to_string(v) + " of " +
                          std::to_string(n));
  if (!options.vertex_ids.empty() && options.vertex_ids.size() != s.positions.size())
    return make_error("surface vertex_ids has " + std::to_string(options.vertex_ids.size()) + " entries for " +
                      std::to_string(n) + " vertices");
  for (const auto& [name, values] : options.face_values) {
    if (values.size() != s.triangles.size())
      return make_error("surface face values \"" + name + "\" has " + std::to_string(values.size()) + " entries for " +
                        std::to_string(s.triangles.size()) + " triangles");
    if (name.empty() || name.find_first_of(" \t\r\n") != std::string::npos)
      return make_error("surface face values need a name without spaces, got \"" + name + "\"");
  }
  return {};
}

void flush_if_big(std::ostream& out, std::string& s) {
  if (s.size() > (1u << 16)) {
    out << s;
    s.clear();
  }
}

Vec3 unit_normal(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double len = n.norm();
  return len > 0 && std::isfinite(len) ? Vec3(n / len) : Vec3::Zero();
}

/// Resolves raw 0-based vertex references once all vertices are known; `where` is a line
/// (text) or byte offset (binary) for the error message.
struct RawTriangles {
  std::vector<std::array<std::int64_t, 3>> tris;
  std::vector<std::int64_t> where;
  void add(std::int64_t a, std::int64_t b, std::int64_t c, std::int64_t w) {
    tris.push_back({a, b, c});
    where.push_back(w);
  }
  Result<void> resolve(TriSurface& s, const std::function<Error(std::int64_t, std::string)>& error) const {
    const auto n = static_cast<std::int64_t>(s.positions.size());
    s.triangles.reserve(tris.size());
    for (std::size_t t = 0; t < tris.size(); ++t) {
      TriIndices tri{};
      for (int k = 0; k < 3; ++k) {
        if (tris[t][k] < 0 || tris[t][k] >= n)
          return error(where[t], "face uses vertex " + std::to_string(tris[t][k] + 1) + " (1-based), but there are " +
                                     std::to_string(n) + " vertices");
        tri[k] = static_cast<Index>(tris[t][k]);
      }
      s.triangles.push_back(tri);
    }
    return {};
  }
};

std::vector<std::string_view> split_blanks(std::string_view l) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  auto blank = [](char ch) { return ch == ' ' || ch == '\t' || ch == '\r' || ch == '\f' || ch == '\v'; };
  while (i < l.size()) {
    while (i < l.size() && blank(l[i])) ++i;
    const std::size_t s = i;
    while (i < l.size() && !blank(l[i])) ++i;
    if (i > s) out.push_back(l.substr(s, i - s));
  }
  return out;
}

// ---------------------------------------------------------------- PLY
struct PlyProperty {
  std::string name;
  ScalarType type = ScalarType::f32;
  bool is_list = false;
  ScalarType count_type = ScalarType::u8;
};
struct PlyElement {
  std::string name;
  std::int64_t count = 0;
  std::int64_t line = 0;
  std::vector<PlyProperty> props;
};

class PlyBody {
 public:
  PlyBody(std::string_view bytes, const std::string& name, std::size_t start, int format, const TextCursor& header)
      : text_(header), bytes_(bytes, name, start, format == 2), format_(format) {}

  /// Where the next row starts: its line (ASCII) or byte offset (binary).
  std::int64_t where() {
    if (format_ != 0) return static_cast<std::int64_t>(bytes_.position());
    text_.skip_space();
    return text_.line();
  }
  Error error(const std::string& m) const { return format_ == 0 ? text_.error(m) : bytes_.error(m); }
  std::size_t remaining() const { return format_ == 0 ? text_.remaining() : bytes_.remaining(); }
  bool ascii() const { return format_ == 0; }

  Result<Scalar> read(ScalarType t, const char* what) {
    if (format_ == 0) {
      Scalar v;
      if (io::is_float(t)) {
        SHATTER_TRY(d, text_.next_double(what));
        v.is_int = false;
        v.d = *d;
      } else {
        SHATTER_TRY(i, text_.next_int(what));
        v.i = *i;
      }
      return v;
    }
    SHATTER_TRY(v, io::read_scalar(bytes_, t, what));
    if (!v->is_int && !std::isfinite(v->d)) return bytes_.error(std::string("expected ") + what + " (a finite number)");
    return *v;
  }

  /// The item count of a list, checked against the bytes that remain.
  Result<std::int64_t> list_count(const PlyProperty& p) {
    SHATTER_TRY(v, read(p.count_type, "list length"));
    if (!v->is_int || v->i < 0) return error("expected a list length >= 0");
    const std::int64_t min_bytes = format_ == 0 ? 2 : static_cast<std::int64_t>(io::scalar_size(p.type));
    if (v->i > (static_cast<std::int64_t>(remaining()) + 1) / min_bytes)
      return error("list length " + std::to_string(v->i) + " is larger than the " + std::to_string(remaining()) +
                   " bytes that follow can hold");
    return v->i;
  }

 private:
  TextCursor text_;
  ByteCursor bytes_;
  int format_;  // 0 ascii, 1 binary LE, 2 binary BE
};

}  // namespace

// ---------------------------------------------------------------- OBJ
Result<SurfaceReadResult> parse_obj(std::string_view bytes, const std::string& name) {
  SurfaceReadResult result;
  result.format = "obj";
  TriSurface& s = result.surface;
  TextCursor c(bytes, name);
  RawTriangles raw;
  std::int64_t polygons = 0, lines = 0, points = 0, short_faces = 0;
  std::vector<std::int64_t> face;
  while (!c.at_end()) {
    const std::int64_t line = c.line();
    std::string_view l = c.next_line();
    if (const auto h = l.find('#'); h != std::string_view::npos) l = l.substr(0, h);
    const auto tok = split_blanks(l);
    if (tok.empty()) continue;
    if (tok[0] == "v") {
      if (tok.size() < 4) return c.error_at(line, "expected 'v x y z'");
      Vec3 p;
      for (int k = 0; k < 3; ++k)
        if (!io::parse_double(tok[1 + k], p[k]))
          return c.error_at(line,
                            "expected a vertex coordinate (a finite number), found " + io::quote_token(tok[1 + k]));
      if (s.positions.size() >= static_cast<std::size_t>(io::kMaxEntities))
        return c.error_at(line, "too many vertices");
      s.positions.push_back(p);
    } else if (tok[0] == "f") {
      face.clear();
      for (std::size_t k = 1; k < tok.size(); ++k) {
        const std::string_view ref = tok[k].substr(0, tok[k].find('/'));
        std::int64_t v = 0;
        if (!io::parse_int(ref, v) || v == 0)
          return c.error_at(line, "expected a vertex index (a non-zero integer), found " + io::quote_token(tok[k]));
        // Negative: relative to the vertices defined so far.
        const std::int64_t index = v > 0 ? v - 1 : static_cast<std::int64_t>(s.positions.size()) + v;
        if (v < 0 && index < 0)
          return c.error_at(line, "relative vertex index " + std::to_string(v) + " reaches before the first vertex");
        face.push_back(index);
      }
      if (face.size() < 3) {
        ++short_faces;
        continue;
      }
      if (face.size() > 3) ++polygons;
      for (std::size_t k = 1; k + 1 < face.size(); ++k) raw.add(face[0], face[k], face[k + 1], line);
      if (raw.tris.size() > static_cast<std::size_t>(io::kMaxEntities)) return c.error_at(line, "too many faces");
    } else if (tok[0] == "l") {
      ++lines;
    } else if (tok[0] == "p") {
      ++points;
    }
  }
  SHATTER_TRY(ok, raw.resolve(s, [&](std::int64_t line, const std::string& m) { return c.error_at(line, m); }));
  if (polygons) result.skipped.push_back("polygons triangulated: " + std::to_string(polygons));
  if (lines) result.skipped.push_back(std::to_string(lines) + " lines");
  if (points) result.skipped.push_back(std::to_string(points) + " points");
  if (short_faces) result.skipped.push_back(std::to_string(short_faces) + " faces with fewer than 3 vertices");
  return result;
}

Result<void> write_obj(std::ostream& out, const TriSurface& surface, const SurfaceWriteOptions& options) {
  SHATTER_TRY(ok, check_surface(surface, options));
  std::string s = "# " + std::to_string(surface.positions.size()) + " vertices, " +
                  std::to_string(surface.triangles.size()) + " triangles\n";
  for (const Vec3& p : surface.positions) {
    s += 'v';
    for (int k = 0; k < 3; ++k) {
      s += ' ';
      io::append_double(s, p[k]);
    }
    s += '\n';
    flush_if_big(out, s);
  }
  if (!options.vertex_ids.empty()) {
    s += "# vertex ids, in vertex order:\n";
    for (std::size_t i = 0; i < options.vertex_ids.size(); ++i) {
      s += (i % 16 == 0) ? "# " : " ";
      io::append_int(s, options.vertex_ids[i]);
      if (i % 16 == 15 || i + 1 == options.vertex_ids.size()) s += '\n';
      flush_if_big(out, s);
    }
  }
  for (const TriIndices& t : surface.triangles) {
    s += 'f';
    for (Index v : t) {
      s += ' ';
      io::append_int(s, static_cast<std::int64_t>(v) + 1);
    }
    s += '\n';
    flush_if_big(out, s);
  }
  out << s;
  return {};
}

// ---------------------------------------------------------------- PLY
Result<SurfaceReadResult> parse_ply(std::string_view bytes, const std::string& name) {
  SurfaceReadResult result;
  TriSurface& s = result.surface;
  TextCursor c(bytes, name);
  if (c.at_end()) return c.error("empty file: expected 'ply'");
  if (io::trim(c.next_line()) != "ply") return c.error_at(1, "expected 'ply' on the first line");
  int format = -1;
  std::vector<PlyElement> elements;
  while (true) {
    if (c.at_end()) return c.error("file ends before 'end_header'");
    const std::int64_t line = c.line();
    const auto tok = split_blanks(c.next_line());
    if (tok.empty()) continue;
    if (tok[0] == "end_header") break;
    if (tok[0] == "comment" || tok[0] == "obj_info") continue;
    if (tok[0] == "format") {
      if (tok.size() < 3 || tok[2] != "1.0")
        return c.error_at(line, "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      if (tok[1] == "ascii")
        format = 0;
      else if (tok[1] == "binary_little_endian")
        format = 1;
      else if (tok[1] == "binary_big_endian")
        format = 2;
      else
        return c.error_at(line, "unknown PLY format " + io::quote_token(tok[1]));
    } else if (tok[0] == "element") {
      if (tok.size() != 3) return c.error_at(line, "expected 'element <name> <count>'");
      PlyElement e;
      e.name = std::string(tok[1]);
      e.line = line;
      if (!io::parse_int(tok[2], e.count) || e.count < 0)
        return c.error_at(line, "expected an element count (an integer >= 0), found " + io::quote_token(tok[2]));
      elements.push_back(std::move(e));
    } else if (tok[0] == "property") {
      if (elements.empty()) return c.error_at(line, "'property' before any 'element'");
      PlyProperty p;
      if (tok.size() == 5 && tok[1] == "list") {
        p.is_list = true;
        const auto count_type = io::scalar_type_from_name(io::ScalarNames::ply, tok[2]);
        if (!count_type || io::is_float(*count_type))
          return c.error_at(line, "expected an integer list length type, found " + io::quote_token(tok[2]));
        const auto type = io::scalar_type_from_name(io::ScalarNames::ply, tok[3]);
        if (!type) return c.error_at(line, "unknown PLY type " + io::quote_token(tok[3]));
        p.count_type = *count_type;
        p.type = *type;
        p.name = std::string(tok[4]);
      } else if (tok.size() == 3) {
        const auto type = io::scalar_type_from_name(io::ScalarNames::ply, tok[1]);
        if (!type) return c.error_at(line, "unknown PLY type " + io::quote_token(tok[1]));
        p.type = *type;
        p.name = std::string(tok[2]);
      } else {
        return c.error_at(line, "expected 'property <type> <name>' or 'property list <type> <type> <name>'");
      }
      elements.back().props.push_back(std::move(p));
    } else {
      return c.error_at(line, "unexpected " + io::quote_token(tok[0]) + " in the PLY header");
    }
  }
  if (format < 0) return c.error("the PLY header has no 'format' line");
  result.format = format == 0 ? "ply ascii" : format == 1 ? "ply binary_little_endian" : "ply binary_big_endian";

  PlyBody body(bytes, name, c.position(), format, c);
  RawTriangles raw;
  bool have_vertices = false;
  std::int64_t polygons = 0, short_faces = 0;
  for (const PlyElement& e : elements) {
    // Every row takes at least this many bytes, so the count is checked before reserving.
    std::int64_t min_row = 0;
    for (const PlyProperty& p : e.props)
      min_row += body.ascii() ? 2 : static_cast<std::int64_t>(io::scalar_size(p.is_list ? p.count_type : p.type));
    if (e.count > 0 && min_row == 0) return c.error_at(e.line, "element '" + e.name + "' has rows but no properties");
    if (e.count > 0 && e.count > (static_cast<std::int64_t>(body.remaining()) + 1) / min_row)
      return c.error_at(e.line, "element '" + e.name + "' count " + std::to_string(e.count) + " is larger than the " +
                                    std::to_string(body.remaining()) + " bytes that follow can hold");
    if (e.name == "vertex") {
      if (have_vertices) return c.error_at(e.line, "a second 'vertex' element");
      have_vertices = true;
      int ix = -1, iy = -1, iz = -1, iid = -1;
      for (std::size_t k = 0; k < e.props.size(); ++k) {
        const PlyProperty& p = e.props[k];
        const int* slot = nullptr;
        if (p.name == "x") {
          ix = static_cast<int>(k);
          slot = &ix;
        }
        if (p.name == "y") {
          iy = static_cast<int>(k);
          slot = &iy;
        }
        if (p.name == "z") {
          iz = static_cast<int>(k);
          slot = &iz;
        }
        if (p.name == "id") {
          iid = static_cast<int>(k);
          slot = &iid;
        }
        if (slot && p.is_list) return c.error_at(e.line, "vertex property '" + p.name + "' must not be a list");
      }
      if (ix < 0 || iy < 0 || iz < 0) return c.error_at(e.line, "the vertex element needs properties x, y and z");
      if (e.count > io::kMaxEntities) return c.error_at(e.line, "too many vertices");
      s.positions.reserve(static_cast<std::size_t>(e.count));
      if (iid >= 0) result.vertex_ids.reserve(static_cast<std::size_t>(e.count));
      for (std::int64_t i = 0; i < e.count; ++i) {
        Vec3 p = Vec3::Zero();
        for (std::size_t k = 0; k < e.props.size(); ++k) {
          const PlyProperty& prop = e.props[k];
          if (prop.is_list) {
            SHATTER_TRY(n, body.list_count(prop));
            for (std::int64_t j = 0; j < *n; ++j) {
              SHATTER_TRY(v, body.read(prop.type, "list item"));
            }
            continue;
          }
          SHATTER_TRY(v, body.read(prop.type, "vertex property"));
          const int kk = static_cast<int>(k);
          if (kk == ix) p.x() = v->as_double();
          if (kk == iy) p.y() = v->as_double();
          if (kk == iz) p.z() = v->as_double();
          if (kk == iid) {
            if (!v->is_int && (v->d != std::floor(v->d) || std::abs(v->d) > 9.0e15))
              return body.error("expected an integer vertex id");
            result.vertex_ids.push_back(v->is_int ? v->i : static_cast<FileId>(v->d));
          }
        }
        s.positions.push_back(p);
      }
    } else if (e.name == "face") {
      int iv = -1;
      for (std::size_t k = 0; k < e.props.size(); ++k)
        if (e.props[k].name == "vertex_indices" || e.props[k].name == "vertex_index") iv = static_cast<int>(k);
      if (iv < 0 || !e.props[iv].is_list)
        return c.error_at(e.line, "the face element needs a list property 'vertex_indices'");
      if (io::is_float(e.props[iv].type)) return c.error_at(e.line, "face vertex indices must have an integer type");
      std::vector<std::int64_t> face;
      for (std::int64_t f = 0; f < e.count; ++f) {
        const std::int64_t where = body.where();
        for (std::size_t k = 0; k < e.props.size(); ++k) {
          const PlyProperty& prop = e.props[k];
          if (!prop.is_list) {
            SHATTER_TRY(v, body.read(prop.type, "face property"));
            continue;
          }
          SHATTER_TRY(n, body.list_count(prop));
          if (static_cast<int>(k) == iv) face.clear();
          for (std::int64_t j = 0; j < *n; ++j) {
            SHATTER_TRY(v, body.read(prop.type, "vertex index"));
            if (static_cast<int>(k) == iv) face.push_back(v->i);
          }
        }
        if (face.size() < 3) {
          ++short_faces;
          continue;
        }
        if (face.size() > 3) ++polygons;
        for (std::size_t k = 1; k + 1 < face.size(); ++k) raw.add(face[0], face[k], face[k + 1], where);
        if (raw.tris.size() > static_cast<std::size_t>(io::kMaxEntities)) return body.error("too many faces");
      }
    } else {
      for (std::int64_t i = 0; i < e.count; ++i)
        for (const PlyProperty& prop : e.props) {
          std::int64_t items = 1;
          if (prop.is_list) {
            SHATTER_TRY(m, body.list_count(prop));
            items = *m;
          }
          for (std::int64_t j = 0; j < items; ++j) {
            SHATTER_TRY(v, body.read(prop.type, "property"));
          }
        }
      result.skipped.push_back(std::to_string(e.count) + " " + e.name + " elements");
    }
  }
  if (!have_vertices) return c.error("the PLY header declares no 'vertex' element");
  SHATTER_TRY(ok, raw.resolve(s, [&](std::int64_t w, const std::string& m) {
    return format == 0 ? line_error(name, w, m) : offset_error(name, w, m);
  }));
  if (polygons) result.skipped.push_back("polygons triangulated: " + std::to_string(polygons));
  if (short_faces) result.skipped.push_back(std::to_string(short_faces) + " faces with fewer than 3 vertices");
  return result;
}

Result<void> write_ply(std::ostream& out, const TriSurface& surface, const SurfaceWriteOptions& options) {
  SHATTER_TRY(ok, check_surface(surface, options));
  const bool ids = !options.vertex_ids.empty();
  bool ids_fit_int = true;
  for (FileId id : options.vertex_ids)
    ids_fit_int &= id >= std::numeric_limits<std::int32_t>::min() && id <= std::numeric_limits<std::int32_t>::max();
  std::string s = "ply\nformat ";
  s += options.binary ? "binary_little_endian" : "ascii";
  s += " 1.0\nelement vertex " + std::to_string(surface.positions.size()) +
       "\nproperty double x\nproperty double y\nproperty double z\n";
  if (ids) s += ids_fit_int ? "property int id\n" : "property int64 id\n";
  s += "element face " + std::to_string(surface.triangles.size()) + "\nproperty list uchar int vertex_indices\n";
  for (const auto& face_value : options.face_values) s += "property int " + face_value.first + "\n";
  s += "end_header\n";
  for (std::size_t i = 0; i < surface.positions.size(); ++i) {
    const Vec3& p = surface.positions[i];
    if (options.binary) {
      for (int k = 0; k < 3; ++k) io::append_binary<double>(s, p[k], false);
      if (ids) {
        if (ids_fit_int)
          io::append_binary<std::int32_t>(s, static_cast<std::int32_t>(options.vertex_ids[i]), false);
        else
          io::append_binary<std::int64_t>(s, options.vertex_ids[i], false);
      }
    } else {
      for (int k = 0; k < 3; ++k) {
        if (k) s += ' ';
        io::append_double(s, p[k]);
      }
      if (ids) {
        s += ' ';
        io::append_int(s, options.vertex_ids[i]);
      }
      s += '\n';
    }
    flush_if_big(out, s);
  }
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    const TriIndices& t = surface.triangles[f];
    if (options.binary) {
      io::append_binary<std::uint8_t>(s, 3, false);
      for (Index v : t) io::append_binary<std::int32_t>(s, v, false);
      for (const auto& face_value : options.face_values)
        io::append_binary<std::int32_t>(s, face_value.second[f], false);
    } else {
      s += '3';
      for (Index v : t) {
        s += ' ';
        io::append_int(s, v);
      }
      for (const auto& face_value : options.face_values) {
        s += ' ';
        io::append_int(s, face_value.second[f]);
      }
      s += '\n';
    }
    flush_if_big(out, s);
  }
  out << s;
  return {};
}

// ---------------------------------------------------------------- STL
namespace {

/// Welds exactly equal positions (-0 and +0 are equal) in order of first appearance.
class Welder {
 public:
  explicit Welder(TriSurface& s) : s_(s) {}
  Index add(Vec3 p) {
    for (int k = 0; k < 3; ++k)
      if (p[k] == 0.0) p[k] = 0.0;
    Key key{};
    std::memcpy(key.data(), p.data(), sizeof(double) * 3);
    const auto [it, inserted] = map_.emplace(key, static_cast<Index>(s_.positions.size()));
    if (inserted) s_.positions.push_back(p);
    return it->second;
  }
  void triangle(const Vec3& a, const Vec3& b, const Vec3& c) {
    const TriIndices t{add(a), add(b), add(c)};
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      ++degenerate;
    else
      s_.triangles.push_back(t);
  }
  std::int64_t degenerate = 0;

 private:
  using Key = std::array<std::uint64_t, 3>;
  struct Hash {
    std::size_t operator()(const Key& k) const {
      std::uint64_t h = 0x9E3779B97F4A7C15ULL;
      for (std::uint64_t v : k) h = (h ^ v) * 0x100000001B3ULL + (h >> 29);
      return static_cast<std::size_t>(h);
    }
  };
  TriSurface& s_;
  std::unordered_map<Key, Index, Hash> map_;
};

Result<SurfaceReadResult> parse_stl_binary(std::string_view bytes, const std::string& name) {
  SurfaceReadResult result;
  result.format = "stl binary";
  ByteCursor b(bytes, name);
  if (bytes.size() < 84)
    return b.error("file is neither ASCII STL (starting with 'solid') nor binary STL (84 bytes or more): " +
                   std::to_string(bytes.size()) + " bytes");
  SHATTER_TRY(header, b.take(80, "header"));
  SHATTER_TRY(count, b.u32("triangle count"));
  SHATTER_TRY(fits, b.require(*count, 50, "triangles"));
  if (*count > static_cast<std::uint32_t>(io::kMaxEntities)) return b.error("too many triangles");
  result.surface.triangles.reserve(*count);
  Welder weld(result.surface);
  for (std::uint32_t t = 0; t < *count; ++t) {
    for (int k = 0; k < 3; ++k) {
      SHATTER_TRY(n, b.f32("normal"));
    }
    Vec3 v[3];
    for (auto& p : v)
      for (int k = 0; k < 3; ++k) {
        SHATTER_TRY(x, b.f32("vertex coordinate"));
        if (!std::isfinite(*x))
          return offset_error(name, static_cast<std::int64_t>(b.position()) - 4,
                              "expected a vertex coordinate (a finite number)");
        p[k] = *x;
      }
    SHATTER_TRY(attr, b.u16("attribute byte count"));
    weld.triangle(v[0], v[1], v[2]);
  }
  if (b.remaining() > 0) result.skipped.push_back(std::to_string(b.remaining()) + " bytes after the last triangle");
  if (weld.degenerate) result.skipped.push_back(std::to_string(weld.degenerate) + " degenerate triangles");
  return result;
}

Result<SurfaceReadResult> parse_stl_ascii(std::string_view bytes, const std::string& name) {
  SurfaceReadResult result;
  result.format = "stl ascii";
  TextCursor c(bytes, name);
  Welder weld(result.surface);
  std::int64_t polygons = 0, solids = 0;
  auto expect = [&](std::string_view kw) { return c.expect(kw, true); };
  while (true) {
    const std::string_view t = c.next_token();
    if (t.empty()) break;
    if (!io::iequals(t, "solid"))
      return c.error(solids ? "expected 'solid' or the end of the file, found " + io::quote_token(t)
                            : "expected 'solid', found " + io::quote_token(t));
    ++solids;
    c.skip_line();  // the solid's name
    while (true) {
      const std::string_view kw = c.next_token();
      if (kw.empty()) return c.error("file ends inside a solid: expected 'facet' or 'endsolid'");
      if (io::iequals(kw, "endsolid")) {
        c.skip_line();
        break;
      }
      if (!io::iequals(kw, "facet")) return c.error("expected 'facet' or 'endsolid', found " + io::quote_token(kw));
      SHATTER_TRY(a, expect("normal"));
      for (int i = 0; i < 3; ++i) {
        // Some writers put "nan" in normals of degenerate facets; the normal is not used.
        const std::string_view n = c.next_token();
        if (n.empty()) return c.error("file ends inside a facet normal");
      }
      SHATTER_TRY(b, expect("outer"));
      SHATTER_TRY(d, expect("loop"));
      std::vector<Vec3> loop;
      while (true) {
        const std::string_view v = c.next_token();
        if (io::iequals(v, "endloop")) break;
        if (!io::iequals(v, "vertex"))
          return c.error(v.empty() ? std::string("file ends inside a facet")
                                   : "expected 'vertex' or 'endloop', found " + io::quote_token(v));
        Vec3 p;
        for (int k = 0; k < 3; ++k) {
          SHATTER_TRY(x, c.next_double("vertex coordinate"));
          p[k] = *x;
        }
        loop.push_back(p);
      }
      SHATTER_TRY(e, expect("endfacet"));
      if (loop.size() < 3) return c.error("a facet needs at least 3 vertices, found " + std::to_string(loop.size()));
      if (loop.size() > 3) ++polygons;
      for (std::size_t k = 1; k + 1 < loop.size(); ++k) weld.triangle(loop[0], loop[k], loop[k + 1]);
      if (result.surface.triangles.size() > static_cast<std::size_t>(io::kMaxEntities))
        return c.error("too many triangles");
    }
  }
  if (solids == 0) return c.error("empty file: expected 'solid'");
  if (polygons) result.skipped.push_back("polygons triangulated: " + std::to_string(polygons));
  if (weld.degenerate) result.skipped.push_back(std::to_string(weld.degenerate) + " degenerate triangles");
  return result;
}

}  // namespace

Result<SurfaceReadResult> parse_stl(std::string_view bytes, const std::string& name) {
  // Binary when the size matches the triangle count exactly (even if the header starts with
  // "solid"); ASCII when it starts with "solid" and holds no NUL byte; binary otherwise.
  if (bytes.size() >= 84) {
    std::uint32_t n = 0;
    ByteCursor b(bytes, name, 80);
    n = *b.u32("count");
    if (84 + 50 * static_cast<std::uint64_t>(n) == bytes.size()) return parse_stl_binary(bytes, name);
  }
  std::string_view head = bytes;
  if (head.size() >= 3 && head.substr(0, 3) == "\xEF\xBB\xBF") head.remove_prefix(3);
  while (!head.empty() && (head[0] == ' ' || head[0] == '\t' || head[0] == '\r' || head[0] == '\n'))
    head.remove_prefix(1);
  const bool starts_solid = head.size() >= 5 && io::iequals(head.substr(0, 5), "solid");
  if (starts_solid && bytes.find('\0') == std::string_view::npos) return parse_stl_ascii(bytes, name);
  return parse_stl_binary(bytes, name);
}

Result<void> write_stl(std::ostream& out, const TriSurface& surface, const SurfaceWriteOptions& options) {
  SHATTER_TRY(ok, check_surface(surface, options));
  std::string s;
  if (options.binary) {
    if (surface.triangles.size() > std::numeric_limits<std::uint32_t>::max())
      return make_error("binary STL holds at most 2^32-1 triangles");
    std::string header = "binary STL";
    header.resize(80, ' ');
    s += header;
    io::append_binary<std::uint32_t>(s, static_cast<std::uint32_t>(surface.triangles.size()), false);
  } else {
    s += "solid surface\n";
  }
  for (const TriIndices& t : surface.triangles) {
    const Vec3 &a = surface.positions[t[0]], &b = surface.positions[t[1]], &c = surface.positions[t[2]];
    const Vec3 n = unit_normal(a, b, c);
    if (options.binary) {
      for (int k = 0; k < 3; ++k) io::append_binary<float>(s, static_cast<float>(n[k]), false);
      for (const Vec3* p : {&a, &b, &c})
        for (int k = 0; k < 3; ++k) io::append_binary<float>(s, static_cast<float>((*p)[k]), false);
      io::append_binary<std::uint16_t>(s, 0, false);
    } else {
      s += "facet normal";
      for (int k = 0; k < 3; ++k) {
        s += ' ';
        io::append_double(s, n[k]);
      }
      s += "\n outer loop\n";
      for (const Vec3* p : {&a, &b, &c}) {
        s += "  vertex";
        for (int k = 0; k < 3; ++k) {
          s += ' ';
          io::append_double(s, (*p)[k]);
        }
        s += '\n';
      }
      s += " endloop\nendfacet\n";
    }
    flush_if_big(out, s);
  }
  if (!options.binary) s += "endsolid surface\n";
  out << s;
  return {};
}

// ---------------------------------------------------------------- by extension
SurfaceFormat surface_format_from_path(const std::string& path) {
  const std::string ext = file_extension(path);
  if (ext == ".obj") return SurfaceFormat::obj;
  if (ext == ".ply") return SurfaceFormat::ply;
  if (ext == ".stl") return SurfaceFormat::stl;
  return SurfaceFormat::unknown;
}

Result<SurfaceReadResult> read_surface(const std::string& path) {
  const SurfaceFormat format = surface_format_from_path(path);
  if (format == SurfaceFormat::unknown)
    return file_error(path, "unknown surface format '" + file_extension(path) + "': expected .obj, .ply or .stl");
  SHATTER_TRY(bytes, read_file(path));
  switch (format) {
    case SurfaceFormat::obj: return parse_obj(*bytes, path);
    case SurfaceFormat::ply: return parse_ply(*bytes, path);
    default: return parse_stl(*bytes, path);
  }
}

Result<void> write_surface(const std::string& path, const TriSurface& surface, const SurfaceWriteOptions& options) {
  const SurfaceFormat format = surface_format_from_path(path);
  if (format == SurfaceFormat::unknown)
    return file_error(path, "unknown surface format '" + file_extension(path) + "': expected .obj, .ply or .stl");
  SHATTER_TRY(ok, check_surface(surface, options));
  return write_file_atomic(path, [&](std::ostream& out) -> Result<void> {
    switch (format) {
      case SurfaceFormat::obj: return write_obj(out, surface, options);
      case SurfaceFormat::ply: return write_ply(out, surface, options);
      default: return write_stl(out, surface, options);
    }
  });
}

}  // namespace shatter
