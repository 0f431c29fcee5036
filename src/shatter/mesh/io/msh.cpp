// Gmsh MSH reader (2.2 and 4.1, ASCII and binary) and writer (4.1, ASCII or binary).
// Linear tets (type 4) become the mesh; every other element type is counted in `skipped`, and when
// a file holds such elements the nodes no tet uses are dropped (so a surface + volume file loads
// cleanly). Tet tags: 2.2 the first element tag (physical), 4.1 the first physical tag of the
// element's volume entity. Physical names of volumes become tet_sets.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <ostream>
#include <set>

#include "shatter/core/log.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/mesh_io_util.h"
#include "shatter/mesh/io/text_cursor.h"

namespace shatter {
namespace {

using io::ByteCursor;
using io::TextCursor;

// A binary MSH 4.1 tag (size_t in the file) as a file id: above the largest int64 it would wrap to
// a negative id ("node id -1" for 2^64 - 1), so it is refused, naming the value.
Result<FileId> read_tag(ByteCursor& b, const char* what) {
  SHATTER_TRY(v, b.u64(what));
  if (*v > static_cast<std::uint64_t>(std::numeric_limits<FileId>::max()))
    return b.error(std::string(what) + " " + std::to_string(*v) + " is larger than the largest id " +
                   std::to_string(std::numeric_limits<FileId>::max()));
  return static_cast<FileId>(*v);
}

constexpr std::int64_t kMaxIndex = std::numeric_limits<Index>::max();

struct GmshType {
  int type;
  int nodes;
  const char* singular;
  const char* plural;
};
constexpr GmshType kGmshTypes[] = {
    {1, 2, "line", "lines"},
    {2, 3, "triangle", "triangles"},
    {3, 4, "quadrangle", "quadrangles"},
    {4, 4, "tetrahedron", "tetrahedra"},
    {5, 8, "hexahedron", "hexahedra"},
    {6, 6, "prism", "prisms"},
    {7, 5, "pyramid", "pyramids"},
    {8, 3, "quadratic line", "quadratic lines"},
    {9, 6, "quadratic triangle", "quadratic triangles"},
    {10, 9, "9-node quadrangle", "9-node quadrangles"},
    {11, 10, "quadratic tetrahedron", "quadratic tetrahedra"},
    {12, 27, "27-node hexahedron", "27-node hexahedra"},
    {13, 18, "18-node prism", "18-node prisms"},
    {14, 14, "14-node pyramid", "14-node pyramids"},
    {15, 1, "point", "points"},
    {16, 8, "8-node quadrangle", "8-node quadrangles"},
    {17, 20, "20-node hexahedron", "20-node hexahedra"},
    {18, 15, "15-node prism", "15-node prisms"},
    {19, 13, "13-node pyramid", "13-node pyramids"},
    {20, 9, "9-node triangle", "9-node triangles"},
    {21, 10, "10-node triangle", "10-node triangles"},
    {22, 12, "12-node triangle", "12-node triangles"},
    {23, 15, "15-node triangle", "15-node triangles"},
    {24, 15, "15-node triangle", "15-node triangles"},
    {25, 21, "21-node triangle", "21-node triangles"},
    {26, 4, "cubic line", "cubic lines"},
    {27, 5, "4th-order line", "4th-order lines"},
    {28, 6, "5th-order line", "5th-order lines"},
    {29, 20, "cubic tetrahedron", "cubic tetrahedra"},
    {30, 35, "4th-order tetrahedron", "4th-order tetrahedra"},
    {31, 56, "5th-order tetrahedron", "5th-order tetrahedra"},
    {92, 64, "64-node hexahedron", "64-node hexahedra"},
    {93, 125, "125-node hexahedron", "125-node hexahedra"},
};

const GmshType* find_type(std::int64_t type) {
  for (const GmshType& t : kGmshTypes)
    if (t.type == type) return &t;
  return nullptr;
}

/// File node tag -> node index. Tags 1..n in order (the usual case) need no table.
class NodeLookup {
 public:
  /// Fails with the duplicated tag, if any.
  bool build(const std::vector<FileId>& tags, FileId& duplicate) {
    contiguous_ = true;
    first_ = tags.empty() ? 1 : tags[0];
    for (std::size_t i = 0; i < tags.size(); ++i)
      if (tags[i] != first_ + static_cast<FileId>(i)) {
        contiguous_ = false;
        break;
      }
    count_ = tags.size();
    sorted_.clear();
    if (contiguous_) return true;
    sorted_.reserve(tags.size());
    for (std::size_t i = 0; i < tags.size(); ++i) sorted_.emplace_back(tags[i], static_cast<Index>(i));
    std::sort(sorted_.begin(), sorted_.end());
    for (std::size_t i = 1; i < sorted_.size(); ++i)
      if (sorted_[i].first == sorted_[i - 1].first) {
        duplicate = sorted_[i].first;
        return false;
      }
    return true;
  }
  /// -1 if the tag is not a node.
  [[nodiscard]] Index find(FileId tag) const {
    if (contiguous_) {
      if (tag < first_ || static_cast<std::uint64_t>(tag - first_) >= count_) return -1;
      return static_cast<Index>(tag - first_);
    }
    const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::make_pair(tag, Index(-1)));
    if (it == sorted_.end() || it->first != tag) return -1;
    return it->second;
  }

 private:
  bool contiguous_ = true;
  FileId first_ = 1;
  std::size_t count_ = 0;
  std::vector<std::pair<FileId, Index>> sorted_;
};

class MshReader {
 public:
  MshReader(std::string_view bytes, const std::string& name) : bytes_(bytes), name_(name), c_(bytes, name) {}

  Result<MeshReadResult> read() {
    const std::string_view first = c_.next_token();
    if (first.empty()) return c_.error("empty file: expected '$MeshFormat'");
    if (first != "$MeshFormat")
      return c_.error("not a Gmsh MSH file: expected '$MeshFormat', found " + io::quote_token(first));
    if (auto r = read_format(); !r) return r.error();
    bool have_nodes = false, have_elements = false;
    for (;;) {
      const std::string_view tok = c_.next_token();
      if (tok.empty()) break;
      Result<void> r;
      if (tok == "$PhysicalNames") {
        r = read_physical_names();
      } else if (tok == "$Entities") {
        r = version_ == 4 ? read_entities() : skip_section(tok);
      } else if (tok == "$Nodes") {
        if (have_nodes) return c_.error("second $Nodes section");
        have_nodes = true;
        r = version_ == 4 ? read_nodes41() : read_nodes22();
      } else if (tok == "$Elements") {
        if (!have_nodes) return c_.error("$Elements before $Nodes");
        if (have_elements) return c_.error("second $Elements section");
        have_elements = true;
        r = version_ == 4 ? read_elements41() : read_elements22();
      } else if (tok[0] == '$' && tok.size() > 1 && tok.substr(0, 4) != "$End") {
        r = skip_section(tok);
      } else {
        return c_.error("expected a section such as '$Nodes' or '$Elements', found " + io::quote_token(tok));
      }
      if (!r) return r.error();
    }
    if (!have_nodes) return c_.error("file ends without a $Nodes section");
    if (!have_elements) return c_.error("file ends without an $Elements section");
    return finish();
  }

 private:
  // --- $MeshFormat ---
  Result<void> read_format() {
    const std::string_view v = c_.next_token();
    if (v.empty()) return c_.error("file ends where the MSH version was expected");
    if (v == "2" || v == "2.0" || v == "2.1" || v == "2.2") {
      version_ = 2;
    } else if (v == "4.1") {
      version_ = 4;
    } else {
      return c_.error("unsupported MSH version " + io::quote_token(v) + " (2.2 and 4.1 are supported)");
    }
    version_text_ = std::string(v);
    SHATTER_TRY(file_type, c_.next_int_in("file type (0 ASCII, 1 binary)", 0, 1));
    binary_ = *file_type == 1;
    SHATTER_TRY(data_size, c_.next_int("data size"));
    if (*data_size != 8) return c_.error("expected data size 8, found " + std::to_string(*data_size));
    if (binary_) {
      // One int 1 written in the file's byte order, right after the header line.
      c_.skip_blanks();
      (void)c_.take_bytes(c_.at_end() || c_.rest()[0] != '\n' ? 0 : 1, "newline");
      ByteCursor b(bytes_, name_, c_.position());
      SHATTER_TRY(one, b.i32("binary endianness marker (int 1)"));
      if (*one != 1) {
        ByteCursor be(bytes_, name_, c_.position(), true);
        SHATTER_TRY(swapped, be.i32("binary endianness marker (int 1)"));
        if (*swapped == 1) return b.error("big-endian binary MSH is not supported (marker reads 1 only byte-swapped)");
        return b.error("bad binary endianness marker: expected int 1, found " + std::to_string(*one));
      }
      (void)c_.take_bytes(4, "endianness marker");
    }
    return end_section("$EndMeshFormat");
  }

  Result<void> end_section(std::string_view end) { return c_.expect(end); }

  Result<void> skip_section(std::string_view tok) {
    const std::string end = "$End" + std::string(tok.substr(1));
    const std::string_view rest = c_.rest();
    std::size_t at = 0;
    for (;;) {
      at = rest.find(end, at);
      if (at == std::string_view::npos) return c_.error("section " + std::string(tok) + " has no " + end);
      // Must start a line.
      if (at == 0 || rest[at - 1] == '\n') break;
      ++at;
    }
    (void)c_.take_bytes(at + end.size(), "skipped section");
    skipped_sections_.emplace_back(tok);
    return {};
  }

  /// Each item needs at least `min_bytes` bytes of text.
  Result<void> require_text(std::int64_t count, std::int64_t min_bytes, const char* what) {
    if (count < 0) return c_.error(std::string("negative ") + what + " count " + std::to_string(count));
    if (static_cast<std::uint64_t>(count) > c_.remaining() / static_cast<std::uint64_t>(min_bytes))
      return c_.error(std::string(what) + " count " + std::to_string(count) + " is larger than the " +
                      std::to_string(c_.remaining()) + " bytes that remain can hold");
    return {};
  }

  // --- $PhysicalNames ---
  Result<void> read_physical_names() {
    SHATTER_TRY(n, c_.next_int("physical name count"));
    if (auto r = require_text(*n, 6, "physical name"); !r) return r;
    for (std::int64_t i = 0; i < *n; ++i) {
      SHATTER_TRY(dim, c_.next_int_in("physical dimension", 0, 3));
      SHATTER_TRY(tag, c_.next_int_in("physical tag", std::numeric_limits<std::int32_t>::min(),
                                      std::numeric_limits<std::int32_t>::max()));
      c_.skip_blanks();
      std::string_view line = c_.next_line();
      while (!line.empty() && (line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
      if (line.size() >= 2 && line.front() == '"' && line.back() == '"') line = line.substr(1, line.size() - 2);
      if (*dim == 3 && !line.empty()) physical_names_[static_cast<std::int32_t>(*tag)] = std::string(line);
    }
    return end_section("$EndPhysicalNames");
  }

  // --- $Entities (4.1): only the physical tag of volumes matters; the rest is skipped. ---
  Result<void> read_entities() {
    if (binary_) {
      c_.skip_blanks();
      (void)c_.take_bytes(!c_.at_end() && c_.rest()[0] == '\n' ? 1 : 0, "newline");
      ByteCursor b(bytes_, name_, c_.position());
      std::uint64_t counts[4];
      for (auto& n : counts) {
        SHATTER_TRY(v, b.u64("entity count"));
        n = *v;
      }
      for (int dim = 0; dim < 4; ++dim) {
        if (auto r = b.require(counts[dim], dim == 0 ? 36 : 72, "entities"); !r) return r;
        for (std::uint64_t i = 0; i < counts[dim]; ++i) {
          SHATTER_TRY(tag, b.i32("entity tag"));
          SHATTER_TRY(box, b.take(dim == 0 ? 24 : 48, "entity coordinates"));
          SHATTER_TRY(nphys, b.u64("physical tag count"));
          if (auto r = b.require(*nphys, 4, "physical tags"); !r) return r;
          for (std::uint64_t k = 0; k < *nphys; ++k) {
            SHATTER_TRY(p, b.i32("physical tag"));
            if (dim == 3 && k == 0) volume_physical_[*tag] = *p;
          }
          if (dim > 0) {
            SHATTER_TRY(nb, b.u64("bounding entity count"));
            if (auto r = b.require(*nb, 4, "bounding entities"); !r) return r;
            SHATTER_TRY(skip, b.take(static_cast<std::size_t>(*nb) * 4, "bounding entities"));
          }
        }
      }
      (void)c_.take_bytes(b.position() - c_.position(), "entities");
      return end_section("$EndEntities");
    }
    std::int64_t counts[4];
    for (auto& n : counts) {
      SHATTER_TRY(v, c_.next_int("entity count"));
      n = *v;
    }
    for (int dim = 0; dim < 4; ++dim) {
      if (auto r = require_text(counts[dim], dim == 0 ? 10 : 20, "entity"); !r) return r;
      for (std::int64_t i = 0; i < counts[dim]; ++i) {
        SHATTER_TRY(tag, c_.next_int_in("entity tag", std::numeric_limits<std::int32_t>::min(),
                                        std::numeric_limits<std::int32_t>::max()));
        for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) {
          SHATTER_TRY(x, c_.next_double("entity coordinate"));
        }
        SHATTER_TRY(nphys, c_.next_int("physical tag count"));
        if (auto r = require_text(*nphys, 2, "physical tag"); !r) return r;
        for (std::int64_t k = 0; k < *nphys; ++k) {
          SHATTER_TRY(p, c_.next_int_in("physical tag", std::numeric_limits<std::int32_t>::min(),
                                        std::numeric_limits<std::int32_t>::max()));
          if (dim == 3 && k == 0) volume_physical_[static_cast<std::int32_t>(*tag)] = static_cast<std::int32_t>(*p);
        }
        if (dim > 0) {
          SHATTER_TRY(nb, c_.next_int("bounding entity count"));
          if (auto r = require_text(*nb, 2, "bounding entity"); !r) return r;
          for (std::int64_t k = 0; k < *nb; ++k) {
            SHATTER_TRY(t, c_.next_int("bounding entity tag"));
          }
        }
      }
    }
    return end_section("$EndEntities");
  }

  Result<void> check_node_total(std::int64_t total) {
    if (total < 0) return c_.error("negative node count " + std::to_string(total));
    if (total > kMaxIndex) return c_.error("node count " + std::to_string(total) + " exceeds the limit of 2^31-1");
    return {};
  }

  Result<void> add_node(FileId tag, double x, double y, double z, ByteCursor* b) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
      const std::string msg = "node " + std::to_string(tag) + " has a coordinate that is not finite";
      return b ? b->error(msg) : c_.error(msg);
    }
    node_tags_.push_back(tag);
    positions_.emplace_back(x, y, z);
    return {};
  }

  Result<void> build_lookup() {
    FileId dup = 0;
    if (!lookup_.build(node_tags_, dup))
      return c_.error("node tag " + std::to_string(dup) + " appears twice in $Nodes");
    return {};
  }

  // --- $Nodes 2.2 ---
  Result<void> read_nodes22() {
    SHATTER_TRY(n, c_.next_int("node count"));
    if (auto r = check_node_total(*n); !r) return r;
    if (binary_) {
      c_.skip_blanks();
      (void)c_.take_bytes(!c_.at_end() && c_.rest()[0] == '\n' ? 1 : 0, "newline");
      ByteCursor b(bytes_, name_, c_.position());
      if (auto r = b.require(static_cast<std::uint64_t>(*n), 28, "nodes"); !r) return r;
      positions_.reserve(static_cast<std::size_t>(*n));
      node_tags_.reserve(static_cast<std::size_t>(*n));
      for (std::int64_t i = 0; i < *n; ++i) {
        SHATTER_TRY(tag, b.i32("node tag"));
        SHATTER_TRY(x, b.f64("x"));
        SHATTER_TRY(y, b.f64("y"));
        SHATTER_TRY(z, b.f64("z"));
        if (auto r = add_node(*tag, *x, *y, *z, &b); !r) return r;
      }
      (void)c_.take_bytes(b.position() - c_.position(), "nodes");
    } else {
      if (auto r = require_text(*n, 7, "node"); !r) return r;
      positions_.reserve(static_cast<std::size_t>(*n));
      node_tags_.reserve(static_cast<std::size_t>(*n));
      for (std::int64_t i = 0; i < *n; ++i) {
        SHATTER_TRY(tag, c_.next_int("node tag"));
        SHATTER_TRY(x, c_.next_double("x coordinate"));
        SHATTER_TRY(y, c_.next_double("y coordinate"));
        SHATTER_TRY(z, c_.next_double("z coordinate"));
        if (auto r = add_node(*tag, *x, *y, *z, nullptr); !r) return r;
      }
    }
    if (auto r = build_lookup(); !r) return r;
    return end_section("$EndNodes");
  }

  // --- $Nodes 4.1 ---
  Result<void> read_nodes41() {
    if (binary_) {
      c_.skip_blanks();
      (void)c_.take_bytes(!c_.at_end() && c_.rest()[0] == '\n' ? 1 : 0, "newline");
      ByteCursor b(bytes_, name_, c_.position());
      SHATTER_TRY(nblocks, b.u64("node block count"));
      SHATTER_TRY(total, b.u64("node count"));
      SHATTER_TRY(min_tag, b.u64("min node tag"));
      SHATTER_TRY(max_tag, b.u64("max node tag"));
      if (*total > static_cast<std::uint64_t>(kMaxIndex))
        return b.error("node count " + std::to_string(*total) + " exceeds the limit of 2^31-1");
      if (auto r = b.require(*total, 32, "nodes"); !r) return r;
      if (auto r = b.require(*nblocks, 20, "node blocks"); !r) return r;
      positions_.reserve(static_cast<std::size_t>(*total));
      node_tags_.reserve(static_cast<std::size_t>(*total));
      for (std::uint64_t blk = 0; blk < *nblocks; ++blk) {
        SHATTER_TRY(dim, b.i32("entity dimension"));
        SHATTER_TRY(etag, b.i32("entity tag"));
        SHATTER_TRY(param, b.i32("parametric flag"));
        SHATTER_TRY(n, b.u64("nodes in block"));
        if (*dim < 0 || *dim > 3) return b.error("entity dimension must be 0..3, found " + std::to_string(*dim));
        if (*n > *total - positions_.size())
          return b.error("node blocks hold more nodes than the " + std::to_string(*total) + " declared");
        const std::uint64_t ncoord = 3 + (*param != 0 ? static_cast<std::uint64_t>(*dim) : 0);
        if (auto r = b.require(*n, 8 + 8 * ncoord, "nodes in block"); !r) return r;
        const std::size_t first = node_tags_.size();
        for (std::uint64_t i = 0; i < *n; ++i) {
          SHATTER_TRY(tag, read_tag(b, "node tag"));
          node_tags_.push_back(*tag);
        }
        for (std::uint64_t i = 0; i < *n; ++i) {
          double xyz[3];
          for (std::uint64_t k = 0; k < ncoord; ++k) {
            SHATTER_TRY(v, b.f64("node coordinate"));
            if (k < 3) xyz[k] = *v;
          }
          if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2]))
            return b.error("node " + std::to_string(node_tags_[first + i]) + " has a coordinate that is not finite");
          positions_.emplace_back(xyz[0], xyz[1], xyz[2]);
        }
      }
      if (positions_.size() != *total)
        return b.error("node blocks hold " + std::to_string(positions_.size()) + " nodes, " + std::to_string(*total) +
                       " declared");
      (void)c_.take_bytes(b.position() - c_.position(), "nodes");
    } else {
      SHATTER_TRY(nblocks, c_.next_int("node block count"));
      SHATTER_TRY(total, c_.next_int("node count"));
      SHATTER_TRY(min_tag, c_.next_int("min node tag"));
      SHATTER_TRY(max_tag, c_.next_int("max node tag"));
      if (auto r = check_node_total(*total); !r) return r;
      if (auto r = require_text(*total, 7, "node"); !r) return r;
      if (auto r = require_text(*nblocks, 8, "node block"); !r) return r;
      positions_.reserve(static_cast<std::size_t>(*total));
      node_tags_.reserve(static_cast<std::size_t>(*total));
      for (std::int64_t blk = 0; blk < *nblocks; ++blk) {
        SHATTER_TRY(dim, c_.next_int_in("entity dimension", 0, 3));
        SHATTER_TRY(etag, c_.next_int("entity tag"));
        SHATTER_TRY(param, c_.next_int_in("parametric flag", 0, 1));
        SHATTER_TRY(n, c_.next_int("nodes in block"));
        if (*n < 0 || static_cast<std::uint64_t>(*n) > static_cast<std::uint64_t>(*total) - positions_.size())
          return c_.error("node block of " + std::to_string(*n) + " nodes: blocks hold more than the " +
                          std::to_string(*total) + " nodes declared");
        const int ncoord = 3 + (*param != 0 ? static_cast<int>(*dim) : 0);
        for (std::int64_t i = 0; i < *n; ++i) {
          SHATTER_TRY(tag, c_.next_int("node tag"));
          node_tags_.push_back(*tag);
        }
        for (std::int64_t i = 0; i < *n; ++i) {
          double xyz[3];
          for (int k = 0; k < ncoord; ++k) {
            SHATTER_TRY(v, c_.next_double("node coordinate"));
            if (k < 3) xyz[k] = *v;
          }
          positions_.emplace_back(xyz[0], xyz[1], xyz[2]);
        }
      }
      if (static_cast<std::int64_t>(positions_.size()) != *total)
        return c_.error("node blocks hold " + std::to_string(positions_.size()) + " nodes, " + std::to_string(*total) +
                        " declared");
    }
    if (auto r = build_lookup(); !r) return r;
    return end_section("$EndNodes");
  }

  // Adds one tet given node tags; errors name the element.
  template <class ErrFn>
  Result<void> add_tet(FileId id, const FileId* tags, std::int32_t phys, ErrFn&& err) {
    TetIndices t;
    for (int k = 0; k < 4; ++k) {
      t[k] = lookup_.find(tags[k]);
      if (t[k] < 0)
        return err("element " + std::to_string(id) + " references node " + std::to_string(tags[k]) +
                   ", which is not in $Nodes");
    }
    if (tets_.size() >= static_cast<std::size_t>(kMaxIndex)) return err("more than 2^31-1 tetrahedra");
    tets_.push_back(t);
    tet_ids_.push_back(id);
    tet_phys_.push_back(phys);
    return {};
  }

  // --- $Elements 2.2 ---
  Result<void> read_elements22() {
    SHATTER_TRY(n, c_.next_int("element count"));
    if (*n < 0) return c_.error("negative element count " + std::to_string(*n));
    if (binary_) {
      c_.skip_blanks();
      (void)c_.take_bytes(!c_.at_end() && c_.rest()[0] == '\n' ? 1 : 0, "newline");
      ByteCursor b(bytes_, name_, c_.position());
      if (auto r = b.require(static_cast<std::uint64_t>(*n), 8, "elements"); !r) return r;
      std::int64_t done = 0;
      while (done < *n) {
        SHATTER_TRY(type, b.i32("element type"));
        SHATTER_TRY(follow, b.i32("element count in block"));
        SHATTER_TRY(ntags, b.i32("tag count"));
        const GmshType* gt = find_type(*type);
        if (!gt) return b.error("unknown gmsh element type " + std::to_string(*type) + " in binary file");
        if (*follow < 0 || *follow > *n - done)
          return b.error("element block of " + std::to_string(*follow) + " elements exceeds the declared count");
        if (*ntags < 0) return b.error("negative tag count " + std::to_string(*ntags));
        const std::uint64_t per = 1 + static_cast<std::uint64_t>(*ntags) + static_cast<std::uint64_t>(gt->nodes);
        if (auto r = b.require(static_cast<std::uint64_t>(*follow), per * 4, "elements"); !r) return r;
        for (std::int32_t i = 0; i < *follow; ++i) {
          if (gt->type != 4) {
            (void)b.take(per * 4, "element");
            continue;
          }
          SHATTER_TRY(id, b.i32("element tag"));
          std::int32_t phys = 0;
          for (std::int32_t k = 0; k < *ntags; ++k) {
            SHATTER_TRY(tag, b.i32("element tag"));
            if (k == 0) phys = *tag;
          }
          if (*ntags > 0) any_phys_ = true;
          FileId nodes[4];
          for (auto& v : nodes) {
            SHATTER_TRY(x, b.i32("node tag"));
            v = *x;
          }
          if (auto r = add_tet(*id, nodes, phys, [&](const std::string& m) { return b.error(m); }); !r) return r;
        }
        if (gt->type != 4) skipped_elements_[gt->type] += *follow;
        done += *follow;
      }
      (void)c_.take_bytes(b.position() - c_.position(), "elements");
      return end_section("$EndElements");
    }
    if (auto r = require_text(*n, 8, "element"); !r) return r;
    for (std::int64_t i = 0; i < *n; ++i) {
      SHATTER_TRY(id, c_.next_int("element tag"));
      SHATTER_TRY(type, c_.next_int("element type"));
      if (*type != 4) {
        // Skip the rest of this element's line.
        (void)c_.next_line();
        ++skipped_elements_[*type];
        continue;
      }
      SHATTER_TRY(ntags, c_.next_int_in("tag count", 0, 1000000));
      std::int32_t phys = 0;
      for (std::int64_t k = 0; k < *ntags; ++k) {
        SHATTER_TRY(tag, c_.next_int_in("element tag", std::numeric_limits<std::int32_t>::min(),
                                        std::numeric_limits<std::int32_t>::max()));
        if (k == 0) phys = static_cast<std::int32_t>(*tag);
      }
      if (*ntags > 0) any_phys_ = true;
      FileId nodes[4];
      for (auto& v : nodes) {
        SHATTER_TRY(x, c_.next_int("node tag"));
        v = *x;
      }
      if (auto r = add_tet(*id, nodes, phys, [&](const std::string& m) { return c_.error(m); }); !r) return r;
    }
    return end_section("$EndElements");
  }

  // --- $Elements 4.1 ---
  Result<void> read_elements41() {
    if (binary_) {
      c_.skip_blanks();
      (void)c_.take_bytes(!c_.at_end() && c_.rest()[0] == '\n' ? 1 : 0, "newline");
      ByteCursor b(bytes_, name_, c_.position());
      SHATTER_TRY(nblocks, b.u64("element block count"));
      SHATTER_TRY(total, b.u64("element count"));
      SHATTER_TRY(min_tag, b.u64("min element tag"));
      SHATTER_TRY(max_tag, b.u64("max element tag"));
      if (auto r = b.require(*total, 16, "elements"); !r) return r;
      if (auto r = b.require(*nblocks, 20, "element blocks"); !r) return r;
      std::uint64_t done = 0;
      for (std::uint64_t blk = 0; blk < *nblocks; ++blk) {
        SHATTER_TRY(dim, b.i32("entity dimension"));
        SHATTER_TRY(etag, b.i32("entity tag"));
        SHATTER_TRY(type, b.i32("element type"));
        SHATTER_TRY(n, b.u64("elements in block"));
        const GmshType* gt = find_type(*type);
        if (!gt) return b.error("unknown gmsh element type " + std::to_string(*type) + " in binary file");
        if (*n > *total - done)
          return b.error("element blocks hold more elements than the " + std::to_string(*total) + " declared");
        const std::uint64_t per = 1 + static_cast<std::uint64_t>(gt->nodes);
        if (auto r = b.require(*n, per * 8, "elements in block"); !r) return r;
        if (gt->type != 4) {
          (void)b.take(static_cast<std::size_t>(*n * per * 8), "elements");
          skipped_elements_[gt->type] += static_cast<std::int64_t>(*n);
        } else {
          const std::int32_t phys = block_physical(*dim, *etag);
          for (std::uint64_t i = 0; i < *n; ++i) {
            SHATTER_TRY(id, read_tag(b, "element tag"));
            FileId nodes[4];
            for (auto& v : nodes) {
              SHATTER_TRY(x, read_tag(b, "node tag"));
              v = *x;
            }
            if (auto r = add_tet(*id, nodes, phys, [&](const std::string& m) { return b.error(m); }); !r) return r;
          }
        }
        done += *n;
      }
      if (done != *total)
        return b.error("element blocks hold " + std::to_string(done) + " elements, " + std::to_string(*total) +
                       " declared");
      (void)c_.take_bytes(b.position() - c_.position(), "elements");
      return end_section("$EndElements");
    }
    SHATTER_TRY(nblocks, c_.next_int("element block count"));
    SHATTER_TRY(total, c_.next_int("element count"));
    SHATTER_TRY(min_tag, c_.next_int("min element tag"));
    SHATTER_TRY(max_tag, c_.next_int("max element tag"));
    if (auto r = require_text(*total, 4, "element"); !r) return r;
    if (auto r = require_text(*nblocks, 8, "element block"); !r) return r;
    std::int64_t done = 0;
    for (std::int64_t blk = 0; blk < *nblocks; ++blk) {
      SHATTER_TRY(dim, c_.next_int_in("entity dimension", 0, 3));
      SHATTER_TRY(etag, c_.next_int_in("entity tag", std::numeric_limits<std::int32_t>::min(),
                                       std::numeric_limits<std::int32_t>::max()));
      SHATTER_TRY(type, c_.next_int("element type"));
      SHATTER_TRY(n, c_.next_int("elements in block"));
      if (*n < 0 || *n > *total - done)
        return c_.error("element block of " + std::to_string(*n) + " elements: blocks hold more than the " +
                        std::to_string(*total) + " elements declared");
      const GmshType* gt = find_type(*type);
      if (!gt || gt->type != 4) {
        if (gt) {
          for (std::int64_t i = 0; i < *n * (1 + gt->nodes); ++i) {
            SHATTER_TRY(x, c_.next_int("element tag or node tag"));
          }
        } else {
          // Unknown type: one element per line.
          (void)c_.next_line();
          for (std::int64_t i = 0; i < *n; ++i) {
            if (c_.at_end()) return c_.error("file ends inside an element block");
            (void)c_.next_line();
          }
        }
        skipped_elements_[static_cast<int>(*type)] += *n;
      } else {
        const std::int32_t phys = block_physical(static_cast<int>(*dim), static_cast<std::int32_t>(*etag));
        for (std::int64_t i = 0; i < *n; ++i) {
          SHATTER_TRY(id, c_.next_int("element tag"));
          FileId nodes[4];
          for (auto& v : nodes) {
            SHATTER_TRY(x, c_.next_int("node tag"));
            v = *x;
          }
          if (auto r = add_tet(*id, nodes, phys, [&](const std::string& m) { return c_.error(m); }); !r) return r;
        }
      }
      done += *n;
    }
    if (done != *total)
      return c_.error("element blocks hold " + std::to_string(done) + " elements, " + std::to_string(*total) +
                      " declared");
    return end_section("$EndElements");
  }

  std::int32_t block_physical(int dim, std::int32_t entity_tag) {
    if (dim != 3) return 0;
    const auto it = volume_physical_.find(entity_tag);
    if (it == volume_physical_.end()) return 0;
    any_phys_ = true;
    return it->second;
  }

  Result<MeshReadResult> finish() {
    MeshReadResult out;
    out.format = "msh " +
                 std::string(version_ == 4          ? "4.1"
                             : version_text_ == "2" ? "2.0"
                                                    : version_text_) +
                 (binary_ ? " binary" : " ascii");
    if (tets_.empty()) {
      std::string what;
      for (const auto& [type, n] : skipped_elements_)
        what += (what.empty() ? "" : ", ") + std::to_string(n) + " of gmsh type " + std::to_string(type);
      return c_.error("no linear tetrahedra (gmsh type 4) in the file" +
                      (what.empty() ? std::string() : " (found " + what + ")"));
    }
    TetMesh& m = out.mesh;
    m.positions = std::move(positions_);
    m.node_ids = std::move(node_tags_);
    m.tets = std::move(tets_);
    m.tet_ids = std::move(tet_ids_);
    if (any_phys_) m.tet_tags = std::move(tet_phys_);
    for (const auto& [type, n] : skipped_elements_) {
      const GmshType* gt = find_type(type);
      out.skipped.push_back(
          gt ? io::count_phrase(n, gt->singular, gt->plural) + " (gmsh type " + std::to_string(type) + ")"
             : io::count_phrase(n, "element", "elements") + " of unknown gmsh type " + std::to_string(type));
    }
    if (!skipped_elements_.empty()) {
      const Index dropped = io::drop_unused_nodes(m);
      if (dropped > 0) out.skipped.push_back(io::count_phrase(dropped, "node", "nodes") + " used by no tetrahedron");
    }
    for (const std::string& s : skipped_sections_) out.skipped.push_back("section " + s);
    io::drop_default_ids(m.node_ids);
    io::drop_default_ids(m.tet_ids);
    // Named volume regions become tet sets.
    if (!m.tet_tags.empty())
      for (const auto& [tag, name] : physical_names_) {
        std::vector<Index> set;
        for (Index e = 0; e < m.num_tets(); ++e)
          if (m.tet_tags[e] == tag) set.push_back(e);
        if (!set.empty()) m.tet_sets[name] = std::move(set);
      }
    return out;
  }

  std::string_view bytes_;
  std::string name_;
  TextCursor c_;
  int version_ = 0;
  std::string version_text_;
  bool binary_ = false;
  std::vector<Vec3> positions_;
  std::vector<FileId> node_tags_;
  NodeLookup lookup_;
  std::vector<TetIndices> tets_;
  std::vector<FileId> tet_ids_;
  std::vector<std::int32_t> tet_phys_;
  bool any_phys_ = false;
  std::map<int, std::int64_t> skipped_elements_;
  std::vector<std::string> skipped_sections_;
  std::map<std::int32_t, std::int32_t> volume_physical_;
  std::map<std::int32_t, std::string> physical_names_;
};

}  // namespace

Result<MeshReadResult> parse_msh(std::string_view bytes, const std::string& name) {
  MshReader reader(bytes, name);
  return reader.read();
}

// --- Writer: MSH 4.1. Node tags are node ids, element tags tet ids. With tet tags, one volume
// entity per distinct tag (entity tag = physical tag) so Gmsh and meshio read the tags back; tets
// are written in their order, one element block per run of equal tags. ---
Result<void> write_msh(std::ostream& out, const TetMesh& mesh, const MeshWriteOptions& options) {
  const bool bin = options.binary;
  const Index nn = mesh.num_nodes(), ne = mesh.num_tets();
  if (!mesh.node_ids.empty() && mesh.node_ids.size() != static_cast<std::size_t>(nn))
    return make_error("write_msh: node_ids has " + std::to_string(mesh.node_ids.size()) + " entries for " +
                      std::to_string(nn) + " nodes");
  if (!mesh.tet_ids.empty() && mesh.tet_ids.size() != static_cast<std::size_t>(ne))
    return make_error("write_msh: tet_ids has " + std::to_string(mesh.tet_ids.size()) + " entries for " +
                      std::to_string(ne) + " tets");
  const bool tagged = !mesh.tet_tags.empty();
  if (tagged && mesh.tet_tags.size() != static_cast<std::size_t>(ne))
    return make_error("write_msh: tet_tags has " + std::to_string(mesh.tet_tags.size()) + " entries for " +
                      std::to_string(ne) + " tets");
  // Gmsh tags are > 0. Ids that are not all positive (TetGen's and MEDIT's may start at 0) cannot
  // be kept: the nodes or tets are then tagged 1..n, and a warning says so.
  bool node_ids_kept = true, tet_ids_kept = true;
  for (Index i = 0; i < nn && node_ids_kept; ++i) node_ids_kept = mesh.node_id(i) > 0;
  for (Index e = 0; e < ne && tet_ids_kept; ++e) tet_ids_kept = mesh.tet_id(e) > 0;
  if (!node_ids_kept) log_warning("write_msh: node ids are not all positive; Gmsh node tags written as 1..n");
  if (!tet_ids_kept) log_warning("write_msh: tet ids are not all positive; Gmsh element tags written as 1..n");
  auto node_tag = [&](Index i) { return node_ids_kept ? mesh.node_id(i) : FileId{i} + 1; };
  auto tet_tag = [&](Index e) { return tet_ids_kept ? mesh.tet_id(e) : FileId{e} + 1; };
  FileId min_node = std::numeric_limits<FileId>::max(), max_node = 0, min_tet = std::numeric_limits<FileId>::max(),
         max_tet = 0;
  for (Index i = 0; i < nn; ++i) {
    min_node = std::min(min_node, node_tag(i));
    max_node = std::max(max_node, node_tag(i));
  }
  for (Index e = 0; e < ne; ++e) {
    min_tet = std::min(min_tet, tet_tag(e));
    max_tet = std::max(max_tet, tet_tag(e));
  }
  if (nn == 0) min_node = 0;
  if (ne == 0) min_tet = 0;
  for (Index e = 0; e < ne; ++e)
    for (Index v : mesh.tets[e])
      if (v < 0 || v >= nn)
        return make_error("write_msh: tet " + std::to_string(tet_tag(e)) + " has node index " + std::to_string(v) +
                          " out of range");

  io::WriteBuffer w(out);
  auto size_t_val = [&](std::uint64_t v) { w.raw(v, false); };
  auto int_val = [&](std::int32_t v) { w.raw(v, false); };
  w << "$MeshFormat\n4.1 " << (bin ? "1" : "0") << " 8\n";
  if (bin) {
    int_val(1);
    w << '\n';
  }
  w << "$EndMeshFormat\n";

  // Distinct tags, sorted, and physical names from tet sets that are exactly one tag's tets.
  std::vector<std::int32_t> tags;
  if (tagged) {
    std::set<std::int32_t> s(mesh.tet_tags.begin(), mesh.tet_tags.end());
    tags.assign(s.begin(), s.end());
  }
  std::vector<std::pair<std::int32_t, std::string>> names;
  if (tagged) {
    std::map<std::int32_t, std::size_t> tag_count;
    for (std::int32_t t : mesh.tet_tags) ++tag_count[t];
    for (const auto& [name, set] : mesh.tet_sets) {
      if (set.empty() || set[0] < 0 || set[0] >= ne) continue;
      const std::int32_t t = mesh.tet_tags[set[0]];
      bool same = set.size() == tag_count[t];
      for (Index e : set) same = same && e >= 0 && e < ne && mesh.tet_tags[e] == t;
      if (same && name.find('"') == std::string::npos && name.find('\n') == std::string::npos)
        names.emplace_back(t, name);
    }
    std::sort(names.begin(), names.end());
  }
  if (!names.empty()) {
    w << "$PhysicalNames\n";
    w.integer(static_cast<std::int64_t>(names.size()));
    w << '\n';
    for (const auto& [t, name] : names) {
      w << "3 ";
      w.integer(t);
      w << " \"" << name << "\"\n";
    }
    w << "$EndPhysicalNames\n";
  }

  // Entities: one volume per tag, with the bounding box of its tets.
  if (tagged) {
    std::map<std::int32_t, Aabb> boxes;
    for (Index e = 0; e < ne; ++e)
      for (Index v : mesh.tets[e]) boxes[mesh.tet_tags[e]].extend(mesh.positions[v]);
    w << "$Entities\n";
    if (bin) {
      size_t_val(0);
      size_t_val(0);
      size_t_val(0);
      size_t_val(tags.size());
      for (std::int32_t t : tags) {
        int_val(t);
        const Aabb& b = boxes[t];
        for (int k = 0; k < 3; ++k) w.raw(b.min[k], false);
        for (int k = 0; k < 3; ++k) w.raw(b.max[k], false);
        size_t_val(1);
        int_val(t);
        size_t_val(0);
      }
      w << '\n';
    } else {
      w << "0 0 0 ";
      w.integer(static_cast<std::int64_t>(tags.size()));
      w << '\n';
      for (std::int32_t t : tags) {
        w.integer(t);
        const Aabb& b = boxes[t];
        for (int k = 0; k < 3; ++k) {
          w << ' ';
          w.number(b.min[k]);
        }
        for (int k = 0; k < 3; ++k) {
          w << ' ';
          w.number(b.max[k]);
        }
        w << " 1 ";
        w.integer(t);
        w << " 0\n";
      }
    }
    w << "$EndEntities\n";
  }

  // Nodes: one block, classified on the first volume.
  const std::int32_t node_entity = tagged ? tags.front() : 1;
  w << "$Nodes\n";
  if (bin) {
    size_t_val(nn > 0 ? 1 : 0);
    size_t_val(static_cast<std::uint64_t>(nn));
    size_t_val(static_cast<std::uint64_t>(min_node));
    size_t_val(static_cast<std::uint64_t>(max_node));
    if (nn > 0) {
      int_val(3);
      int_val(node_entity);
      int_val(0);
      size_t_val(static_cast<std::uint64_t>(nn));
      for (Index i = 0; i < nn; ++i) size_t_val(static_cast<std::uint64_t>(node_tag(i)));
      for (const Vec3& p : mesh.positions)
        for (int k = 0; k < 3; ++k) w.raw(p[k], false);
    }
    w << '\n';
  } else {
    w.integer(nn > 0 ? 1 : 0);
    w << ' ';
    w.integer(nn);
    w << ' ';
    w.integer(min_node);
    w << ' ';
    w.integer(max_node);
    w << '\n';
    if (nn > 0) {
      w << "3 ";
      w.integer(node_entity);
      w << " 0 ";
      w.integer(nn);
      w << '\n';
      for (Index i = 0; i < nn; ++i) {
        w.integer(node_tag(i));
        w << '\n';
      }
      for (const Vec3& p : mesh.positions) {
        w.number(p[0]);
        w << ' ';
        w.number(p[1]);
        w << ' ';
        w.number(p[2]);
        w << '\n';
      }
    }
  }
  w << "$EndNodes\n";

  // Elements: one block per run of equal tags.
  std::vector<std::pair<Index, Index>> runs;  // [begin, end)
  for (Index e = 0; e < ne;) {
    Index f = e + 1;
    while (f < ne && tagged && mesh.tet_tags[f] == mesh.tet_tags[e]) ++f;
    if (!tagged) f = ne;
    runs.emplace_back(e, f);
    e = f;
  }
  w << "$Elements\n";
  if (bin) {
    size_t_val(runs.size());
    size_t_val(static_cast<std::uint64_t>(ne));
    size_t_val(static_cast<std::uint64_t>(min_tet));
    size_t_val(static_cast<std::uint64_t>(max_tet));
  } else {
    w.integer(static_cast<std::int64_t>(runs.size()));
    w << ' ';
    w.integer(ne);
    w << ' ';
    w.integer(min_tet);
    w << ' ';
    w.integer(max_tet);
    w << '\n';
  }
  for (const auto& [b, e_end] : runs) {
    const std::int32_t entity = tagged ? mesh.tet_tags[b] : 1;
    if (bin) {
      int_val(3);
      int_val(entity);
      int_val(4);
      size_t_val(static_cast<std::uint64_t>(e_end - b));
      for (Index e = b; e < e_end; ++e) {
        size_t_val(static_cast<std::uint64_t>(tet_tag(e)));
        for (Index v : mesh.tets[e]) size_t_val(static_cast<std::uint64_t>(node_tag(v)));
      }
    } else {
      w << "3 ";
      w.integer(entity);
      w << " 4 ";
      w.integer(e_end - b);
      w << '\n';
      for (Index e = b; e < e_end; ++e) {
        w.integer(tet_tag(e));
        for (Index v : mesh.tets[e]) {
          w << ' ';
          w.integer(node_tag(v));
        }
        w << '\n';
      }
    }
  }
  if (bin) w << '\n';
  w << "$EndElements\n";
  w.flush();
  if (!w.good()) return make_error("write_msh: the output stream failed");
  return {};
}

}  // namespace shatter
