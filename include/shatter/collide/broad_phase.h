// Broad phase (docs/method.md §2.8): the pairs of bodies whose bounding boxes overlap, found with a
// uniform grid as the paper does. Each box is entered in every grid cell it overlaps; the entries
// are bucketed by a hash of their cell with a counting sort (stable, so the order is fixed by the
// body order alone), and two boxes sharing a cell are reported only from the cell that holds the
// lowest corner of their overlap, so every pair comes once without a set. Boxes that would cover
// more than max_cells_per_box cells (a ground slab, a wall) are kept out of the grid and tested
// against every box. Pairs come sorted (i < j, lexicographic): the same on any thread count and
// for any hash table size.
#pragma once

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "shatter/core/types.h"

namespace shatter {

/// Settings of the grid.
struct BroadPhaseOptions {
  /// Cell edge, m. 0: from the boxes, the median of their largest extents (the paper sizes cells by
  /// the objects), so a typical box covers a few cells.
  double cell_size = 0;
  /// A box that would cover more cells than this is tested against all boxes instead.
  std::int64_t max_cells_per_box = 64;
};

/// What one query did (for benchmarks and tests).
struct BroadPhaseStats {
  double cell_size = 0;          ///< cell edge used, m
  std::int64_t entries = 0;      ///< (box, cell) entries in the grid
  std::int64_t large_boxes = 0;  ///< boxes kept out of the grid
  std::int64_t box_tests = 0;    ///< box-box overlap tests made
};

/// A box the grid takes in: not empty, with finite corners (the others are skipped).
bool valid_box(const Aabb& b);

/// Two boxes overlap (closed intervals: touching counts). Inline: the tet-contact traversal calls
/// it per BVH node.
inline bool boxes_overlap(const Aabb& a, const Aabb& b) {
  return (a.min.array() <= b.max.array()).all() && (b.min.array() <= a.max.array()).all();
}

/// A pair of body indices, first < second.
using BodyPair = std::pair<Index, Index>;

/// The grid with its buffers kept between queries (a step's query then allocates nothing once the
/// buffers have grown to the scene).
class BroadPhase {
 public:
  /// Pairs (i, j), i < j, of overlapping non-empty boxes, sorted. `boxes`: one per body
  /// (#bodies); empty or non-finite boxes take part in no pair. Valid until the next call.
  const std::vector<BodyPair>& find_pairs(const std::vector<Aabb>& boxes, const BroadPhaseOptions& options = {});
  /// What the last query did.
  [[nodiscard]] const BroadPhaseStats& stats() const { return stats_; }

 private:
  /// One (box, cell) entry: cell coordinates (|c| < 2^21 by the cell-size floor) and the body.
  struct Entry {
    std::array<std::int32_t, 3> cell;
    Index body;
  };
  std::vector<Entry> entries_, sorted_;
  std::vector<std::uint32_t> bucket_;  ///< hash bucket of each entry (#entries)
  std::vector<std::uint32_t> start_;   ///< first sorted entry of each bucket (#buckets + 1)
  std::vector<Index> large_;           ///< boxes kept out of the grid
  std::vector<char> is_large_;         ///< per box (#bodies)
  std::vector<BodyPair> pairs_;
  BroadPhaseStats stats_;
};

/// One query with a grid of its own (see BroadPhase::find_pairs).
std::vector<BodyPair> find_overlapping_pairs(const std::vector<Aabb>& boxes, const BroadPhaseOptions& options = {},
                                             BroadPhaseStats* stats = nullptr);

/// The same by testing every pair (for tests and tiny scenes).
std::vector<BodyPair> find_overlapping_pairs_brute_force(const std::vector<Aabb>& boxes);

}  // namespace shatter
