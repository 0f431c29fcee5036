// Convex decomposition by region growing over face-connected tets, then merging (see
// convex_decomposition.h).
//  1. Growing: from the lowest-index tet not yet in a piece, add face neighbours. Tets whose nodes
//     are all inside the current hull come first (they fill it; the hull does not change). Else the
//     neighbour nearest the seed is tried: the hull with its nodes is kept when it over-fills the
//     piece's tets, plus the unassigned tets whose centres it already encloses (the material the
//     piece takes in next), by no more than max_overfill. Without counting that material a convex
//     body could not be grown tet by tet: a small cluster's jagged front over-fills its hull.
//     Candidates refused wait and are tried again whenever the hull grows. Hulls are rebuilt from
//     the old hull's vertices and the new nodes only.
//  2. Merging: adjacent pieces are joined while the merged over-fill is no more than the larger
//     of max_overfill and the two pieces' own (least excess first), which also absorbs the small
//     leftovers of growth. Then, while there are more than max_pieces, the least over-filling
//     pairs are joined regardless.
#include "shatter/collide/convex_decomposition.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <tuple>

namespace shatter {
namespace {

struct Cluster {
  ConvexHull hull;
  std::vector<Index> tets;
  double volume = 0;  // tet volume, m^3
  Index version = 0;  // bumped on every change (stale queue entries)
  bool alive = true;
};

bool inside(const ConvexHull& hull, const Vec3& p) {
  for (const HullFace& f : hull.faces)
    if (f.normal.dot(p) - f.offset > hull.tolerance) return false;
  return true;
}

Result<ConvexHull> hull_with(const ConvexHull& hull, std::span<const Vec3> extra, std::vector<Vec3>& scratch) {
  scratch.assign(hull.vertices.begin(), hull.vertices.end());
  scratch.insert(scratch.end(), extra.begin(), extra.end());
  return build_convex_hull(scratch);
}

Error piece_error(const Error& e, Index seed) {
  return make_error("convex decomposition: the piece grown from tet " + std::to_string(seed) +
                    " spans no volume (degenerate tets): " + e.message);
}

class Decomposer {
 public:
  Decomposer(const TetMesh& mesh, const TetFaces& faces, const DecompositionOptions& options)
      : mesh_(mesh), faces_(faces), options_(options) {}

  Result<std::vector<ConvexPiece>> run() {
    const Index n = mesh_.num_tets();
    volume_.resize(static_cast<std::size_t>(n));
    centroid_.resize(static_cast<std::size_t>(n));
    for (Index e = 0; e < n; ++e) {
      volume_[e] = std::abs(signed_volume(mesh_, e));
      centroid_[e] = mesh_.corners(e).rowwise().mean();
    }
    mark_.assign(static_cast<std::size_t>(n), 0);
    checked_.assign(static_cast<std::size_t>(n), 0);
    piece_of_.assign(static_cast<std::size_t>(n), -1);
    tried_.assign(static_cast<std::size_t>(n), -1);
    for (Index seed = 0; seed < n; ++seed) {
      if (piece_of_[seed] >= 0) continue;
      SHATTER_TRY(grown, grow(seed));
    }
    SHATTER_TRY(merged, merge());
    // Pieces in order of their lowest tet, tets sorted.
    std::vector<ConvexPiece> pieces;
    for (Cluster& c : clusters_) {
      if (!c.alive) continue;
      std::sort(c.tets.begin(), c.tets.end());
      pieces.push_back({std::move(c.hull), std::move(c.tets), c.volume});
    }
    std::sort(pieces.begin(), pieces.end(),
              [](const ConvexPiece& a, const ConvexPiece& b) { return a.tets.front() < b.tets.front(); });
    return pieces;
  }

 private:
  // Over-fill of a hull over tets of `volume`.
  static double overfill(const ConvexHull& hull, double volume) { return (hull.volume - volume) / volume; }

  // Volume of the unassigned tets whose centroids lie inside `hull`, reached from the frontier
  // and from e through such tets, m^3: the material a growing cluster will take in next.
  double fill_volume(const ConvexHull& hull, Index e) {
    ++stamp_;
    double volume = 0;
    queue_tets_.clear();
    const auto visit = [&](Index t) {
      if (t < 0 || piece_of_[t] >= 0 || t == e || mark_[t] == stamp_) return;
      mark_[t] = stamp_;
      if (!inside(hull, centroid_[t])) return;
      volume += volume_[t];
      queue_tets_.push_back(t);
    };
    for (Index t : frontier_) visit(t);
    for (int k = 0; k < 4; ++k) visit(faces_.neighbor(e, k));
    for (std::size_t q = 0; q < queue_tets_.size(); ++q)  // NOLINT(modernize-loop-convert): grows while visited
      for (int k = 0; k < 4; ++k) visit(faces_.neighbor(queue_tets_[q], k));
    return volume;
  }

  std::array<Vec3, 4> nodes(Index e) const {
    const TetIndices& t = mesh_.tets[e];
    return {mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]], mesh_.positions[t[3]]};
  }

  Result<void> grow(Index seed) {
    const auto id = static_cast<Index>(clusters_.size());
    const std::array<Vec3, 4> seed_nodes = nodes(seed);
    auto hull = build_convex_hull(seed_nodes);
    if (!hull.ok()) return piece_error(hull.error(), seed);
    Cluster c;
    c.hull = std::move(*hull);
    c.tets = {seed};
    c.volume = volume_[seed];
    piece_of_[seed] = id;
    frontier_.clear();
    add_neighbours(seed, id);
    const Vec3 origin = centroid_[seed];
    // Candidates the hull could not take yet; they get another try whenever the hull grows. The
    // number of hull builds per piece is capped (the rest go to later pieces).
    deferred_.clear();
    Index builds = 0;
    std::int64_t hull_version = ++hull_versions_;
    const Index max_builds = 16 + 4 * mesh_.num_tets();
    while (!frontier_.empty()) {
      // A frontier tet inside the hull (the first in frontier order), else the one nearest the seed.
      // (checked_[t] == hull_version: t was found not inside this hull already.)
      std::size_t pick = frontier_.size();
      for (std::size_t k = 0; k < frontier_.size() && pick == frontier_.size(); ++k) {
        const Index t = frontier_[k];
        if (checked_[t] == hull_version) continue;
        const std::array<Vec3, 4> x = nodes(t);
        if (inside(c.hull, x[0]) && inside(c.hull, x[1]) && inside(c.hull, x[2]) && inside(c.hull, x[3]))
          pick = k;
        else
          checked_[t] = hull_version;
      }
      const bool free = pick < frontier_.size();
      if (!free) {
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < frontier_.size(); ++k) {
          const double d = (centroid_[frontier_[k]] - origin).squaredNorm();
          if (d < best) best = d, pick = k;
        }
      }
      const Index e = frontier_[pick];
      frontier_.erase(frontier_.begin() + static_cast<std::ptrdiff_t>(pick));
      if (!free) {
        if (builds >= max_builds) continue;
        ++builds;
        const std::array<Vec3, 4> x = nodes(e);
        auto grown = hull_with(c.hull, x, scratch_);
        if (!grown.ok() || overfill(*grown, c.volume + volume_[e] + fill_volume(*grown, e)) > options_.max_overfill) {
          deferred_.push_back(e);
          continue;
        }
        c.hull = std::move(*grown);
        hull_version = ++hull_versions_;
        frontier_.insert(frontier_.end(), deferred_.begin(), deferred_.end());
        deferred_.clear();
      }
      c.tets.push_back(e);
      c.volume += volume_[e];
      piece_of_[e] = id;
      add_neighbours(e, id);
    }
    clusters_.push_back(std::move(c));
    return {};
  }

  // Unassigned face neighbours of e not yet offered to piece `id` join the frontier.
  void add_neighbours(Index e, Index id) {
    for (int k = 0; k < 4; ++k) {
      const Index nb = faces_.neighbor(e, k);
      if (nb < 0 || piece_of_[nb] >= 0 || tried_[nb] == id) continue;
      tried_[nb] = id;
      frontier_.push_back(nb);
    }
  }

  // A possible merge. Its key is how far the merged over-fill exceeds the larger of max_overfill
  // and the two pieces' own over-fills: <= 0 when the merge makes nothing worse.
  struct Candidate {
    double overfill;  // the key above
    Index a, b;       // cluster ids, a < b
    Index version_a, version_b;
    bool operator>(const Candidate& o) const { return std::tie(overfill, a, b) > std::tie(o.overfill, o.a, o.b); }
  };

  void offer(Index a, Index b) {
    if (a > b) std::swap(a, b);
    const Cluster& ca = clusters_[a];
    const Cluster& cb = clusters_[b];
    scratch_.assign(ca.hull.vertices.begin(), ca.hull.vertices.end());
    scratch_.insert(scratch_.end(), cb.hull.vertices.begin(), cb.hull.vertices.end());
    auto hull = build_convex_hull(scratch_);
    if (!hull.ok()) return;
    const double own = std::max({options_.max_overfill, overfill(ca.hull, ca.volume), overfill(cb.hull, cb.volume)});
    queue_.push({overfill(*hull, ca.volume + cb.volume) - own, a, b, ca.version, cb.version});
  }

  Result<void> merge() {
    const auto k = static_cast<Index>(clusters_.size());
    neighbours_.assign(static_cast<std::size_t>(k), {});
    for (Index f = 0; f < faces_.num_faces(); ++f) {
      const auto& ft = faces_.face_tets[f];
      if (ft[1] < 0) continue;
      const Index a = piece_of_[ft[0]], b = piece_of_[ft[1]];
      if (a != b) neighbours_[a].push_back(b), neighbours_[b].push_back(a);
    }
    for (auto& nb : neighbours_) {
      std::sort(nb.begin(), nb.end());
      nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    }
    for (Index a = 0; a < k; ++a)
      for (Index b : neighbours_[a])
        if (a < b) offer(a, b);
    Index alive = k;
    const auto too_many = [&] { return options_.max_pieces > 0 && alive > options_.max_pieces; };
    for (bool forced = false;;) {
      while (!queue_.empty()) {
        const Candidate c = queue_.top();
        if (!forced && c.overfill > 0) break;
        queue_.pop();
        Cluster& ca = clusters_[c.a];
        Cluster& cb = clusters_[c.b];
        if (!ca.alive || !cb.alive || ca.version != c.version_a || cb.version != c.version_b) continue;
        scratch_.assign(ca.hull.vertices.begin(), ca.hull.vertices.end());
        scratch_.insert(scratch_.end(), cb.hull.vertices.begin(), cb.hull.vertices.end());
        auto hull = build_convex_hull(scratch_);
        if (!hull.ok()) continue;
        ca.hull = std::move(*hull);
        for (Index e : cb.tets) piece_of_[e] = c.a;
        ca.tets.insert(ca.tets.end(), cb.tets.begin(), cb.tets.end());
        ca.volume += cb.volume;
        ++ca.version;
        cb.alive = false;
        cb.tets = {};
        --alive;
        // a takes b's neighbours.
        std::vector<Index> nb;
        for (Index x : neighbours_[c.a])
          if (clusters_[x].alive && x != c.a) nb.push_back(x);
        for (Index x : neighbours_[c.b])
          if (clusters_[x].alive && x != c.a) nb.push_back(x);
        std::sort(nb.begin(), nb.end());
        nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
        neighbours_[c.a] = nb;
        neighbours_[c.b] = {};
        for (Index x : nb) {
          auto& back = neighbours_[x];
          std::replace(back.begin(), back.end(), c.b, c.a);
          std::sort(back.begin(), back.end());
          back.erase(std::unique(back.begin(), back.end()), back.end());
          offer(c.a, x);
        }
        if (forced && !too_many()) break;
      }
      if (!too_many()) break;
      if (!forced) {
        forced = true;
        continue;
      }
      // Still too many with no adjacent pairs left (disconnected parts): pair each piece with the
      // pieces whose centres are nearest.
      std::vector<Index> live;
      for (Index a = 0; a < k; ++a)
        if (clusters_[a].alive) live.push_back(a);
      for (Index a : live) {
        std::vector<std::pair<double, Index>> near;
        for (Index b : live)
          if (b != a) near.emplace_back((clusters_[a].hull.centroid - clusters_[b].hull.centroid).squaredNorm(), b);
        const std::size_t m = std::min<std::size_t>(near.size(), 4);
        std::partial_sort(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(m), near.end());
        for (std::size_t j = 0; j < m; ++j) offer(a, near[j].second);
      }
      if (queue_.empty()) break;
    }
    return {};
  }

  const TetMesh& mesh_;
  const TetFaces& faces_;
  DecompositionOptions options_;
  std::vector<double> volume_;   // |volume| per tet
  std::vector<Vec3> centroid_;   // per tet
  std::vector<Index> piece_of_;  // cluster of each tet, -1 while unassigned
  std::vector<Index> tried_;     // last cluster that put the tet on its frontier
  std::vector<Index> frontier_;  // candidate tets of the growing cluster
  std::vector<Index> deferred_;  // candidates its hull could not take yet
  std::vector<Cluster> clusters_;
  std::vector<std::vector<Index>> neighbours_;  // adjacent clusters, sorted
  std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> queue_;
  std::vector<Vec3> scratch_;
  std::vector<Index> mark_, queue_tets_;  // fill_volume's visit stamps and queue
  Index stamp_ = 0;
  std::vector<std::int64_t> checked_;  // per tet: the hull version it was last found not inside
  std::int64_t hull_versions_ = 0;     // hull versions handed out (all pieces)
};

}  // namespace

Result<std::vector<ConvexPiece>> decompose_convex(const TetMesh& mesh, const TetFaces& faces,
                                                  const DecompositionOptions& options) {
  if (mesh.num_tets() == 0) return make_error("convex decomposition: the mesh has no tets");
  if (faces.tet_faces.size() != mesh.tets.size())
    return make_error("convex decomposition: the faces are not those of this mesh (" +
                      std::to_string(faces.tet_faces.size()) + " tets vs " + std::to_string(mesh.tets.size()) + ")");
  if (!(options.max_overfill >= 0) || options.max_pieces < 0)
    return make_error("convex decomposition: max_overfill must be >= 0 and max_pieces >= 0");
  Decomposer d(mesh, faces, options);
  return d.run();
}

}  // namespace shatter
