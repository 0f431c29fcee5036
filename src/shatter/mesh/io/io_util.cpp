// Helpers shared by the mesh and surface readers/writers (see io_util.h).
#include "shatter/mesh/io/io_util.h"

#include <algorithm>

namespace shatter::io {

void drop_default_ids(std::vector<FileId>& ids) {
  for (std::size_t i = 0; i < ids.size(); ++i)
    if (ids[i] != static_cast<FileId>(i) + 1) return;
  ids.clear();
}

void drop_zero_tags(std::vector<std::int32_t>& tags) {
  if (std::all_of(tags.begin(), tags.end(), [](std::int32_t t) { return t == 0; })) tags.clear();
}

void append_double(std::string& out, double v) {
  if (v == 0.0) v = 0.0;  // write -0 as 0
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void append_int(std::string& out, std::int64_t v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void remove_nodes(TetMesh& mesh, const std::vector<bool>& drop) {
  const Index n = mesh.num_nodes();
  std::vector<Index> new_index(static_cast<std::size_t>(n), -1);
  Index next = 0;
  for (Index i = 0; i < n; ++i)
    if (!drop[i]) new_index[i] = next++;
  if (next == n) return;
  auto compact = [&](auto& v) {
    if (v.empty()) return;
    Index k = 0;
    for (Index i = 0; i < n; ++i)
      if (!drop[i]) v[k++] = v[i];
    v.resize(static_cast<std::size_t>(k));
  };
  compact(mesh.positions);
  compact(mesh.node_ids);
  compact(mesh.node_tags);
  for (TetIndices& t : mesh.tets)
    for (Index& v : t) v = new_index[v];
  for (auto& [name, set] : mesh.node_sets) {
    std::vector<Index> kept;
    for (Index i : set)
      if (new_index[i] >= 0) kept.push_back(new_index[i]);
    set = std::move(kept);
  }
}

std::string_view trim(std::string_view s) {
  auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_fields(std::string_view line, char sep) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t p = line.find(sep, start);
    if (p == std::string_view::npos) {
      fields.push_back(trim(line.substr(start)));
      break;
    }
    fields.push_back(trim(line.substr(start, p - start)));
    start = p + 1;
  }
  return fields;
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

std::size_t remove_midside_nodes(TetMesh& mesh, const std::vector<bool>& corner, const std::vector<bool>& midside) {
  std::vector<bool> drop(corner.size(), false);
  std::size_t dropped = 0;
  for (std::size_t i = 0; i < drop.size(); ++i)
    if (midside[i] && !corner[i]) {
      drop[i] = true;
      ++dropped;
    }
  remove_nodes(mesh, drop);
  return dropped;
}

}  // namespace shatter::io
