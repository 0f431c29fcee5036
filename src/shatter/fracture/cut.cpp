#include "shatter/fracture/cut.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iterator>
#include <limits>
#include <numeric>
#include <span>

#include "shatter/core/assert.h"
#include "shatter/mesh/topology.h"

namespace shatter {
namespace {

using Edge = std::array<Index, 2>;  // (lower, higher) node index

Edge make_edge(Index a, Index b) { return a < b ? Edge{a, b} : Edge{b, a}; }

FileId first_free_id(const std::vector<FileId>& ids) {
  FileId m = 0;
  for (FileId id : ids) m = std::max(m, id);
  return m + 1;
}

/// New nodes inherit tags and set membership: a node made from nodes a and b belongs to a set when
/// both do; ids are fresh above the maximum.
void append_node_attributes(TetMesh& out, const TetMesh& in, const std::vector<Edge>& sources) {
  if (sources.empty()) return;
  if (!in.node_ids.empty()) {
    FileId next = first_free_id(in.node_ids);
    for (std::size_t i = 0; i < sources.size(); ++i) out.node_ids.push_back(next++);
  }
  if (!in.node_tags.empty())
    for (const Edge& s : sources)
      out.node_tags.push_back(in.node_tags[s[0]] == in.node_tags[s[1]] ? in.node_tags[s[0]] : 0);
  const Index first = in.num_nodes();
  for (auto& [name, set] : out.node_sets) {
    const std::vector<Index>& old = in.node_sets.at(name);
    auto member = [&](Index v) { return std::binary_search(old.begin(), old.end(), v); };
    for (std::size_t i = 0; i < sources.size(); ++i)
      if (member(sources[i][0]) && member(sources[i][1])) set.push_back(first + static_cast<Index>(i));
  }
}

/// Appended tets (pieces) inherit tag and set membership of their parent; ids are fresh.
void append_tet_attributes(TetMesh& out, const TetMesh& in, const std::vector<Index>& parents) {
  if (parents.empty()) return;
  if (!in.tet_ids.empty()) {
    FileId next = first_free_id(in.tet_ids);
    for (std::size_t i = 0; i < parents.size(); ++i) out.tet_ids.push_back(next++);
  }
  if (!in.tet_tags.empty())
    for (Index p : parents) out.tet_tags.push_back(in.tet_tags[p]);
  const Index first = in.num_tets();
  for (auto& [name, set] : out.tet_sets) {
    const std::vector<Index>& old = in.tet_sets.at(name);
    for (std::size_t i = 0; i < parents.size(); ++i)
      if (std::binary_search(old.begin(), old.end(), parents[i])) set.push_back(first + static_cast<Index>(i));
  }
}

struct Piece {
  TetIndices t;
  std::int8_t side;
};

/// Cut one tet (global corners g, node signs s in {-1, 0, +1}, with a + and a - corner) along the
/// plane into positively oriented pieces. Each side's convex piece is coned from its lowest-index
/// vertex over its faces, each face fanned from its own lowest-index vertex (so a face shared by
/// two tets is triangulated the same way by both). Returns false if a piece is below min_volume.
template <class EdgeNode, class Pos>
bool split_tet(const TetIndices& g, const std::array<int, 4>& s, EdgeNode&& edge_node, Pos&& pos, double min_volume,
               std::vector<Piece>& out) {
  std::array<Index, 4> section{};
  std::array<std::array<int, 2>, 4> section_local{};  // local corners of the edge (or {z, z})
  int ns = 0;
  for (int i = 0; i < 4; ++i)
    if (s[i] == 0) {
      section_local[ns] = {i, i};
      section[ns++] = g[i];
    }
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      if (s[i] * s[j] < 0) {
        section_local[ns] = {i, j};
        section[ns++] = edge_node(g[i], g[j]);
      }
  SHATTER_ASSERT(ns == 3 || ns == 4);
  if (ns == 4) {
    // Four edge points: neighbours in the polygon share a corner (lie on a common face).
    auto adjacent = [&](int p, int q) {
      const auto& a = section_local[p];
      const auto& b = section_local[q];
      return a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1];
    };
    if (!adjacent(0, 1)) {
      std::swap(section[1], section[2]);
      std::swap(section_local[1], section_local[2]);
    }
    if (!adjacent(1, 2)) {
      std::swap(section[2], section[3]);
      std::swap(section_local[2], section_local[3]);
    }
  }
  const std::size_t first_piece = out.size();
  for (int side : {1, -1}) {
    std::array<std::array<Index, 4>, 5> faces{};
    std::array<int, 5> face_size{};
    int nf = 0;
    for (int k = 0; k < 4; ++k) {
      int n = 0;
      bool has_side = false;
      for (int j = 0; j < 3; ++j) {
        const int a = kTetFaces[k][j];
        const int b = kTetFaces[k][(j + 1) % 3];
        if (s[a] == side || s[a] == 0) faces[nf][n++] = g[a];
        has_side |= s[a] == side;
        if (s[a] * s[b] < 0) faces[nf][n++] = edge_node(g[a], g[b]);
      }
      if (n >= 3 && has_side) face_size[nf++] = n;
    }
    for (int i = 0; i < ns; ++i) faces[nf][i] = section[i];
    face_size[nf++] = ns;
    // Apex: the piece's lowest-index vertex.
    Index apex = std::numeric_limits<Index>::max();
    for (int f = 0; f < nf; ++f)
      for (int i = 0; i < face_size[f]; ++i) apex = std::min(apex, faces[f][i]);
    for (int f = 0; f < nf; ++f) {
      const int n = face_size[f];
      const auto& p = faces[f];
      if (std::find(p.begin(), p.begin() + n, apex) != p.begin() + n) continue;
      const int m = static_cast<int>(std::min_element(p.begin(), p.begin() + n) - p.begin());
      for (int i = 1; i + 1 < n; ++i) {
        TetIndices t{apex, p[m], p[(m + i) % n], p[(m + i + 1) % n]};
        double v = signed_volume(pos(t[0]), pos(t[1]), pos(t[2]), pos(t[3]));
        if (v < 0) {
          std::swap(t[2], t[3]);
          v = -v;
        }
        if (!(v >= min_volume)) {
          out.resize(first_piece);
          return false;
        }
        out.push_back({t, static_cast<std::int8_t>(side)});
      }
    }
  }
  return true;
}

}  // namespace

CutResult split_along_plane(const TetMesh& mesh, const CutPlane& plane, const std::vector<Index>& region_in,
                            const CutOptions& options) {
  const Index nn = mesh.num_nodes();
  const Index nt = mesh.num_tets();
  // In increasing order without repeats (crack regions come so: then no copy is sorted).
  const bool ordered =
      std::adjacent_find(region_in.begin(), region_in.end(), std::greater_equal<Index>()) == region_in.end();
  std::vector<Index> sorted_region;
  if (!ordered) {
    sorted_region = region_in;
    std::sort(sorted_region.begin(), sorted_region.end());
    sorted_region.erase(std::unique(sorted_region.begin(), sorted_region.end()), sorted_region.end());
  }
  const std::vector<Index>& region = ordered ? region_in : sorted_region;

  // Node signs with snapping: |d| <= snap_fraction x shortest incident region edge counts as 0.
  std::vector<double> dist(nn, 0.0);
  // Shortest squared edge per node: sqrt is correctly rounded and monotone, so the square root of
  // the least square is the least length, bit for bit, for one root per node instead of per edge.
  std::vector<double> h2(nn, std::numeric_limits<double>::infinity());
  std::vector<int> sign(nn, 0);
  for (Index e : region) {
    const TetIndices& t = mesh.tets[e];
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const double l2 = (mesh.positions[t[a]] - mesh.positions[t[b]]).squaredNorm();
        h2[t[a]] = std::min(h2[t[a]], l2);
        h2[t[b]] = std::min(h2[t[b]], l2);
      }
  }
  // Each node once (h2 is final; a node lies on about twenty region tets).
  std::vector<char> signed_node(static_cast<std::size_t>(nn), 0);
  for (Index e : region)
    for (Index v : mesh.tets[e]) {
      if (signed_node[v]) continue;
      signed_node[v] = 1;
      const double d = plane.normal.dot(mesh.positions[v] - plane.point);
      dist[v] = d;
      sign[v] = std::abs(d) <= options.snap_fraction * std::sqrt(h2[v]) ? 0 : (d > 0 ? 1 : -1);
    }
  auto crossed = [&](Index e) {
    bool plus = false, minus = false;
    for (Index v : mesh.tets[e]) {
      plus |= sign[v] > 0;
      minus |= sign[v] < 0;
    }
    return plus && minus;
  };

  // Candidate tets and their crossed edges (provisional node index nn + rank in sorted order).
  std::vector<Index> cand;
  if (options.split_tets)
    for (Index e : region)
      if (crossed(e)) cand.push_back(e);
  std::vector<Edge> edges;
  for (Index e : cand) {
    const TetIndices& t = mesh.tets[e];
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        if (sign[t[a]] * sign[t[b]] < 0) edges.push_back(make_edge(t[a], t[b]));
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  auto edge_rank = [&](Index a, Index b) {
    const Edge k = make_edge(a, b);
    return static_cast<Index>(std::lower_bound(edges.begin(), edges.end(), k) - edges.begin());
  };
  std::vector<Vec3> edge_pos(edges.size());
  std::vector<double> edge_t(edges.size());
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const auto [a, b] = edges[i];
    const double t = dist[a] / (dist[a] - dist[b]);
    edge_t[i] = t;
    edge_pos[i] = mesh.positions[a] + t * (mesh.positions[b] - mesh.positions[a]);
  }
  auto pos = [&](Index v) -> const Vec3& { return v < nn ? mesh.positions[v] : edge_pos[v - nn]; };
  // The rank of each candidate's crossed edges, found once, by local edge (kTetEdges).
  std::vector<std::array<Index, 6>> cand_edge(cand.size());
  for (std::size_t c = 0; c < cand.size(); ++c) {
    const TetIndices& t = mesh.tets[cand[c]];
    for (int q = 0; q < 6; ++q) {
      const Index a = t[kTetEdges[q][0]], b = t[kTetEdges[q][1]];
      cand_edge[c][q] = sign[a] * sign[b] < 0 ? edge_rank(a, b) : -1;
    }
  }

  // Pieces of each candidate; a candidate with a too small piece is dropped.
  std::vector<char> in_s(nt, 0);
  std::vector<Index> piece_begin;  // per candidate, into pieces (+ end)
  std::vector<Piece> pieces;
  for (std::size_t c = 0; c < cand.size(); ++c) {
    const Index e = cand[c];
    piece_begin.push_back(static_cast<Index>(pieces.size()));
    const TetIndices& t = mesh.tets[e];
    // The provisional node of crossed edge (a, b) of this tet: nn + its rank.
    auto provisional = [&](Index a, Index b) {
      for (int q = 0; q < 6; ++q) {
        const Index u = t[kTetEdges[q][0]], w = t[kTetEdges[q][1]];
        if ((u == a && w == b) || (u == b && w == a)) return nn + cand_edge[c][q];
      }
      SHATTER_ASSERT(false);
      return Index{-1};
    };
    const std::array<int, 4> s{sign[t[0]], sign[t[1]], sign[t[2]], sign[t[3]]};
    const double min_volume = options.min_volume_fraction * signed_volume(mesh, e);
    if (split_tet(t, s, provisional, pos, min_volume, pieces)) in_s[e] = 1;
  }
  piece_begin.push_back(static_cast<Index>(pieces.size()));

  // Conformity: an edge is split only if every tet around it is split, and a tet only if all its
  // crossed edges are. Shrink both sets to the fixed point (the largest one: the rules only ever
  // remove, so the order of the passes does not change it). The tets around each edge are found
  // once (CSR, for the crossed edges' end nodes only).
  std::vector<char> on_edge(static_cast<std::size_t>(nn), 0);
  for (const Edge& edge : edges) on_edge[edge[0]] = on_edge[edge[1]] = 1;
  const NodeTets nt_of = node_tets(mesh, on_edge);
  std::vector<Index> edge_tets_begin{0};
  std::vector<Index> edge_tets;
  edge_tets_begin.reserve(edges.size() + 1);
  for (const Edge& edge : edges) {
    const auto ta = nt_of.of(edge[0]);
    const auto tb = nt_of.of(edge[1]);
    std::set_intersection(ta.begin(), ta.end(), tb.begin(), tb.end(), std::back_inserter(edge_tets));
    edge_tets_begin.push_back(static_cast<Index>(edge_tets.size()));
  }
  std::vector<char> edge_alive(edges.size(), 1);
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t i = 0; i < edges.size(); ++i) {
      if (!edge_alive[i]) continue;
      for (Index k = edge_tets_begin[i]; k < edge_tets_begin[i + 1]; ++k)
        if (!in_s[edge_tets[k]]) {
          edge_alive[i] = 0;
          changed = true;
          break;
        }
    }
    for (std::size_t c = 0; c < cand.size(); ++c) {
      if (!in_s[cand[c]]) continue;
      for (const Index rank : cand_edge[c])
        if (rank >= 0 && !edge_alive[rank]) {
          in_s[cand[c]] = 0;
          changed = true;
          break;
        }
    }
  }

  // Compact the surviving edge nodes (order preserved, so the lowest-index rules are unchanged).
  std::vector<Index> edge_node(edges.size(), -1);
  CutResult r;
  r.mesh = mesh;
  std::vector<Edge> new_sources;
  r.node_origin.resize(nn);
  for (Index v = 0; v < nn; ++v) r.node_origin[v] = {v, v, 0.0};
  for (std::size_t i = 0; i < edges.size(); ++i)
    if (edge_alive[i]) {
      edge_node[i] = static_cast<Index>(r.mesh.positions.size());
      r.mesh.positions.push_back(edge_pos[i]);
      r.node_origin.push_back({edges[i][0], edges[i][1], edge_t[i]});
      new_sources.push_back(edges[i]);
    }
  r.edge_nodes = static_cast<Index>(new_sources.size());
  append_node_attributes(r.mesh, mesh, new_sources);
  auto remap = [&](Index v) { return v < nn ? v : edge_node[v - nn]; };

  r.tet_parent.resize(nt);
  std::iota(r.tet_parent.begin(), r.tet_parent.end(), Index(0));
  r.tet_side.assign(nt, 0);
  std::vector<Index> extra_parents;
  for (std::size_t c = 0; c < cand.size(); ++c) {
    const Index e = cand[c];
    if (!in_s[e]) continue;
    ++r.tets_split;
    r.changed_tets.push_back(e);
    for (Index p = piece_begin[c]; p < piece_begin[c + 1]; ++p) {
      TetIndices t = pieces[p].t;
      for (Index& v : t) v = remap(v);
      if (p == piece_begin[c]) {
        r.mesh.tets[e] = t;
        r.tet_side[e] = pieces[p].side;
      } else {
        r.mesh.tets.push_back(t);
        r.tet_side.push_back(pieces[p].side);
        r.tet_parent.push_back(e);
        extra_parents.push_back(e);
      }
    }
  }
  append_tet_attributes(r.mesh, mesh, extra_parents);
  // Unsplit region tets: the side of their off-plane corners if they agree, else of the centroid.
  for (Index e : region) {
    if (in_s[e]) continue;
    const TetIndices& t = mesh.tets[e];
    int plus = 0, minus = 0;
    for (Index v : t) {
      plus += sign[v] > 0;
      minus += sign[v] < 0;
    }
    if (plus > 0 && minus == 0)
      r.tet_side[e] = 1;
    else if (minus > 0 && plus == 0)
      r.tet_side[e] = -1;
    else {
      const Vec3 c = mesh.corners(e).rowwise().mean();
      r.tet_side[e] = plane.normal.dot(c - plane.point) >= 0 ? 1 : -1;
    }
  }
  return r;
}

DisconnectResult disconnect_faces(const TetMesh& mesh, const std::vector<std::int8_t>& tet_side) {
  SHATTER_CHECK(tet_side.size() == mesh.tets.size());
  const Index nn = mesh.num_nodes();
  using Face = std::array<Index, 3>;  // sorted node indices
  auto face_key = [&](Index e, int k) {
    const TetIndices& t = mesh.tets[e];
    Face f{t[kTetFaces[k][0]], t[kTetFaces[k][1]], t[kTetFaces[k][2]]};
    std::sort(f.begin(), f.end());
    return f;
  };
  // Faces between + and - tets (local search from the marked tets). Only a face whose three nodes
  // all belong to some - tet can have one on its other side: the others need no search.
  std::vector<char> on_minus(static_cast<std::size_t>(nn), 0);
  std::vector<char> on_plus(static_cast<std::size_t>(nn), 0);
  for (Index e = 0; e < mesh.num_tets(); ++e)
    if (tet_side[e] != 0)
      for (Index v : mesh.tets[e]) (tet_side[e] < 0 ? on_minus : on_plus)[v] = 1;
  // Every node asked about below is on a face of a + tet whose three nodes are all on - tets.
  std::vector<char> on_both(static_cast<std::size_t>(nn), 0);
  for (std::size_t v = 0; v < on_both.size(); ++v) on_both[v] = on_minus[v] & on_plus[v];
  const NodeTets nt_of = node_tets(mesh, on_both);
  std::vector<Face> cut_faces;
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    if (tet_side[e] <= 0) continue;
    const TetIndices& t = mesh.tets[e];
    for (int k = 0; k < 4; ++k) {
      if (!on_minus[t[kTetFaces[k][0]]] || !on_minus[t[kTetFaces[k][1]]] || !on_minus[t[kTetFaces[k][2]]]) continue;
      const Index n = face_neighbor(mesh, nt_of, e, k);
      if (n >= 0 && tet_side[n] < 0) cut_faces.push_back(face_key(e, k));
    }
  }
  std::sort(cut_faces.begin(), cut_faces.end());
  std::vector<Face> kept;  // faces left connected to stay manifold (sorted)
  auto is_cut = [&](Index e, int k, Index n) {
    if (tet_side[e] * tet_side[n] >= 0) return false;
    const Face f = face_key(e, k);
    return !std::binary_search(kept.begin(), kept.end(), f);
  };

  DisconnectResult r;
  for (;;) {
    std::vector<Index> cand;
    std::vector<Face> active;
    for (const Face& f : cut_faces)
      if (!std::binary_search(kept.begin(), kept.end(), f)) {
        active.push_back(f);
        cand.insert(cand.end(), f.begin(), f.end());
      }
    std::sort(cand.begin(), cand.end());
    cand.erase(std::unique(cand.begin(), cand.end()), cand.end());

    r.mesh = mesh;
    r.changed_tets.clear();
    r.node_parent.resize(nn);
    std::iota(r.node_parent.begin(), r.node_parent.end(), Index(0));
    std::vector<Edge> sources;
    std::vector<Index> parent;  // local union-find over the node's tets
    // The faces through a node, keyed by their two other nodes (a < b) as ((a + 1) << 32) | (b + 1)
    // (0: an empty slot), in an open-addressing table of a power-of-two size, with the last face
    // of each key seen so far, as (tet i << 2) | face k. Cleared slot by slot after each node.
    std::vector<std::uint64_t> slot_key;
    std::vector<std::int64_t> slot_last;
    std::vector<std::size_t> used_slots;
    std::vector<Index> copy_of_root;
    for (Index v : cand) {
      const auto ts = nt_of.of(v);
      const Index n = static_cast<Index>(ts.size());
      parent.resize(n);
      std::iota(parent.begin(), parent.end(), Index(0));
      auto find = [&](Index i) {
        while (parent[i] != i) i = parent[i] = parent[parent[i]];
        return i;
      };
      // Two tets of v share a face through v when they share its other two nodes. The faces through
      // v (three per tet; face k is opposite corner k), in (tet, face) order: each is paired with
      // the last earlier face of the same two nodes (a face of a valid mesh has one such).
      std::size_t size = 16;
      while (size < 6 * static_cast<std::size_t>(n)) size *= 2;
      if (slot_key.size() < size) {
        slot_key.assign(size, 0);
        slot_last.resize(size);
      }
      const std::size_t mask = slot_key.size() - 1;
      const int shift = 64 - std::countr_zero(slot_key.size());
      for (Index i = 0; i < n; ++i) {
        const TetIndices& t = mesh.tets[ts[i]];
        for (int k = 0; k < 4; ++k) {
          if (t[k] == v) continue;
          std::array<Index, 2> others{};
          int no = 0;
          for (int c = 0; c < 4; ++c)
            if (c != k && t[c] != v) others[no++] = t[c];
          const std::uint64_t key = (static_cast<std::uint64_t>(std::min(others[0], others[1]) + 1) << 32) |
                                    static_cast<std::uint64_t>(std::max(others[0], others[1]) + 1);
          std::size_t h = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ULL) >> shift) & mask;
          while (slot_key[h] != 0 && slot_key[h] != key) h = (h + 1) & mask;
          const std::int64_t here = (static_cast<std::int64_t>(i) << 2) | k;
          if (slot_key[h] == 0) {
            slot_key[h] = key;
            used_slots.push_back(h);
          } else {
            const auto earlier = static_cast<Index>(slot_last[h] >> 2);
            const int earlier_face = static_cast<int>(slot_last[h] & 3);
            // Roots are the lowest member of their group whatever the order of unions, so the
            // groups and the copies below do not depend on it.
            if (!is_cut(ts[earlier], earlier_face, ts[i])) {
              const Index a = find(earlier), b = find(i);
              if (a != b) parent[std::max(a, b)] = std::min(a, b);
            }
          }
          slot_last[h] = here;
        }
      }
      for (const std::size_t h : used_slots) slot_key[h] = 0;
      used_slots.clear();
      // Group of the lowest tet keeps v; each further group (by lowest tet) gets a new copy.
      copy_of_root.assign(static_cast<std::size_t>(n), -1);
      for (Index i = 0; i < n; ++i) {
        const Index root = find(i);
        if (copy_of_root[root] < 0) {
          if (root == 0) {
            copy_of_root[root] = v;
          } else {
            copy_of_root[root] = static_cast<Index>(r.mesh.positions.size());
            r.mesh.positions.push_back(mesh.positions[v]);
            r.node_parent.push_back(v);
            sources.push_back({v, v});
          }
        }
        const Index c = copy_of_root[root];
        if (c != v) {
          for (Index& w : r.mesh.tets[ts[i]])
            if (w == v) w = c;
          r.changed_tets.push_back(ts[i]);
        }
      }
    }
    std::sort(r.changed_tets.begin(), r.changed_tets.end());
    r.changed_tets.erase(std::unique(r.changed_tets.begin(), r.changed_tets.end()), r.changed_tets.end());
    append_node_attributes(r.mesh, mesh, sources);
    r.nodes_duplicated = static_cast<Index>(sources.size());
    r.faces_cut = static_cast<Index>(active.size());
    if (sources.empty()) break;

    // Manifold check on the edges of the cut faces: in the new mesh, the tets around a copy of the
    // edge may expose at most two boundary faces at it. Otherwise keep the cut faces on that edge
    // connected and redo.
    std::vector<Edge> bad;
    std::vector<std::array<Index, 3>> fan;  // (copy of u, copy of w, third node) per face at the edge
    std::vector<Edge> face_edges;           // each edge once (most are on two cut faces)
    face_edges.reserve(3 * active.size());
    for (const Face& f : active)
      for (int j = 0; j < 3; ++j) face_edges.push_back(make_edge(f[j], f[(j + 1) % 3]));
    std::sort(face_edges.begin(), face_edges.end());
    face_edges.erase(std::unique(face_edges.begin(), face_edges.end()), face_edges.end());
    for (const auto& [u, w] : face_edges) {
      const auto tu = nt_of.of(u);
      const auto tw = nt_of.of(w);
      fan.clear();
      for (Index e : tu) {
        if (!std::binary_search(tw.begin(), tw.end(), e)) continue;
        Index cu = -1, cw = -1;
        std::array<Index, 2> others{};
        int no = 0;
        for (int k = 0; k < 4; ++k) {
          if (mesh.tets[e][k] == u)
            cu = r.mesh.tets[e][k];
          else if (mesh.tets[e][k] == w)
            cw = r.mesh.tets[e][k];
          else
            others[no++] = r.mesh.tets[e][k];
        }
        for (Index o : others) fan.push_back({cu, cw, o});
      }
      std::sort(fan.begin(), fan.end());
      for (std::size_t i = 0; i < fan.size();) {
        std::size_t end = i;
        int boundary = 0;
        while (end < fan.size() && fan[end][0] == fan[i][0] && fan[end][1] == fan[i][1]) {
          std::size_t same = end;
          while (same < fan.size() && fan[same] == fan[end]) ++same;
          boundary += same - end == 1;
          end = same;
        }
        if (boundary > 2) bad.push_back(make_edge(u, w));
        i = end;
      }
    }
    if (bad.empty()) break;
    std::sort(bad.begin(), bad.end());
    bool changed = false;
    for (const Face& f : active)
      for (int j = 0; j < 3; ++j)
        if (std::binary_search(bad.begin(), bad.end(), make_edge(f[j], f[(j + 1) % 3]))) {
          kept.push_back(f);
          changed = true;
          break;
        }
    std::sort(kept.begin(), kept.end());
    if (!changed) break;
  }
  return r;
}

CutResult cut_mesh(const TetMesh& mesh, const CutPlane& plane, const std::vector<Index>& region,
                   const CutOptions& options) {
  CutResult split = split_along_plane(mesh, plane, region, options);
  DisconnectResult d = disconnect_faces(split.mesh, split.tet_side);
  CutResult r;
  r.mesh = std::move(d.mesh);
  r.node_origin.reserve(r.mesh.positions.size());
  for (Index p : d.node_parent) r.node_origin.push_back(split.node_origin[p]);
  r.tet_parent = std::move(split.tet_parent);
  r.tet_side = std::move(split.tet_side);
  r.tets_split = split.tets_split;
  r.edge_nodes = split.edge_nodes;
  r.nodes_duplicated = d.nodes_duplicated;
  r.faces_cut = d.faces_cut;
  // Both lists are increasing: merged without repeats, the input's tets only (a split's pieces
  // past them may have taken node copies too).
  const auto input_end = std::lower_bound(d.changed_tets.begin(), d.changed_tets.end(), mesh.num_tets());
  std::set_union(split.changed_tets.begin(), split.changed_tets.end(), d.changed_tets.begin(), input_end,
                 std::back_inserter(r.changed_tets));
  return r;
}

}  // namespace shatter
