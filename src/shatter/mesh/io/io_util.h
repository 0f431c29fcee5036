// Helpers shared by the mesh and surface readers/writers: file-id lookup, shortest round-trip
// number text, line splitting, and removal of nodes that only quadratic elements used.
#pragma once

#include <charconv>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "shatter/core/types.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter::io {

/// Largest entity count a mesh can hold (Index is 32-bit).
inline constexpr std::int64_t kMaxEntities = std::numeric_limits<Index>::max();

/// File id -> index. Ids may be sparse and in any order; duplicates are rejected by insert().
class IdIndex {
 public:
  void reserve(std::size_t n) { map_.reserve(n); }
  /// False if `id` is already present.
  bool insert(FileId id, Index index) { return map_.emplace(id, index).second; }
  [[nodiscard]] std::optional<Index> find(FileId id) const {
    const auto it = map_.find(id);
    if (it == map_.end()) return std::nullopt;
    return it->second;
  }
  [[nodiscard]] std::size_t size() const { return map_.size(); }

 private:
  std::unordered_map<FileId, Index> map_;
};

/// Clear `ids` when it is exactly 1, 2, ..., n (the default numbering of TetMesh).
void drop_default_ids(std::vector<FileId>& ids);
/// Clear `tags` when every entry is zero.
void drop_zero_tags(std::vector<std::int32_t>& tags);

/// Shortest text that reads back to the same double (std::to_chars), appended to `out`.
void append_double(std::string& out, double v);
void append_int(std::string& out, std::int64_t v);

/// Remove the nodes flagged in `drop` (#nodes); tets, ids, tags and node sets are renumbered.
/// Every dropped node must be unused by the tets.
void remove_nodes(TetMesh& mesh, const std::vector<bool>& drop);
/// Quadratic tets read by their corners: remove the nodes used only as mid-edge nodes
/// (midside[i] && !corner[i]). Returns how many were removed.
std::size_t remove_midside_nodes(TetMesh& mesh, const std::vector<bool>& corner, const std::vector<bool>& midside);

/// Split `line` at `sep`, trimming blanks (spaces, tabs, CR) around each field.
std::vector<std::string_view> split_fields(std::string_view line, char sep);
/// Trim blanks (spaces, tabs, CR) at both ends.
std::string_view trim(std::string_view s);
/// Case-insensitive ASCII comparison.
bool iequals(std::string_view a, std::string_view b);

}  // namespace shatter::io
