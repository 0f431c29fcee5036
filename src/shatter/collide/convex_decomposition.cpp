// Convex decomposition by region growing over face-connected tets, then merging (see
// convex_decomposition.h).
//  0. Units: growth and merging work on units of face-connected tets. Up to group_above tets, each
//     tet is a unit. Finer meshes are cut by a grid of cubes sized to hold about tets / groups tets
//     each, and a unit is a face-connected set of tets with their centres in one cube, so the work
//     stays about that of a mesh of `groups` tets (each trial hull is tested against the frontier,
//     and both grow with the piece). The hulls are exact either way: the hull of the nodes of the
//     tets a piece covers.
//  1. Growing: from the unit with the lowest tet not yet in a piece, add neighbouring units. Units
//     whose nodes are all inside the current hull come first (they fill it; the hull does not
//     change). Else the neighbour nearest the seed is tried: the hull with its nodes is kept when it
//     over-fills the piece's tets, plus the unassigned units whose centres it already encloses (the
//     material the piece takes in next), by no more than max_overfill. Without counting that
//     material a convex body could not be grown tet by tet: a small cluster's jagged front
//     over-fills its hull. Candidates refused wait and are tried again whenever the hull grows.
//     Hulls are rebuilt from the old hull's vertices and the new nodes only.
//  2. Merging: adjacent pieces are joined while the merged over-fill is no more than the larger
//     of max_overfill and the two pieces' own (least excess first), which also absorbs the small
//     leftovers of growth. Then, while there are more than max_pieces, the least over-filling
//     pairs are joined regardless.
#include "shatter/collide/convex_decomposition.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <span>
#include <tuple>

namespace shatter {
namespace {

struct Cluster {
  ConvexHull hull;
  std::vector<Index> units;
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

Error piece_error(const Error& e, Index seed_tet) {
  return make_error("convex decomposition: the piece grown from tet " + std::to_string(seed_tet) +
                    " spans no volume (degenerate tets): " + e.message);
}

class Decomposer {
 public:
  Decomposer(const TetMesh& mesh, const TetFaces& faces, const DecompositionOptions& options)
      : mesh_(mesh), faces_(faces), options_(options) {}

  Result<std::vector<ConvexPiece>> run() {
    make_units();
    const auto n = static_cast<Index>(volume_.size());
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
      std::vector<Index> tets;
      for (const Index u : c.units) tets.insert(tets.end(), unit_tets(u).begin(), unit_tets(u).end());
      std::sort(tets.begin(), tets.end());
      pieces.push_back({std::move(c.hull), std::move(tets), c.volume});
    }
    std::sort(pieces.begin(), pieces.end(),
              [](const ConvexPiece& a, const ConvexPiece& b) { return a.tets.front() < b.tets.front(); });
    return pieces;
  }

 private:
  // Splits the tets into units (step 0 above), numbered in order of their lowest tet.
  void make_units() {
    const Index n = mesh_.num_tets();
    std::vector<double> tet_volume(static_cast<std::size_t>(n));
    std::vector<Vec3> tet_centroid(static_cast<std::size_t>(n));
    double total = 0;
    Aabb box;
    for (Index e = 0; e < n; ++e) {
      tet_volume[e] = std::abs(signed_volume(mesh_, e));
      tet_centroid[e] = mesh_.corners(e).rowwise().mean();
      total += tet_volume[e];
      box.extend(tet_centroid[e]);
    }
    // Grid cell of each tet's centre: cubes of the volume of total / groups (0 for all when each
    // tet is its own unit).
    std::vector<std::uint64_t> cell(static_cast<std::size_t>(n), 0);
    const bool grouped = options_.group_above > 0 && n > options_.group_above && total > 0;
    if (grouped) {
      const double size = std::cbrt(total / static_cast<double>(options_.groups));
      const auto coordinate = [&](double x, double lo) {
        return static_cast<std::uint64_t>(std::clamp(std::floor((x - lo) / size), 0.0, double{(1 << 21) - 1}));
      };
      for (Index e = 0; e < n; ++e) {
        const Vec3& c = tet_centroid[e];
        cell[e] = coordinate(c.x(), box.min.x()) << 42 | coordinate(c.y(), box.min.y()) << 21 |
                  coordinate(c.z(), box.min.z());
      }
    }
    // Units: the face-connected tets of one cell, by a walk from each tet not yet in one.
    unit_of_.assign(static_cast<std::size_t>(n), -1);
    unit_start_ = {0};
    unit_tet_list_.clear();
    for (Index seed = 0; seed < n; ++seed) {
      if (unit_of_[seed] >= 0) continue;
      const auto u = static_cast<Index>(unit_start_.size() - 1);
      const std::size_t first = unit_tet_list_.size();
      unit_of_[seed] = u;
      unit_tet_list_.push_back(seed);
      if (grouped)
        for (std::size_t q = first; q < unit_tet_list_.size(); ++q)  // NOLINT(modernize-loop-convert): grows
          for (int k = 0; k < 4; ++k) {
            const Index nb = faces_.neighbor(unit_tet_list_[q], k);
            if (nb < 0 || unit_of_[nb] >= 0 || cell[nb] != cell[seed]) continue;
            unit_of_[nb] = u;
            unit_tet_list_.push_back(nb);
          }
      unit_start_.push_back(static_cast<Index>(unit_tet_list_.size()));
    }
    // Per unit: volume, centre (volume-weighted; a single tet's is its centroid), its nodes (in
    // order of first use) and its neighbouring units (in order of first meeting; for single tets,
    // the face neighbours in face order).
    const auto units = static_cast<Index>(unit_start_.size() - 1);
    volume_.assign(static_cast<std::size_t>(units), 0);
    centroid_.assign(static_cast<std::size_t>(units), Vec3::Zero());
    node_start_ = {0};
    node_list_.clear();
    neighbour_start_ = {0};
    neighbour_list_.clear();
    std::vector<Index> node_seen(mesh_.positions.size(), -1);
    std::vector<Index> unit_seen(static_cast<std::size_t>(units), -1);
    for (Index u = 0; u < units; ++u) {
      const std::span<const Index> tets = unit_tets(u);
      if (tets.size() == 1) {
        volume_[u] = tet_volume[tets[0]];
        centroid_[u] = tet_centroid[tets[0]];
      } else {
        for (const Index e : tets) {
          volume_[u] += tet_volume[e];
          centroid_[u] += tet_volume[e] * tet_centroid[e];
        }
        centroid_[u] /= volume_[u] > 0 ? volume_[u] : 1.0;
      }
      for (const Index e : tets)
        for (const Index v : mesh_.tets[e])
          if (node_seen[v] != u) {
            node_seen[v] = u;
            node_list_.push_back(mesh_.positions[v]);
          }
      node_start_.push_back(static_cast<Index>(node_list_.size()));
      for (const Index e : tets)
        for (int k = 0; k < 4; ++k) {
          const Index nb = faces_.neighbor(e, k);
          if (nb < 0 || unit_of_[nb] == u || unit_seen[unit_of_[nb]] == u) continue;
          unit_seen[unit_of_[nb]] = u;
          neighbour_list_.push_back(unit_of_[nb]);
        }
      neighbour_start_.push_back(static_cast<Index>(neighbour_list_.size()));
    }
  }

  std::span<const Index> unit_tets(Index u) const {
    return {unit_tet_list_.data() + unit_start_[u], unit_tet_list_.data() + unit_start_[u + 1]};
  }
  std::span<const Vec3> nodes(Index u) const {
    return {node_list_.data() + node_start_[u], node_list_.data() + node_start_[u + 1]};
  }
  std::span<const Index> neighbours(Index u) const {
    return {neighbour_list_.data() + neighbour_start_[u], neighbour_list_.data() + neighbour_start_[u + 1]};
  }
  bool nodes_inside(const ConvexHull& hull, Index u) const {
    const std::span<const Vec3> x = nodes(u);
    return std::all_of(x.begin(), x.end(), [&](const Vec3& p) { return inside(hull, p); });
  }

  // Over-fill of a hull over tets of `volume`.
  static double overfill(const ConvexHull& hull, double volume) { return (hull.volume - volume) / volume; }

  // Volume of the unassigned units whose centres lie inside `hull`, reached from the frontier
  // and from e through such units, m^3: the material a growing cluster will take in next.
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
    for (const Index t : neighbours(e)) visit(t);
    for (std::size_t q = 0; q < queue_tets_.size(); ++q)  // NOLINT(modernize-loop-convert): grows while visited
      for (const Index t : neighbours(queue_tets_[q])) visit(t);
    return volume;
  }

  Result<void> grow(Index seed) {
    const auto id = static_cast<Index>(clusters_.size());
    auto hull = build_convex_hull(nodes(seed));
    if (!hull.ok()) return piece_error(hull.error(), unit_tets(seed).front());
    Cluster c;
    c.hull = std::move(*hull);
    c.units = {seed};
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
    const Index max_builds = 16 + 4 * static_cast<Index>(volume_.size());
    while (!frontier_.empty()) {
      // A frontier tet inside the hull (the first in frontier order), else the one nearest the seed.
      // (checked_[t] == hull_version: t was found not inside this hull already.)
      std::size_t pick = frontier_.size();
      for (std::size_t k = 0; k < frontier_.size() && pick == frontier_.size(); ++k) {
        const Index t = frontier_[k];
        if (checked_[t] == hull_version) continue;
        if (nodes_inside(c.hull, t))
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
        auto grown = hull_with(c.hull, nodes(e), scratch_);
        if (!grown.ok() || overfill(*grown, c.volume + volume_[e] + fill_volume(*grown, e)) > options_.max_overfill) {
          deferred_.push_back(e);
          continue;
        }
        c.hull = std::move(*grown);
        hull_version = ++hull_versions_;
        frontier_.insert(frontier_.end(), deferred_.begin(), deferred_.end());
        deferred_.clear();
      }
      c.units.push_back(e);
      c.volume += volume_[e];
      piece_of_[e] = id;
      add_neighbours(e, id);
    }
    clusters_.push_back(std::move(c));
    return {};
  }

  // Unassigned neighbours of unit e not yet offered to piece `id` join the frontier.
  void add_neighbours(Index e, Index id) {
    for (const Index nb : neighbours(e)) {
      if (piece_of_[nb] >= 0 || tried_[nb] == id) continue;
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

  // Queues the merge of a and b. Only the merged hull's volume is needed here (the hull is built
  // when the merge is made): that of the triangle hull, from the vertices of the hull with more of
  // them and those of the other outside it (none outside: the first hull itself).
  void offer(Index a, Index b) {
    if (a > b) std::swap(a, b);
    const Cluster& ca = clusters_[a];
    const Cluster& cb = clusters_[b];
    const bool a_larger = ca.hull.vertices.size() >= cb.hull.vertices.size();
    const ConvexHull& large = a_larger ? ca.hull : cb.hull;
    const ConvexHull& small = a_larger ? cb.hull : ca.hull;
    scratch_.assign(large.vertices.begin(), large.vertices.end());
    for (const Vec3& x : small.vertices)
      if (!inside(large, x)) scratch_.push_back(x);
    double merged = large.volume;
    if (scratch_.size() > large.vertices.size()) {
      auto volume = convex_hull_volume(scratch_);
      if (!volume.ok()) return;
      merged = *volume;
    }
    const double own = std::max({options_.max_overfill, overfill(ca.hull, ca.volume), overfill(cb.hull, cb.volume)});
    const double tets = ca.volume + cb.volume;
    queue_.push({(merged - tets) / tets - own, a, b, ca.version, cb.version});
  }

  Result<void> merge() {
    const auto k = static_cast<Index>(clusters_.size());
    neighbours_.assign(static_cast<std::size_t>(k), {});
    for (Index f = 0; f < faces_.num_faces(); ++f) {
      const auto& ft = faces_.face_tets[f];
      if (ft[1] < 0) continue;
      const Index a = piece_of_[unit_of_[ft[0]]], b = piece_of_[unit_of_[ft[1]]];
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
        for (Index u : cb.units) piece_of_[u] = c.a;
        ca.units.insert(ca.units.end(), cb.units.begin(), cb.units.end());
        ca.volume += cb.volume;
        ++ca.version;
        cb.alive = false;
        cb.units = {};
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
  // Units (CSR lists): their tets, nodes and neighbouring units.
  std::vector<Index> unit_of_;  // per tet
  std::vector<Index> unit_start_, unit_tet_list_;
  std::vector<Index> node_start_;
  std::vector<Vec3> node_list_;
  std::vector<Index> neighbour_start_, neighbour_list_;
  std::vector<double> volume_;   // tet volume per unit, m^3
  std::vector<Vec3> centroid_;   // per unit
  std::vector<Index> piece_of_;  // cluster of each unit, -1 while unassigned
  std::vector<Index> tried_;     // last cluster that put the unit on its frontier
  std::vector<Index> frontier_;  // candidate units of the growing cluster
  std::vector<Index> deferred_;  // candidates its hull could not take yet
  std::vector<Cluster> clusters_;
  std::vector<std::vector<Index>> neighbours_;  // adjacent clusters, sorted
  std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> queue_;
  std::vector<Vec3> scratch_;
  std::vector<Index> mark_, queue_tets_;  // fill_volume's visit stamps and queue (units)
  Index stamp_ = 0;
  std::vector<std::int64_t> checked_;  // per unit: the hull version it was last found not inside
  std::int64_t hull_versions_ = 0;     // hull versions handed out (all pieces)
};

}  // namespace

Result<std::vector<ConvexPiece>> decompose_convex(const TetMesh& mesh, const TetFaces& faces,
                                                  const DecompositionOptions& options) {
  if (mesh.num_tets() == 0) return make_error("convex decomposition: the mesh has no tets");
  if (faces.tet_faces.size() != mesh.tets.size())
    return make_error("convex decomposition: the faces are not those of this mesh (" +
                      std::to_string(faces.tet_faces.size()) + " tets vs " + std::to_string(mesh.tets.size()) + ")");
  if (!(options.max_overfill >= 0) || options.max_pieces < 0 || options.group_above < 0 || options.groups < 1)
    return make_error(
        "convex decomposition: max_overfill must be >= 0, max_pieces >= 0, group_above >= 0 and groups >= 1");
  Decomposer d(mesh, faces, options);
  return d.run();
}

}  // namespace shatter
