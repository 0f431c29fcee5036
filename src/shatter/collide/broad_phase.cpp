// Uniform-grid broad phase (see broad_phase.h).
#include "shatter/collide/broad_phase.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace shatter {
namespace {

using Cell = std::array<std::int64_t, 3>;

struct Entry {
  Cell cell;
  Index body = -1;
};

bool valid_box(const Aabb& b) { return !b.empty() && b.min.allFinite() && b.max.allFinite(); }

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

bool boxes_overlap(const Aabb& a, const Aabb& b) {
  return (a.min.array() <= b.max.array()).all() && (b.min.array() <= a.max.array()).all();
}

std::vector<std::pair<Index, Index>> find_overlapping_pairs(const std::vector<Aabb>& boxes,
                                                            const BroadPhaseOptions& options, BroadPhaseStats* stats) {
  BroadPhaseStats st;
  std::vector<std::pair<Index, Index>> pairs;
  const auto n = static_cast<Index>(boxes.size());
  Aabb scene;
  for (const Aabb& b : boxes)
    if (valid_box(b)) {
      scene.extend(b.min);
      scene.extend(b.max);
    }
  if (scene.empty()) {
    if (stats) *stats = st;
    return pairs;
  }
  // Cell size: given, else the median largest extent; never so small that the scene spans more
  // than 2^20 cells along an axis (points and slivers), never zero.
  double h = options.cell_size > 0 ? options.cell_size : median_extent(boxes);
  const double span = scene.extent().maxCoeff();
  h = std::max(h, span * std::ldexp(1.0, -20));
  if (!(h > 0)) h = 1.0;
  st.cell_size = h;

  // Entries (box, cell) in body order; boxes over too many cells go to the large list.
  std::vector<Entry> entries;
  std::vector<Index> large;
  std::vector<char> is_large(boxes.size(), 0);
  for (Index i = 0; i < n; ++i) {
    const Aabb& b = boxes[static_cast<std::size_t>(i)];
    if (!valid_box(b)) continue;
    const Cell lo = cell_of(b.min, scene.min, h), hi = cell_of(b.max, scene.min, h);
    const double cells = static_cast<double>(hi[0] - lo[0] + 1) * static_cast<double>(hi[1] - lo[1] + 1) *
                         static_cast<double>(hi[2] - lo[2] + 1);
    if (cells > static_cast<double>(options.max_cells_per_box)) {
      large.push_back(i);
      is_large[static_cast<std::size_t>(i)] = 1;
      continue;
    }
    for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t x = lo[0]; x <= hi[0]; ++x) entries.push_back({{x, y, z}, i});
  }
  st.entries = static_cast<std::int64_t>(entries.size());
  st.large_boxes = static_cast<std::int64_t>(large.size());

  // Counting sort by hash bucket (stable: within a bucket, entries keep body order).
  std::size_t table = 1;
  while (table < 2 * entries.size()) table *= 2;
  std::vector<std::size_t> start(table + 1, 0);
  std::vector<std::size_t> bucket(entries.size());
  for (std::size_t k = 0; k < entries.size(); ++k) {
    bucket[k] = static_cast<std::size_t>(cell_hash(entries[k].cell) & (table - 1));
    ++start[bucket[k] + 1];
  }
  for (std::size_t b = 0; b < table; ++b) start[b + 1] += start[b];
  std::vector<Entry> sorted(entries.size());
  {
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t k = 0; k < entries.size(); ++k) sorted[fill[bucket[k]]++] = entries[k];
  }

  // Pairs within each bucket that share a cell, reported from the cell of their overlap's lowest
  // corner only.
  for (std::size_t b = 0; b < table; ++b) {
    for (std::size_t p = start[b]; p < start[b + 1]; ++p) {
      const Entry& e = sorted[p];
      for (std::size_t q = p + 1; q < start[b + 1]; ++q) {
        const Entry& f = sorted[q];
        if (f.cell != e.cell || f.body == e.body) continue;
        const Aabb& a = boxes[static_cast<std::size_t>(e.body)];
        const Aabb& c = boxes[static_cast<std::size_t>(f.body)];
        ++st.box_tests;
        if (!boxes_overlap(a, c)) continue;
        if (cell_of(a.min.cwiseMax(c.min), scene.min, h) != e.cell) continue;
        pairs.emplace_back(std::min(e.body, f.body), std::max(e.body, f.body));
      }
    }
  }
  // Large boxes against every other box (a pair of large boxes once).
  for (Index i : large) {
    for (Index j = 0; j < n; ++j) {
      if (j == i || !valid_box(boxes[static_cast<std::size_t>(j)])) continue;
      if (is_large[static_cast<std::size_t>(j)] && j < i) continue;
      ++st.box_tests;
      if (boxes_overlap(boxes[static_cast<std::size_t>(i)], boxes[static_cast<std::size_t>(j)]))
        pairs.emplace_back(std::min(i, j), std::max(i, j));
    }
  }
  std::sort(pairs.begin(), pairs.end());
  if (stats) *stats = st;
  return pairs;
}

std::vector<std::pair<Index, Index>> find_overlapping_pairs_brute_force(const std::vector<Aabb>& boxes) {
  std::vector<std::pair<Index, Index>> pairs;
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
