// Abaqus / CalculiX .inp subset: *NODE, *ELEMENT (C3D4 family read; C3D10 family read by its 4
// corner nodes; other types skipped and counted), *NSET / *ELSET (with GENERATE) -> named sets.
#include <algorithm>
#include <map>
#include <ostream>
#include <string>
#include <unordered_set>

#include "shatter/core/log.h"
#include "shatter/mesh/io/io_util.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/mesh_io_util.h"
#include "shatter/mesh/io/text_cursor.h"

namespace shatter {
namespace {

using io::TextCursor;

std::string to_upper(std::string_view s) {
  std::string r(s);
  for (char& ch : r)
    if (ch >= 'a' && ch <= 'z') ch = static_cast<char>(ch - 'a' + 'A');
  return r;
}

/// A keyword line: "*ELEMENT, TYPE=C3D4, ELSET=A" -> name "ELEMENT", params {TYPE: C3D4, ELSET: A}.
struct Keyword {
  std::int64_t line = 0;
  std::string name;                           ///< upper case, without '*'
  std::map<std::string, std::string> params;  ///< upper-case key -> value as written (quotes removed)
  [[nodiscard]] bool has(const std::string& key) const { return params.count(key) > 0; }
  [[nodiscard]] std::string get(const std::string& key) const {
    const auto it = params.find(key);
    return it == params.end() ? std::string() : it->second;
  }
};

Keyword parse_keyword(std::string_view text, std::int64_t line) {
  Keyword k;
  k.line = line;
  const auto fields = io::split_fields(text.substr(1), ',');
  k.name = to_upper(fields[0]);
  for (std::size_t i = 1; i < fields.size(); ++i) {
    if (fields[i].empty()) continue;
    const auto eq = fields[i].find('=');
    std::string key = to_upper(io::trim(fields[i].substr(0, eq)));
    std::string_view value = eq == std::string_view::npos ? std::string_view() : io::trim(fields[i].substr(eq + 1));
    if (value.size() >= 2 && value.front() == '"' && value.back() == '"') value = value.substr(1, value.size() - 2);
    k.params[key] = std::string(value);
  }
  return k;
}

enum class TetKind { none, linear, quadratic };
TetKind tet_kind(std::string type) {
  if (type.rfind("DC3D", 0) == 0 || type.rfind("AC3D", 0) == 0) type = type.substr(1);
  auto letters_only = [](std::string_view s) {
    return std::all_of(s.begin(), s.end(), [](char ch) { return ch >= 'A' && ch <= 'Z'; });
  };
  if (type.rfind("C3D10", 0) == 0 && letters_only(std::string_view(type).substr(5))) return TetKind::quadratic;
  if (type.rfind("C3D4", 0) == 0 && letters_only(std::string_view(type).substr(4))) return TetKind::linear;
  return TetKind::none;
}

/// Set data kept until the end, when all ids are known; resolved in file order.
struct SetBlock {
  bool nodes = true;
  std::string name;
  std::int64_t line = 0;
  bool generate = false;
  struct Item {
    std::int64_t line;
    std::vector<std::string_view> fields;
  };
  std::vector<Item> items;
};

class InpReader {
 public:
  InpReader(std::string_view bytes, const std::string& name) : c_(bytes, name), name_(name) {}

  Result<MeshReadResult> read() {
    if (io::trim(c_.rest()).empty()) return c_.error("empty file: expected *NODE and *ELEMENT");
    Keyword kw;
    bool have_kw = false;
    enum class Block { none, node, element, set, skip } block = Block::none;
    TetKind kind = TetKind::none;
    std::string elset, nset, type;
    std::vector<Index>* elset_target = nullptr;
    std::vector<Index>* nset_target = nullptr;
    // A pending element whose values continue on the next line.
    std::vector<std::string_view> pending;
    std::int64_t pending_line = 0;

    while (!c_.at_end() || !pending.empty()) {
      std::int64_t line = c_.line();
      std::string_view text = c_.at_end() ? std::string_view() : io::trim(c_.next_line());
      const bool is_keyword = !text.empty() && text[0] == '*' && !(text.size() > 1 && text[1] == '*');
      if (!pending.empty() && (c_.at_end() && text.empty() ? true : is_keyword)) {
        return c_.error_at(pending_line, "element " + std::string(pending[0]) + " has " +
                                             std::to_string(pending.size() - 1) + " node numbers, " + type + " needs " +
                                             std::to_string(kind == TetKind::linear ? 4 : 10));
      }
      if (text.empty() || text.rfind("**", 0) == 0) continue;
      if (is_keyword) {
        // Keyword lines ending in ',' continue on the next line.
        std::string joined(text);
        while (!joined.empty() && joined.back() == ',' && !c_.at_end()) joined += std::string(io::trim(c_.next_line()));
        kw = parse_keyword(joined, line);
        have_kw = true;
        block = Block::skip;
        if (kw.name == "NODE") {
          block = Block::node;
          nset = kw.get("NSET");
          nset_target = nset.empty() ? nullptr : &node_set(nset);
        } else if (kw.name == "ELEMENT") {
          block = Block::element;
          type = to_upper(kw.get("TYPE"));
          if (type.empty()) return c_.error_at(line, "*ELEMENT without TYPE=");
          kind = tet_kind(type);
          elset = kw.get("ELSET");
          elset_target = elset.empty() || kind == TetKind::none ? nullptr : &tet_set(elset);
          if (!elset.empty() && kind == TetKind::none) (void)tet_set(elset);
        } else if (kw.name == "NSET" || kw.name == "ELSET") {
          block = Block::set;
          SetBlock s;
          s.nodes = kw.name == "NSET";
          s.name = kw.get(kw.name);
          if (s.name.empty()) return c_.error_at(line, "*" + kw.name + " without " + kw.name + "=");
          s.line = line;
          s.generate = kw.has("GENERATE");
          sets_.push_back(std::move(s));
          if (sets_.back().nodes)
            (void)node_set(sets_.back().name);
          else
            (void)tet_set(sets_.back().name);
        } else {
          ++skipped_keywords_["*" + kw.name];
        }
        continue;
      }
      if (!have_kw)
        return c_.error_at(line, "expected a keyword line (*NODE, *ELEMENT, ...), found " + io::quote_token(text));
      if (block == Block::skip) continue;
      auto fields = io::split_fields(text, ',');
      const bool continues = fields.size() > 1 && fields.back().empty();
      if (continues) fields.pop_back();
      if (block == Block::node) {
        SHATTER_TRY(ok, read_node(fields, line, nset_target));
      } else if (block == Block::element) {
        if (kind == TetKind::none) {
          if (pending.empty()) {
            pending_line = line;
            if (!fields.empty() && !fields[0].empty()) {
              std::int64_t id = 0;
              if (!io::parse_int(fields[0], id))
                return c_.error_at(line, "expected an element number, found " + io::quote_token(fields[0]));
              skipped_ids_.insert(id);
            }
          }
          if (!continues) ++skipped_elements_[type];
          continue;
        }
        if (pending.empty()) pending_line = line;
        pending.insert(pending.end(), fields.begin(), fields.end());
        const std::size_t need = kind == TetKind::linear ? 5 : 11;
        if (pending.size() < need) continue;
        if (pending.size() > need)
          return c_.error_at(line, "element " + std::string(pending[0]) + " has " + std::to_string(pending.size() - 1) +
                                       " node numbers, " + type + " needs " + std::to_string(need - 1));
        SHATTER_TRY(ok, read_tet(pending, pending_line, kind, elset_target));
        pending.clear();
      } else if (block == Block::set) {
        sets_.back().items.push_back({line, std::move(fields)});
      }
    }
    return finish();
  }

 private:
  std::vector<Index>& node_set(const std::string& name) { return mesh().node_sets[canonical(node_names_, name)]; }
  std::vector<Index>& tet_set(const std::string& name) { return mesh().tet_sets[canonical(tet_names_, name)]; }
  /// Set names are case-insensitive; the first spelling is kept.
  static const std::string& canonical(std::map<std::string, std::string>& names, const std::string& name) {
    return names.emplace(to_upper(name), name).first->second;
  }
  TetMesh& mesh() { return result_.mesh; }

  Result<FileId> id_field(std::string_view f, std::int64_t line, const char* what) {
    std::int64_t v = 0;
    if (!io::parse_int(f, v))
      return c_.error_at(line, std::string("expected ") + what + " (an integer), found " + io::quote_token(f));
    return v;
  }

  Result<void> read_node(const std::vector<std::string_view>& f, std::int64_t line, std::vector<Index>* set) {
    if (f.size() < 2) return c_.error_at(line, "expected 'node number, x, y, z'");
    SHATTER_TRY(id, id_field(f[0], line, "node number"));
    Vec3 p = Vec3::Zero();
    for (std::size_t k = 1; k < f.size() && k <= 3; ++k) {
      if (f[k].empty()) continue;
      double x = 0;
      if (!io::parse_double(f[k], x))
        return c_.error_at(line, "expected a coordinate (a finite number), found " + io::quote_token(f[k]));
      p[static_cast<int>(k) - 1] = x;
    }
    if (mesh().positions.size() >= static_cast<std::size_t>(io::kMaxEntities))
      return c_.error_at(line, "too many nodes");
    const auto index = static_cast<Index>(mesh().positions.size());
    if (!node_index_.insert(*id, index)) return c_.error_at(line, "node " + std::to_string(*id) + " is defined twice");
    mesh().positions.push_back(p);
    mesh().node_ids.push_back(*id);
    if (set) set->push_back(index);
    return {};
  }

  Result<void> read_tet(const std::vector<std::string_view>& f, std::int64_t line, TetKind kind,
                        std::vector<Index>* set) {
    SHATTER_TRY(id, id_field(f[0], line, "element number"));
    if (raw_tets_.size() >= static_cast<std::size_t>(io::kMaxEntities)) return c_.error_at(line, "too many elements");
    const auto index = static_cast<Index>(raw_tets_.size());
    if (!tet_index_.insert(*id, index) || skipped_ids_.count(*id))
      return c_.error_at(line, "element " + std::to_string(*id) + " is defined twice");
    std::array<FileId, 10> nodes{};
    for (std::size_t k = 1; k < f.size(); ++k) {
      SHATTER_TRY(v, id_field(f[k], line, "node number"));
      nodes[k - 1] = *v;
    }
    raw_tets_.push_back({nodes, line, kind == TetKind::quadratic});
    mesh().tet_ids.push_back(*id);
    if (set) set->push_back(index);
    return {};
  }

  Result<MeshReadResult> finish() {
    TetMesh& m = mesh();
    if (m.positions.empty()) return c_.error("no *NODE data in the file");
    if (raw_tets_.empty()) {
      std::string what = "no C3D4 or C3D10 elements in the file";
      if (!skipped_elements_.empty()) what += " (found only other element types)";
      return c_.error(what);
    }
    // Element node numbers -> indices.
    const std::size_t n = m.positions.size();
    std::vector<bool> corner(n, false), midside(n, false);
    bool any_quadratic = false;
    m.tets.reserve(raw_tets_.size());
    for (std::size_t e = 0; e < raw_tets_.size(); ++e) {
      const RawTet& r = raw_tets_[e];
      TetIndices t{};
      const int count = r.quadratic ? 10 : 4;
      for (int k = 0; k < count; ++k) {
        const auto idx = node_index_.find(r.nodes[k]);
        if (!idx)
          return c_.error_at(r.line, "element " + std::to_string(m.tet_ids[e]) + " uses node " +
                                         std::to_string(r.nodes[k]) + ", which is not defined");
        if (k < 4) {
          t[k] = *idx;
          corner[*idx] = true;
        } else {
          midside[*idx] = true;
        }
      }
      any_quadratic |= r.quadratic;
      m.tets.push_back(t);
    }
    // Sets, in file order (a set may name earlier sets). Each set is kept free of repeats after its
    // block, so no set outgrows the nodes or elements defined; and all the members added together
    // are bounded, so a short file of sets that each name the previous one many times cannot ask
    // for unbounded time or memory.
    const std::uint64_t max_set_entries =
        kSetEntriesPerItem * (static_cast<std::uint64_t>(n) + raw_tets_.size() + skipped_ids_.size()) + kSetEntriesMin;
    for (const SetBlock& s : sets_) {
      std::vector<Index>& target = s.nodes ? node_set(s.name) : tet_set(s.name);
      const IdLookup lookup = s.nodes ? IdLookup{&node_index_, nullptr} : IdLookup{&tet_index_, &skipped_ids_};
      const std::size_t defined = s.nodes ? n : raw_tets_.size() + skipped_ids_.size();
      auto count_entries = [&](std::uint64_t added, std::int64_t line) -> Result<void> {
        set_entries_ += added;
        if (set_entries_ > max_set_entries)
          return c_.error_at(line, "*NSET / *ELSET lists add up to more than " + std::to_string(max_set_entries) +
                                       " members (" + std::to_string(kSetEntriesPerItem) +
                                       " per node and element defined): sets naming sets too many times");
        return {};
      };
      for (const SetBlock::Item& item : s.items) {
        if (s.generate) {
          if (item.fields.size() < 2 || item.fields.size() > 3)
            return c_.error_at(item.line, "expected 'first, last[, increment]' after GENERATE");
          SHATTER_TRY(first, id_field(item.fields[0], item.line, "first id"));
          SHATTER_TRY(last, id_field(item.fields[1], item.line, "last id"));
          std::int64_t inc = 1;
          if (item.fields.size() == 3) {
            SHATTER_TRY(i, id_field(item.fields[2], item.line, "increment"));
            inc = *i;
          }
          if (inc <= 0 || *last < *first)
            return c_.error_at(item.line, "expected first <= last and increment > 0 after GENERATE");
          const std::uint64_t count = (static_cast<std::uint64_t>(*last) - static_cast<std::uint64_t>(*first)) /
                                          static_cast<std::uint64_t>(inc) +
                                      1;
          if (count > defined)
            return c_.error_at(item.line, "GENERATE range of " + std::to_string(count) + " ids is larger than the " +
                                              std::to_string(defined) + (s.nodes ? " nodes" : " elements") +
                                              " defined");
          SHATTER_TRY(counted, count_entries(count, item.line));
          for (std::uint64_t k = 0; k < count; ++k) {
            SHATTER_TRY(ok, add_id(target, lookup, *first + static_cast<std::int64_t>(k) * inc, item.line, s.nodes));
          }
          continue;
        }
        for (std::string_view f : item.fields) {
          if (f.empty()) continue;
          std::int64_t id = 0;
          if (io::parse_int(f, id)) {
            SHATTER_TRY(counted, count_entries(1, item.line));
            SHATTER_TRY(ok, add_id(target, lookup, id, item.line, s.nodes));
            continue;
          }
          // A set name: its members join this set.
          std::map<std::string, std::string>& names = s.nodes ? node_names_ : tet_names_;
          const auto it = names.find(to_upper(f));
          if (it == names.end())
            return c_.error_at(item.line, std::string("expected a ") + (s.nodes ? "node" : "element") +
                                              " number or set name, found " + io::quote_token(f));
          const std::vector<Index>& other = s.nodes ? m.node_sets[it->second] : m.tet_sets[it->second];
          if (&other != &target) {
            SHATTER_TRY(counted, count_entries(other.size(), item.line));
            const std::vector<Index> copy = other;
            target.insert(target.end(), copy.begin(), copy.end());
          }
        }
      }
      std::sort(target.begin(), target.end());
      target.erase(std::unique(target.begin(), target.end()), target.end());
    }
    for (auto* sets : {&m.node_sets, &m.tet_sets})
      for (auto& [name, v] : *sets) {
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end()), v.end());
      }
    if (any_quadratic) {
      const std::size_t dropped = io::remove_midside_nodes(m, corner, midside);
      result_.skipped.push_back("C3D10 elements read by their 4 corner nodes (" + std::to_string(dropped) +
                                " mid-edge nodes dropped)");
    }
    for (const auto& [type, count] : skipped_elements_)
      result_.skipped.push_back(std::to_string(count) + " elements of type " + type);
    for (const auto& [kw, count] : skipped_keywords_)
      result_.skipped.push_back(kw + (count > 1 ? " (" + std::to_string(count) + " times)" : std::string()));
    if (skipped_set_members_ > 0)
      result_.skipped.push_back(std::to_string(skipped_set_members_) + " element set members that are not tetrahedra");
    io::drop_default_ids(m.node_ids);
    io::drop_default_ids(m.tet_ids);
    result_.format = "inp";
    return std::move(result_);
  }

  struct IdLookup {
    const io::IdIndex* index;
    const std::unordered_set<FileId>* skipped;
  };
  Result<void> add_id(std::vector<Index>& target, const IdLookup& lookup, FileId id, std::int64_t line, bool nodes) {
    if (const auto idx = lookup.index->find(id)) {
      target.push_back(*idx);
      return {};
    }
    if (lookup.skipped && lookup.skipped->count(id)) {
      ++skipped_set_members_;
      return {};
    }
    return c_.error_at(line, std::string(nodes ? "node " : "element ") + std::to_string(id) + " is not defined");
  }

  struct RawTet {
    std::array<FileId, 10> nodes;
    std::int64_t line;
    bool quadratic;
  };

  TextCursor c_;
  std::string name_;
  MeshReadResult result_;
  io::IdIndex node_index_, tet_index_;
  std::unordered_set<FileId> skipped_ids_;
  std::vector<RawTet> raw_tets_;
  std::vector<SetBlock> sets_;
  std::map<std::string, std::string> node_names_, tet_names_;
  std::map<std::string, std::size_t> skipped_elements_, skipped_keywords_;
  std::size_t skipped_set_members_ = 0;
  std::uint64_t set_entries_ = 0;  ///< members added to sets so far (ids, GENERATE ranges, named sets)
  /// Bound on set_entries_: this many per node and element defined, plus a floor for small meshes.
  static constexpr std::uint64_t kSetEntriesPerItem = 64;
  static constexpr std::uint64_t kSetEntriesMin = 1'000'000;
};

Result<void> check_set_name(const std::string& name) {
  if (name.empty()) return make_error("inp: empty set name");
  for (char ch : name)
    if (static_cast<unsigned char>(ch) < 32 || ch == ',' || ch == '=' || ch == '*' || ch == '"' || ch == 127)
      return make_error("inp: set name " + io::quote_token(name) +
                        " cannot be written (no , = * \" or control characters)");
  return {};
}

void write_id_list(std::string& s, const std::vector<Index>& set, const auto& id_of) {
  for (std::size_t k = 0; k < set.size(); ++k) {
    io::append_int(s, id_of(set[k]));
    s += (k + 1 == set.size() || k % 16 == 15) ? "\n" : ", ";
  }
}

std::string set_name_text(const std::string& name) {
  return name.find(' ') != std::string::npos ? "\"" + name + "\"" : name;
}

}  // namespace

Result<MeshReadResult> parse_inp(std::string_view bytes, const std::string& name) {
  return InpReader(bytes, name).read();
}

Result<void> write_inp(std::ostream& out, const TetMesh& mesh) {
  for (const auto* sets : {&mesh.node_sets, &mesh.tet_sets})
    for (const auto& [name, v] : *sets) {
      SHATTER_TRY(ok, check_set_name(name));
    }
  // Abaqus and CalculiX numbers are > 0. Ids that are not all positive (TetGen's and MEDIT's may
  // start at 0) cannot be kept: the nodes or elements are then numbered 1..n, with a warning.
  bool node_ids_kept = true, tet_ids_kept = true;
  for (Index i = 0; i < mesh.num_nodes() && node_ids_kept; ++i) node_ids_kept = mesh.node_id(i) > 0;
  for (Index e = 0; e < mesh.num_tets() && tet_ids_kept; ++e) tet_ids_kept = mesh.tet_id(e) > 0;
  if (!node_ids_kept) log_warning("write_inp: node ids are not all positive; node numbers written as 1..n");
  if (!tet_ids_kept) log_warning("write_inp: tet ids are not all positive; element numbers written as 1..n");
  auto node_number = [&](Index i) { return node_ids_kept ? mesh.node_id(i) : FileId{i} + 1; };
  auto tet_number = [&](Index e) { return tet_ids_kept ? mesh.tet_id(e) : FileId{e} + 1; };
  io::WriteBuffer buffer(out);
  std::string& s = buffer.text();
  s = "*NODE\n";
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    io::append_int(s, node_number(i));
    for (int k = 0; k < 3; ++k) {
      s += ", ";
      io::append_double(s, mesh.positions[i][k]);
    }
    s += '\n';
    buffer.maybe_flush();
  }
  s += "*ELEMENT, TYPE=C3D4\n";
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    io::append_int(s, tet_number(e));
    for (int k = 0; k < 4; ++k) {
      s += ", ";
      io::append_int(s, node_number(mesh.tets[e][k]));
    }
    s += '\n';
    buffer.maybe_flush();
  }
  for (const auto& [name, set] : mesh.node_sets) {
    s += "*NSET, NSET=" + set_name_text(name) + "\n";
    write_id_list(s, set, [&](Index i) { return node_number(i); });
  }
  for (const auto& [name, set] : mesh.tet_sets) {
    s += "*ELSET, ELSET=" + set_name_text(name) + "\n";
    write_id_list(s, set, [&](Index e) { return tet_number(e); });
  }
  buffer.flush();
  return {};
}

}  // namespace shatter
