// Legacy VTK reader (UNSTRUCTURED_GRID, versions up to 4.2 and 5.1, ASCII and big-endian BINARY)
// and writer (4.2). Tets are cell type 10; other cell types are counted in `skipped` and the nodes
// only they use are dropped. Point arrays "node_id" / "node_tag" and cell arrays "tet_id" and
// "tag" (also "tet_tag", "gmsh:physical", "medit:ref") restore ids and tags; other arrays are
// skipped. The writer adds those arrays when the mesh has ids / tags, then the requested fields.
#include <cmath>
#include <limits>
#include <map>
#include <ostream>

#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/mesh_io_util.h"
#include "shatter/mesh/io/scalar_type.h"
#include "shatter/mesh/io/text_cursor.h"

namespace shatter {
namespace {

using io::ByteCursor;
using io::ScalarArray;
using io::ScalarType;
using io::TextCursor;

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

/// Array names encode special characters as %XX (as VTK writes them).
std::string decode_name(std::string_view s) {
  std::string r;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size()) {
      const int h = hex_digit(s[i + 1]), l = hex_digit(s[i + 2]);
      if (h >= 0 && l >= 0) {
        r += static_cast<char>(h * 16 + l);
        i += 2;
        continue;
      }
    }
    r += s[i];
  }
  return r;
}

std::string encode_name(std::string_view s) {
  std::string r;
  for (char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || c == '-' ||
        c == '.' || c == ':') {
      r += ch;
    } else {
      static const char* hex = "0123456789ABCDEF";
      r += '%';
      r += hex[c >> 4];
      r += hex[c & 15];
    }
  }
  return r.empty() ? std::string("unnamed") : r;
}

class VtkReader {
 public:
  VtkReader(std::string_view bytes, const std::string& name) : bytes_(bytes), name_(name), c_(bytes, name) {}

  Result<MeshReadResult> read() {
    if (c_.at_end()) return c_.error("empty file: expected '# vtk DataFile Version'");
    const std::string_view header = c_.next_line();
    const std::string_view magic = "# vtk DataFile Version";
    if (header.size() < magic.size() || io::to_lower(header.substr(0, magic.size())) != io::to_lower(magic))
      return c_.error_at(1,
                         "not a legacy VTK file: expected '# vtk DataFile Version', found " + io::quote_token(header));
    std::string_view v = header.substr(magic.size());
    while (!v.empty() && (v.front() == ' ' || v.front() == '\t')) v.remove_prefix(1);
    while (!v.empty() && (v.back() == ' ' || v.back() == '\t')) v.remove_suffix(1);
    version_ = std::string(v);
    if (v == "5.1") {
      v51_ = true;
    } else if (!(v == "1.0" || v == "2.0" || v == "3.0" || v == "4.0" || v == "4.1" || v == "4.2")) {
      return c_.error_at(1,
                         "unsupported legacy VTK version " + io::quote_token(v) + " (up to 4.2 and 5.1 are supported)");
    }
    if (c_.at_end()) return c_.error("file ends where the title line was expected");
    (void)c_.next_line();  // title
    const std::string_view fmt = c_.next_token();
    if (io::to_lower(fmt) == "ascii") {
      binary_ = false;
    } else if (io::to_lower(fmt) == "binary") {
      binary_ = true;
    } else {
      return c_.error("expected 'ASCII' or 'BINARY', found " + io::quote_token(fmt));
    }
    if (auto r = c_.expect("DATASET", true); !r) return r.error();
    const std::string_view kind = c_.next_token();
    if (io::to_lower(kind) != "unstructured_grid")
      return c_.error("only DATASET UNSTRUCTURED_GRID is supported, found " + io::quote_token(kind));

    for (;;) {
      const std::string_view tok = c_.next_token();
      if (tok.empty()) break;
      const std::string key = io::to_lower(tok);
      Result<void> r;
      if (key == "points") {
        r = read_points();
      } else if (key == "cells") {
        r = read_cells();
      } else if (key == "cell_types") {
        r = read_cell_types();
      } else if (key == "point_data" || key == "cell_data") {
        SHATTER_TRY(n, c_.next_int("data count"));
        target_ = key == "point_data" ? 1 : 2;
        target_count_ = *n;
        if (*n < 0) return c_.error("negative " + key + " count");
      } else if (key == "scalars") {
        r = read_scalars();
      } else if (key == "vectors" || key == "normals") {
        r = read_named_array(3);
      } else if (key == "tensors") {
        r = read_named_array(9);
      } else if (key == "tensors6") {
        r = read_named_array(6);
      } else if (key == "texture_coordinates") {
        r = read_texture_coordinates();
      } else if (key == "color_scalars") {
        r = read_color_scalars();
      } else if (key == "lookup_table") {
        r = read_lookup_table();
      } else if (key == "field") {
        r = read_field();
      } else if (key == "metadata") {
        r = skip_metadata();
      } else {
        return c_.error("unexpected keyword " + io::quote_token(tok) +
                        " (expected POINTS, CELLS, CELL_TYPES, POINT_DATA, CELL_DATA or an array)");
      }
      if (!r) return r.error();
    }
    return finish();
  }

 private:
  /// After a header line that precedes binary data: move past its newline.
  Result<void> start_binary() {
    c_.skip_blanks();
    if (c_.at_end()) return c_.error("file ends where binary data was expected");
    if (c_.rest()[0] != '\n')
      return c_.error("expected the end of the line before binary data, found " +
                      io::quote_token(c_.rest().substr(0, 8)));
    (void)c_.take_bytes(1, "newline");
    return {};
  }

  Result<void> require_count(std::int64_t count, ScalarType type, const char* what) {
    if (count < 0) return c_.error(std::string("negative ") + what + " count " + std::to_string(count));
    const std::uint64_t per = binary_ ? std::max<std::uint64_t>(io::scalar_size(type), 1) : 2;
    std::uint64_t need = static_cast<std::uint64_t>(count);
    if (binary_ && type == ScalarType::bit) need = (need + 7) / 8;
    if (need > c_.remaining() / per)
      return c_.error(std::string(what) + ": " + std::to_string(count) + " values declared, more than the " +
                      std::to_string(c_.remaining()) + " bytes that remain can hold");
    return {};
  }

  /// Read `count` values of `type`; keep == false only consumes them.
  Result<ScalarArray> read_values(std::int64_t count, ScalarType type, const char* what, bool keep) {
    if (auto r = require_count(count, type, what); !r) return r.error();
    ScalarArray a;
    a.integral = !io::is_float(type);
    if (keep) a.reserve(static_cast<std::size_t>(count));
    if (binary_) {
      if (auto r = start_binary(); !r) return r.error();
      ByteCursor b(bytes_, name_, c_.position(), true);
      if (type == ScalarType::bit) {
        SHATTER_TRY(raw, b.take(static_cast<std::size_t>((count + 7) / 8), what));
        if (keep)
          for (std::int64_t i = 0; i < count; ++i)
            a.ints.push_back((static_cast<unsigned char>((*raw)[static_cast<std::size_t>(i / 8)]) >> (7 - i % 8)) & 1);
      } else if (!keep) {
        SHATTER_TRY(raw, b.take(static_cast<std::size_t>(count) * io::scalar_size(type), what));
      } else {
        SHATTER_TRY(ok, io::read_scalars(b, type, static_cast<std::uint64_t>(count), what, a));
      }
      (void)c_.take_bytes(b.position() - c_.position(), what);
      return a;
    }
    for (std::int64_t i = 0; i < count; ++i) {
      if (!keep) {
        if (c_.next_token().empty()) return c_.error(std::string("file ends inside ") + what);
      } else if (a.integral) {
        SHATTER_TRY(x, c_.next_int(what));
        a.ints.push_back(*x);
      } else {
        SHATTER_TRY(x, c_.next_double(what));
        a.reals.push_back(*x);
      }
    }
    return a;
  }

  Result<ScalarType> read_type(const char* what) {
    const std::string_view t = c_.next_token();
    if (t.empty()) return c_.error(std::string("file ends where the ") + what + " data type was expected");
    const std::optional<ScalarType> type = io::scalar_type_from_name(io::ScalarNames::vtk, t);
    if (!type) return c_.error(std::string("unknown ") + what + " data type " + io::quote_token(t));
    return *type;
  }

  Result<void> read_points() {
    if (have_points_) return c_.error("second POINTS section");
    have_points_ = true;
    SHATTER_TRY(n, c_.next_int("point count"));
    if (*n < 0 || *n > std::numeric_limits<Index>::max())
      return c_.error("point count " + std::to_string(*n) + " out of range");
    SHATTER_TRY(type, read_type("POINTS"));
    if (*n > std::numeric_limits<std::int64_t>::max() / 3) return c_.error("point count too large");
    const std::int64_t line = c_.line();
    SHATTER_TRY(a, read_values(*n * 3, *type, "point coordinates", true));
    positions_.resize(static_cast<std::size_t>(*n));
    for (std::int64_t i = 0; i < *n; ++i)
      for (int k = 0; k < 3; ++k) {
        const std::size_t j = static_cast<std::size_t>(3 * i + k);
        const double x = a->integral ? static_cast<double>(a->ints[j]) : a->reals[j];
        if (!std::isfinite(x))
          return c_.error_at(line, "point " + std::to_string(i) + " has a coordinate that is not finite");
        positions_[static_cast<std::size_t>(i)][k] = x;
      }
    return {};
  }

  Result<void> read_cells() {
    if (have_cells_) return c_.error("second CELLS section");
    have_cells_ = true;
    SHATTER_TRY(a, c_.next_int("cell count"));
    SHATTER_TRY(b, c_.next_int("cell list size"));
    if (*a < 0 || *b < 0) return c_.error("negative CELLS counts");
    if (v51_) {
      // CELLS <#offsets> <#connectivity>, then OFFSETS <type> ..., CONNECTIVITY <type> ...
      if (auto r = c_.expect("OFFSETS", true); !r) return r;
      SHATTER_TRY(ot, read_type("OFFSETS"));
      if (io::is_float(*ot)) return c_.error("OFFSETS must be an integer type");
      SHATTER_TRY(offsets, read_values(*a, *ot, "cell offsets", true));
      if (auto r = c_.expect("CONNECTIVITY", true); !r) return r;
      SHATTER_TRY(ct, read_type("CONNECTIVITY"));
      if (io::is_float(*ct)) return c_.error("CONNECTIVITY must be an integer type");
      SHATTER_TRY(conn, read_values(*b, *ct, "cell connectivity", true));
      offsets_ = std::move(offsets->ints);
      if (offsets_.empty()) offsets_.push_back(0);
      if (offsets_.front() != 0)
        return c_.error("first cell offset must be 0, found " + std::to_string(offsets_.front()));
      for (std::size_t i = 1; i < offsets_.size(); ++i)
        if (offsets_[i] < offsets_[i - 1]) return c_.error("cell offsets decrease at cell " + std::to_string(i - 1));
      if (offsets_.back() != *b)
        return c_.error("last cell offset " + std::to_string(offsets_.back()) + " differs from the connectivity size " +
                        std::to_string(*b));
      conn_ = std::move(conn->ints);
      return {};
    }
    // CELLS <#cells> <size>, then per cell: k i1 .. ik.
    if (*a > *b)
      return c_.error("CELLS: " + std::to_string(*a) + " cells cannot fit in a list of " + std::to_string(*b) +
                      " values");
    SHATTER_TRY(list, read_values(*b, ScalarType::i32, "cell list", true));
    offsets_.reserve(static_cast<std::size_t>(*a) + 1);
    offsets_.push_back(0);
    conn_.reserve(static_cast<std::size_t>(*b - *a));
    std::size_t p = 0;
    for (std::int64_t i = 0; i < *a; ++i) {
      if (p >= list->ints.size())
        return c_.error("CELLS list ends at cell " + std::to_string(i) + " of " + std::to_string(*a));
      const std::int64_t k = list->ints[p++];
      if (k < 0 || static_cast<std::uint64_t>(k) > list->ints.size() - p)
        return c_.error("cell " + std::to_string(i) + " declares " + std::to_string(k) +
                        " points, beyond the CELLS list");
      for (std::int64_t j = 0; j < k; ++j) conn_.push_back(list->ints[p++]);
      offsets_.push_back(static_cast<std::int64_t>(conn_.size()));
    }
    if (p != list->ints.size())
      return c_.error("CELLS list size " + std::to_string(*b) + " does not match its " + std::to_string(*a) + " cells");
    return {};
  }

  Result<void> read_cell_types() {
    if (have_types_) return c_.error("second CELL_TYPES section");
    have_types_ = true;
    SHATTER_TRY(n, c_.next_int("cell type count"));
    SHATTER_TRY(t, read_values(*n, ScalarType::i32, "cell types", true));
    types_ = std::move(t->ints);
    return {};
  }

  Result<void> check_target(std::int64_t tuples) {
    if (target_ == 0) return c_.error("data array outside POINT_DATA / CELL_DATA");
    if (tuples != target_count_)
      return c_.error("array has " + std::to_string(tuples) + " tuples, expected " + std::to_string(target_count_));
    return {};
  }

  /// Store an id / tag array if its name is one we restore; consume it otherwise.
  Result<void> array_body(const std::string& name, int components, std::int64_t tuples, ScalarType type) {
    if (auto r = check_target(tuples); !r) return r;
    if (tuples > std::numeric_limits<std::int64_t>::max() / std::max(components, 1)) return c_.error("array too large");
    const std::int64_t line = c_.line();
    int slot = 0;  // 1 node_id, 2 node_tag, 3 tet_id, 4 tet tag
    if (components == 1 && target_ == 1) {
      if (name == "node_id")
        slot = 1;
      else if (name == "node_tag")
        slot = 2;
    } else if (components == 1 && target_ == 2) {
      if (name == "tet_id")
        slot = 3;
      else if (name == "tag" || name == "tet_tag" || name == "gmsh:physical" || name == "medit:ref")
        slot = 4;
    }
    SHATTER_TRY(a, read_values(tuples * components, type, "array values", slot != 0));
    if (slot == 0) return {};
    std::vector<std::int64_t> v;
    if (a->integral) {
      v = std::move(a->ints);
    } else {
      v.reserve(a->reals.size());
      for (double x : a->reals) {
        if (!(std::fabs(x) <= 9.0e15) || x != std::floor(x))
          return c_.error_at(line,
                             "array " + io::quote_token(name) + " holds the non-integer value " + std::to_string(x));
        v.push_back(static_cast<std::int64_t>(x));
      }
    }
    if (slot == 2 || slot == 4)
      for (std::int64_t x : v)
        if (x < std::numeric_limits<std::int32_t>::min() || x > std::numeric_limits<std::int32_t>::max())
          return c_.error_at(line,
                             "array " + io::quote_token(name) + ": tag " + std::to_string(x) + " does not fit 32 bits");
    (slot == 1 ? node_id_ : slot == 2 ? node_tag_ : slot == 3 ? tet_id_ : tet_tag_) = std::move(v);
    return {};
  }

  Result<void> read_scalars() {
    const std::string name = decode_name(c_.next_token());
    SHATTER_TRY(type, read_type("SCALARS"));
    int comps = 1;
    if (!c_.at_line_end()) {
      SHATTER_TRY(n, c_.next_int_in("SCALARS component count", 1, 4));
      comps = static_cast<int>(*n);
    }
    if (io::to_lower(c_.peek_token()) == "lookup_table") {
      (void)c_.next_token();
      (void)c_.next_token();
    }
    return array_body(name, comps, target_count_, *type);
  }

  Result<void> read_named_array(int comps) {
    const std::string name = decode_name(c_.next_token());
    SHATTER_TRY(type, read_type("array"));
    return array_body(name, comps, target_count_, *type);
  }

  Result<void> read_texture_coordinates() {
    const std::string name = decode_name(c_.next_token());
    SHATTER_TRY(dim, c_.next_int_in("texture dimension", 1, 3));
    SHATTER_TRY(type, read_type("TEXTURE_COORDINATES"));
    return array_body(name, static_cast<int>(*dim), target_count_, *type);
  }

  Result<void> read_color_scalars() {
    const std::string name = decode_name(c_.next_token());
    SHATTER_TRY(n, c_.next_int_in("color component count", 1, 4));
    return array_body(name, static_cast<int>(*n), target_count_, binary_ ? ScalarType::u8 : ScalarType::f32);
  }

  Result<void> read_lookup_table() {
    (void)c_.next_token();
    SHATTER_TRY(n, c_.next_int("lookup table size"));
    if (*n < 0 || *n > std::numeric_limits<std::int64_t>::max() / 4) return c_.error("bad lookup table size");
    SHATTER_TRY(a, read_values(*n * 4, binary_ ? ScalarType::u8 : ScalarType::f32, "lookup table", false));
    return {};
  }

  Result<void> read_field() {
    (void)c_.next_token();  // field name
    SHATTER_TRY(n, c_.next_int("field array count"));
    if (*n < 0 || static_cast<std::uint64_t>(*n) > c_.remaining() / 8)
      return c_.error("bad field array count " + std::to_string(*n));
    const int saved_target = target_;
    const std::int64_t saved_count = target_count_;
    for (std::int64_t i = 0; i < *n; ++i) {
      const std::string_view raw = c_.next_token();
      if (raw.empty()) return c_.error("file ends inside FIELD");
      if (raw == "NULL_ARRAY") continue;
      const std::string name = decode_name(raw);
      SHATTER_TRY(comps, c_.next_int_in("field component count", 1, 1 << 20));
      SHATTER_TRY(tuples, c_.next_int("field tuple count"));
      SHATTER_TRY(type, read_type("field"));
      if (*tuples < 0) return c_.error("negative field tuple count");
      if (saved_target == 0) {
        // Dataset-level field data: consume only.
        target_ = 1;
        target_count_ = *tuples;
        auto r = array_body("", static_cast<int>(*comps), *tuples, *type);
        target_ = 0;
        target_count_ = saved_count;
        if (!r) return r;
      } else {
        if (auto r = array_body(name, static_cast<int>(*comps), *tuples, *type); !r) return r;
      }
      // Optional METADATA block after each array.
      if (io::to_lower(c_.peek_token()) == "metadata") {
        (void)c_.next_token();
        if (auto r = skip_metadata(); !r) return r;
      }
    }
    target_ = saved_target;
    return {};
  }

  /// METADATA blocks (5.1 and VTK 8+): lines up to the next blank line.
  Result<void> skip_metadata() {
    (void)c_.next_line();
    while (!c_.at_end()) {
      const std::string_view line = c_.next_line();
      bool blank = true;
      for (char ch : line) blank = blank && (ch == ' ' || ch == '\t' || ch == '\r');
      if (blank) break;
    }
    return {};
  }

  Result<MeshReadResult> finish() {
    if (!have_points_) return c_.error("file ends without a POINTS section");
    if (!have_cells_) return c_.error("file ends without a CELLS section");
    if (!have_types_) return c_.error("file ends without a CELL_TYPES section");
    const std::size_t ncells = offsets_.size() - 1;
    if (types_.size() != ncells)
      return c_.error("CELL_TYPES lists " + std::to_string(types_.size()) + " cells, CELLS " + std::to_string(ncells));
    MeshReadResult out;
    out.format = std::string("vtk ") + version_ + (binary_ ? " binary" : " ascii");
    TetMesh& m = out.mesh;
    m.positions = std::move(positions_);
    const std::int64_t np = static_cast<std::int64_t>(m.positions.size());
    std::map<std::int64_t, std::int64_t> skipped;
    std::vector<std::size_t> tet_cells;
    for (std::size_t i = 0; i < ncells; ++i) {
      const std::int64_t type = types_[i];
      const std::int64_t b = offsets_[i], e = offsets_[i + 1];
      if (type != 10) {
        ++skipped[type];
        continue;
      }
      if (e - b != 4)
        return c_.error("cell " + std::to_string(i) + " is a tetrahedron (type 10) with " + std::to_string(e - b) +
                        " points");
      TetIndices t;
      for (int k = 0; k < 4; ++k) {
        const std::int64_t v = conn_[static_cast<std::size_t>(b + k)];
        if (v < 0 || v >= np)
          return c_.error("cell " + std::to_string(i) + " references point " + std::to_string(v) + ", but there are " +
                          std::to_string(np) + " points");
        t[k] = static_cast<Index>(v);
      }
      if (m.tets.size() >= static_cast<std::size_t>(std::numeric_limits<Index>::max()))
        return c_.error("more than 2^31-1 tetrahedra");
      m.tets.push_back(t);
      tet_cells.push_back(i);
    }
    if (m.tets.empty()) return c_.error("no tetrahedra (cell type 10) in the file");
    // A POINT_DATA / CELL_DATA count is checked against its arrays while reading, against the
    // points and cells only here.
    const struct {
      const std::vector<std::int64_t>& values;
      std::size_t want;
      const char* name;
      const char* of;
    } restored[] = {{node_id_, static_cast<std::size_t>(np), "node_id", "points"},
                    {node_tag_, static_cast<std::size_t>(np), "node_tag", "points"},
                    {tet_id_, ncells, "tet_id", "cells"},
                    {tet_tag_, ncells, "tet tag", "cells"}};
    for (const auto& a : restored)
      if (!a.values.empty() && a.values.size() != a.want)
        return c_.error(std::string("array ") + a.name + " has " +
                        io::count_phrase(static_cast<std::int64_t>(a.values.size()), "value", "values") + " for " +
                        std::to_string(a.want) + " " + a.of);
    if (!node_id_.empty()) m.node_ids = std::move(node_id_);
    if (!node_tag_.empty()) m.node_tags.assign(node_tag_.begin(), node_tag_.end());
    if (!tet_id_.empty())
      for (std::size_t i : tet_cells) m.tet_ids.push_back(tet_id_[i]);
    if (!tet_tag_.empty())
      for (std::size_t i : tet_cells) m.tet_tags.push_back(static_cast<std::int32_t>(tet_tag_[i]));
    static const std::map<std::int64_t, std::pair<const char*, const char*>> names = {
        {1, {"vertex", "vertices"}},
        {2, {"poly-vertex", "poly-vertices"}},
        {3, {"line", "lines"}},
        {4, {"polyline", "polylines"}},
        {5, {"triangle", "triangles"}},
        {6, {"triangle strip", "triangle strips"}},
        {7, {"polygon", "polygons"}},
        {8, {"pixel", "pixels"}},
        {9, {"quad", "quads"}},
        {11, {"voxel", "voxels"}},
        {12, {"hexahedron", "hexahedra"}},
        {13, {"wedge", "wedges"}},
        {14, {"pyramid", "pyramids"}},
        {21, {"quadratic edge", "quadratic edges"}},
        {22, {"quadratic triangle", "quadratic triangles"}},
        {24, {"quadratic tetrahedron", "quadratic tetrahedra"}},
        {42, {"polyhedron", "polyhedra"}},
    };
    for (const auto& [type, n] : skipped) {
      const auto it = names.find(type);
      out.skipped.push_back(it != names.end()
                                ? io::count_phrase(n, it->second.first, it->second.second) + " (vtk type " +
                                      std::to_string(type) + ")"
                                : io::count_phrase(n, "cell", "cells") + " of vtk type " + std::to_string(type));
    }
    if (!skipped.empty()) {
      const Index dropped = io::drop_unused_nodes(m);
      if (dropped > 0) out.skipped.push_back(io::count_phrase(dropped, "node", "nodes") + " used by no tetrahedron");
    }
    io::drop_default_ids(m.node_ids);
    io::drop_default_ids(m.tet_ids);
    return out;
  }

  std::string_view bytes_;
  std::string name_;
  TextCursor c_;
  std::string version_;
  bool v51_ = false;
  bool binary_ = false;
  bool have_points_ = false, have_cells_ = false, have_types_ = false;
  int target_ = 0;  // 0 none, 1 point data, 2 cell data
  std::int64_t target_count_ = 0;
  std::vector<Vec3> positions_;
  std::vector<std::int64_t> offsets_, conn_, types_;
  std::vector<std::int64_t> node_id_, node_tag_, tet_id_, tet_tag_;
};

bool fits_i32(std::int64_t v) {
  return v >= std::numeric_limits<std::int32_t>::min() && v <= std::numeric_limits<std::int32_t>::max();
}

}  // namespace

Result<MeshReadResult> parse_vtk(std::string_view bytes, const std::string& name) {
  VtkReader reader(bytes, name);
  return reader.read();
}

Result<void> write_vtk(std::ostream& out, const TetMesh& mesh, const MeshWriteOptions& options) {
  const bool bin = options.binary;
  const Index nn = mesh.num_nodes(), ne = mesh.num_tets();
  if (auto ok = io::check_mesh_for_writing("write_vtk", mesh, options); !ok) return ok;

  io::WriteBuffer w(out);
  auto end_binary = [&] {
    if (bin) w << '\n';
  };
  auto ints = [&](const auto& values, bool as64) {
    std::size_t i = 0;
    for (const auto v : values) {
      if (bin) {
        if (as64)
          w.raw(static_cast<std::int64_t>(v), true);
        else
          w.raw(static_cast<std::int32_t>(v), true);
      } else {
        w.integer(static_cast<std::int64_t>(v));
        w << (++i % 16 == 0 ? '\n' : ' ');
      }
    }
    if (!bin && i % 16 != 0) w << '\n';
    end_binary();
  };
  auto reals = [&](const std::vector<double>& values, int per_line) {
    std::size_t i = 0;
    for (double v : values) {
      if (bin) {
        w.raw(v, true);
      } else {
        w.number(v);
        w << (++i % static_cast<std::size_t>(per_line) == 0 ? '\n' : ' ');
      }
    }
    if (!bin && i % static_cast<std::size_t>(per_line) != 0) w << '\n';
    end_binary();
  };
  auto id_array = [&](const char* name, const std::vector<std::int64_t>& v) {
    bool small = true;
    for (std::int64_t x : v) small = small && fits_i32(x);
    w << "SCALARS " << name << (small ? " int 1\n" : " vtktypeint64 1\n") << "LOOKUP_TABLE default\n";
    ints(v, !small);
  };
  auto tag_array = [&](const char* name, const std::vector<std::int32_t>& v) {
    w << "SCALARS " << name << " int 1\nLOOKUP_TABLE default\n";
    ints(v, false);
  };
  auto fields = [&](const std::vector<MeshField>& fs, std::int64_t count) {
    std::vector<const MeshField*> other;
    for (const MeshField& f : fs) {
      if (f.components == 1) {
        w << "SCALARS " << encode_name(f.name) << " double 1\nLOOKUP_TABLE default\n";
        reals(f.values, 9);
      } else if (f.components == 3) {
        w << "VECTORS " << encode_name(f.name) << " double\n";
        reals(f.values, 3);
      } else {
        other.push_back(&f);
      }
    }
    if (other.empty()) return;
    w << "FIELD FieldData ";
    w.integer(static_cast<std::int64_t>(other.size()));
    w << '\n';
    for (const MeshField* f : other) {
      w << encode_name(f->name) << ' ';
      w.integer(f->components);
      w << ' ';
      w.integer(count);
      w << " double\n";
      reals(f->values, f->components);
    }
  };

  w << "# vtk DataFile Version 4.2\nshatter tetrahedral mesh\n"
    << (bin ? "BINARY\n" : "ASCII\n") << "DATASET UNSTRUCTURED_GRID\n";
  w << "POINTS ";
  w.integer(nn);
  w << " double\n";
  for (const Vec3& p : mesh.positions)
    for (int k = 0; k < 3; ++k) {
      if (bin) {
        w.raw(p[k], true);
      } else {
        w.number(p[k]);
        w << (k == 2 ? '\n' : ' ');
      }
    }
  end_binary();
  w << "CELLS ";
  w.integer(ne);
  w << ' ';
  w.integer(static_cast<std::int64_t>(ne) * 5);
  w << '\n';
  for (const TetIndices& t : mesh.tets) {
    if (bin) {
      w.raw(std::int32_t{4}, true);
      for (Index v : t) w.raw(static_cast<std::int32_t>(v), true);
    } else {
      w << '4';
      for (Index v : t) {
        w << ' ';
        w.integer(v);
      }
      w << '\n';
    }
  }
  end_binary();
  w << "CELL_TYPES ";
  w.integer(ne);
  w << '\n';
  ints(std::vector<std::int32_t>(static_cast<std::size_t>(ne), 10), false);

  const bool point_data = !mesh.node_ids.empty() || !mesh.node_tags.empty() || !options.fields.node_fields.empty();
  if (point_data) {
    w << "POINT_DATA ";
    w.integer(nn);
    w << '\n';
    if (!mesh.node_ids.empty()) id_array("node_id", mesh.node_ids);
    if (!mesh.node_tags.empty()) tag_array("node_tag", mesh.node_tags);
    fields(options.fields.node_fields, nn);
  }
  const bool cell_data = !mesh.tet_ids.empty() || !mesh.tet_tags.empty() || !options.fields.tet_fields.empty();
  if (cell_data) {
    w << "CELL_DATA ";
    w.integer(ne);
    w << '\n';
    if (!mesh.tet_ids.empty()) id_array("tet_id", mesh.tet_ids);
    if (!mesh.tet_tags.empty()) tag_array("tag", mesh.tet_tags);
    fields(options.fields.tet_fields, ne);
  }
  w.flush();
  if (!w.good()) return make_error("write_vtk: the output stream failed");
  return {};
}

}  // namespace shatter
