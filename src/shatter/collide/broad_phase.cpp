// Uniform-grid broad phase (see broad_phase.h).
#include "shatter/collide/broad_phase.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace shatter {
namespace {

using Cell = std::array<std::int64_t, 3>;

// Cell coordinates of p. Monotone in p (subtraction and division by h > 0 are), so the cell of a
// point inside a box lies within the box's cell range.
Cell cell_of(const Vec3& p, const Vec3& origin, double h) {
  return {static_cast<std::int64_t>(std::floor((p.x() - origin.x()) / h)),
          static_cast<std::int64_t>(std::floor((p.y() - origin.y()) / h)),
          static_cast<std::int64_t>(std::floor((p.z() - origin.z()) / h))};
}

std::uint64_t cell_hash(const Cell& c) {
  // Large odd multipliers (Teschner et al. 2003 use primes the same way), mixed by a final shift.
  std::uint64_t h = static_cast<std::uint64_t>(c[0]) * 0x9E3779B97F4A7C15ULL;
  h ^= static_cast<std::uint64_t>(c[1]) * 0xC2B2AE3D27D4EB4FULL;
  h ^= static_cast<std::uint64_t>(c[2]) * 0x165667B19E3779F9ULL;
  return h ^ (h >> 29);
}

double median_extent(const std::vector<Aabb>& boxes) {
  std::vector<double> e;
  for (const Aabb& b : boxes)
    if (valid_box(b)) e.push_back(b.extent().maxCoeff());
  if (e.empty()) return 0;
  const auto mid = e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2);
  std::nth_element(e.begin(), mid, e.end());
  return *mid;
}

}  // namespace

bool valid_box(const Aabb& b) { return !b.empty() && b.min.allFinite() && b.max.allFinite(); }

const std::vector<BodyPair>& BroadPhase::find_pairs(const std::vector<Aabb>& boxes, const BroadPhaseOptions& options) {
  stats_ = {};
  pairs_.clear();
  entries_.clear();
  large_.clear();
  const auto n = static_cast<Index>(boxes.size());
  Aabb scene;
  for (const Aabb& b : boxes)
    if (valid_box(b)) {
      scene.extend(b.min);
      scene.extend(b.max);
    }
  if (scene.empty()) return pairs_;
  // Cell size: given, else the median largest extent; never so small that the scene spans more
  // than 2^20 cells along an axis (points and slivers), never zero.
  double h = options.cell_size > 0 ? options.cell_size : median_extent(boxes);
  const double span = scene.extent().maxCoeff();
  h = std::max(h, span * std::ldexp(1.0, -20));
  if (!(h > 0)) h = 1.0;
  stats_.cell_size = h;

  // Entries (box, cell) in body order; boxes over too many cells go to the large list.
  is_large_.assign(boxes.size(), 0);
  for (Index i = 0; i < n; ++i) {
    const Aabb& b = boxes[static_cast<std::size_t>(i)];
    if (!valid_box(b)) continue;
    const Cell lo = cell_of(b.min, scene.min, h), hi = cell_of(b.max, scene.min, h);
    const double cells = static_cast<double>(hi[0] - lo[0] + 1) * static_cast<double>(hi[1] - lo[1] + 1) *
                         static_cast<double>(hi[2] - lo[2] + 1);
    if (cells > static_cast<double>(options.max_cells_per_box)) {
      large_.push_back(i);
      is_large_[static_cast<std::size_t>(i)] = 1;
      continue;
    }
    for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
          entries_.push_back(
              {{static_cast<std::int32_t>(x), static_cast<std::int32_t>(y), static_cast<std::int32_t>(z)}, i});
  }
  stats_.entries = static_cast<std::int64_t>(entries_.size());
  stats_.large_boxes = static_cast<std::int64_t>(large_.size());

  // Counting sort by hash bucket (stable: within a bucket, entries keep body order).
  std::size_t table = 1;
  while (table < 2 * entries_.size()) table *= 2;
  start_.assign(table + 1, 0);
  bucket_.resize(entries_.size());
  for (std::size_t k = 0; k < entries_.size(); ++k) {
    const auto& cell = entries_[k].cell;
    bucket_[k] = static_cast<std::uint32_t>(cell_hash({cell[0], cell[1], cell[2]}) & (table - 1));
    ++start_[bucket_[k] + 1];
  }
  for (std::size_t b = 0; b < table; ++b) start_[b + 1] += start_[b];
  sorted_.resize(entries_.size());
  for (std::size_t k = 0; k < entries_.size(); ++k) sorted_[start_[bucket_[k]]++] = entries_[k];
  // start_[b] now holds the end of bucket b, which is the start of bucket b + 1: shift back.
  for (std::size_t b = table; b > 0; --b) start_[b] = start_[b - 1];
  start_[0] = 0;

  // Pairs within each bucket that share a cell, reported from the cell of their overlap's lowest
  // corner only.
  for (std::size_t b = 0; b < table; ++b) {
    for (std::size_t p = start_[b]; p < start_[b + 1]; ++p) {
      const Entry& e = sorted_[p];
      for (std::size_t q = p + 1; q < start_[b + 1]; ++q) {
        const Entry& f = sorted_[q];
        if (f.cell != e.cell || f.body == e.body) continue;
        const Aabb& a = boxes[static_cast<std::size_t>(e.body)];
        const Aabb& c = boxes[static_cast<std::size_t>(f.body)];
        ++stats_.box_tests;
        if (!boxes_overlap(a, c)) continue;
        const Cell corner = cell_of(a.min.cwiseMax(c.min), scene.min, h);
        if (corner[0] != e.cell[0] || corner[1] != e.cell[1] || corner[2] != e.cell[2]) continue;
        pairs_.emplace_back(std::min(e.body, f.body), std::max(e.body, f.body));
      }
    }
  }
  // Large boxes against every other box (a pair of large boxes once).
  for (Index i : large_) {
    for (Index j = 0; j < n; ++j) {
      if (j == i || !valid_box(boxes[static_cast<std::size_t>(j)])) continue;
      if (is_large_[static_cast<std::size_t>(j)] && j < i) continue;
      ++stats_.box_tests;
      if (boxes_overlap(boxes[static_cast<std::size_t>(i)], boxes[static_cast<std::size_t>(j)]))
        pairs_.emplace_back(std::min(i, j), std::max(i, j));
    }
  }
  std::sort(pairs_.begin(), pairs_.end());
  return pairs_;
}

std::vector<BodyPair> find_overlapping_pairs(const std::vector<Aabb>& boxes, const BroadPhaseOptions& options,
                                             BroadPhaseStats* stats) {
  BroadPhase grid;
  std::vector<BodyPair> pairs = grid.find_pairs(boxes, options);
  if (stats) *stats = grid.stats();
  return pairs;
}

std::vector<BodyPair> find_overlapping_pairs_brute_force(const std::vector<Aabb>& boxes) {
  std::vector<BodyPair> pairs;
  const auto n = static_cast<Index>(boxes.size());
  for (Index i = 0; i < n; ++i) {
    if (!valid_box(boxes[static_cast<std::size_t>(i)])) continue;
    for (Index j = i + 1; j < n; ++j)
      if (valid_box(boxes[static_cast<std::size_t>(j)]) &&
          boxes_overlap(boxes[static_cast<std::size_t>(i)], boxes[static_cast<std::size_t>(j)]))
        pairs.emplace_back(i, j);
  }
  return pairs;
}

}  // namespace shatter
