// Quickhull (Barber, Dobkin & Huhdanpaa 1996) with fat planes, then coplanar triangles merged into
// polygons (see convex_hull.h). Two stages:
//  1. Triangle quickhull over the input points: a point counts as outside a triangle only when it is
//     more than half the tolerance above its plane, so points on or near the surface are dropped.
//     Which triangles the eye point sees is decided exactly (orient3d with a floating-point filter
//     and an exact fallback), so the triangle hull of the points kept is exactly convex and every
//     horizon is one simple loop. The visible region is grown depth-first from the triangle the eye
//     belongs to, which gives the horizon in counter-clockwise order (Gregorius, "Implementing
//     Quickhull", GDC 2014).
//  2. Adjacent triangles are clustered while each cluster stays flat within the tolerance, every
//     cluster's boundary loop becomes a face, vertices left between only two faces (points on an
//     edge of the hull) are removed, and faces that still come out coplanar with a neighbour are
//     merged until none do. The result is renumbered compactly: vertices in input order, faces in
//     order of their first triangle, edges by their sorted vertex pair.
#include "shatter/collide/convex_hull.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <tuple>
#include <utility>

#include "shatter/core/assert.h"

namespace shatter {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

struct Tri {
  std::array<Index, 3> v{};    // input point indices, counter-clockwise seen from outside
  std::array<Index, 3> adj{};  // adj[i]: triangle across edge v[i] -> v[i+1]
  Vec3 normal = Vec3::Zero();  // outward unit normal
  double offset = 0;           // normal . x on the plane
  Index outside = -1;          // head of its outside-point list (linked through next_point)
  bool alive = true;
  bool visible = false;
};

// Twice the area vector of triangle (a, b, c), from the two edges at the corner opposite the longest
// edge (the best-conditioned of the three equal cross products).
Vec3 area_vector2(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double lab = (b - a).squaredNorm(), lbc = (c - b).squaredNorm(), lca = (a - c).squaredNorm();
  if (lbc >= lab && lbc >= lca) return (b - a).cross(c - a);
  if (lca >= lab) return (c - b).cross(a - b);
  return (a - c).cross(b - c);
}

// Which edge of a triangle runs from -> to, or -1.
int edge_index(const std::array<Index, 3>& v, Index from, Index to) {
  for (int i = 0; i < 3; ++i)
    if (v[i] == from && v[(i + 1) % 3] == to) return i;
  return -1;
}

// Exact sign of orient3d = (b - a) . ((c - a) x (d - a)): > 0 when d is above the plane of the
// counter-clockwise triangle (a, b, c). A floating-point filter first (error bound after Shewchuk
// 1997), then exact expansion arithmetic for the near-degenerate cases. Exact visibility keeps the
// triangle hull exactly convex whatever the round-off in its face planes.
// An expansion of at most N components (non-overlapping, increasing magnitude), on the stack: the
// exact path runs often (boxes and structured meshes have exactly coplanar points), and heap
// expansions made it cost more than the hull itself.
template <int N>
struct Expansion {
  std::array<double, N> c{};
  int n = 0;
};

void two_sum(double a, double b, double& sum, double& err) {
  sum = a + b;
  const double bv = sum - a, av = sum - bv;
  err = (a - av) + (b - bv);
}

// e += b (Shewchuk's Grow-Expansion), in place: component i is read before slot k <= i is written.
template <int N>
void grow(Expansion<N>& e, double b) {
  SHATTER_CHECK(e.n < N);
  double q = b;
  int k = 0;
  for (int i = 0; i < e.n; ++i) {
    double err;
    two_sum(q, e.c[i], q, err);
    if (err != 0) e.c[k++] = err;
  }
  e.c[k++] = q;
  e.n = k;
}

// e + sign f, component by component of f (sign +-1: exact).
template <int N, int A, int B>
Expansion<N> sum(const Expansion<A>& e, const Expansion<B>& f, double sign = 1) {
  static_assert(N >= A + B);
  Expansion<N> r;
  std::copy(e.c.begin(), e.c.begin() + e.n, r.c.begin());
  r.n = e.n;
  for (int i = 0; i < f.n; ++i) grow(r, sign * f.c[i]);
  return r;
}

template <int N, int A, int B>
Expansion<N> product(const Expansion<A>& e, const Expansion<B>& f) {
  static_assert(N >= 2 * A * B);
  Expansion<N> r;
  for (int j = 0; j < f.n; ++j)
    for (int i = 0; i < e.n; ++i) {
      const double x = e.c[i], y = f.c[j];
      const double p = x * y;
      grow(r, std::fma(x, y, -p));  // x y = p + fma's remainder, exactly
      grow(r, p);
    }
  return r;
}

Expansion<2> exact_diff(double a, double b) {
  Expansion<2> e;
  double d, err;
  two_sum(a, -b, d, err);
  if (err != 0) e.c[e.n++] = err;
  e.c[e.n++] = d;
  return e;
}

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 u = b - a, v = c - a, w = d - a;
  const double det = u.dot(v.cross(w));
  const double permanent = std::abs(u.x()) * (std::abs(v.y() * w.z()) + std::abs(v.z() * w.y())) +
                           std::abs(u.y()) * (std::abs(v.x() * w.z()) + std::abs(v.z() * w.x())) +
                           std::abs(u.z()) * (std::abs(v.x() * w.y()) + std::abs(v.y() * w.x()));
  const double bound = 1e-15 * permanent;  // > (7 + 56 eps) eps * permanent
  if (det > bound) return 1;
  if (det < -bound) return -1;
  std::array<Expansion<2>, 3> eu, ev, ew;
  for (int k = 0; k < 3; ++k)
    eu[k] = exact_diff(b[k], a[k]), ev[k] = exact_diff(c[k], a[k]), ew[k] = exact_diff(d[k], a[k]);
  // (v x w) by components, then u . (v x w): at most 16 and 3 x 64 components.
  const auto cross = [&](int i, int j) { return sum<16>(product<8>(ev[i], ew[j]), product<8>(ev[j], ew[i]), -1); };
  const Expansion<16> cx = cross(1, 2), cy = cross(2, 0), cz = cross(0, 1);
  const Expansion<192> e = sum<192>(sum<128>(product<64>(eu[0], cx), product<64>(eu[1], cy)), product<64>(eu[2], cz));
  for (int i = e.n - 1; i >= 0; --i)  // most significant first
    if (e.c[i] != 0) return e.c[i] > 0 ? 1 : -1;
  return 0;
}

// Stage 1: the triangle hull.
class TriangleHull {
 public:
  TriangleHull(std::span<const Vec3> points, double tol) : p_(points), tol_(tol) {}

  Result<void> build() {
    SHATTER_TRY(simplex, initial_simplex());
    next_point_.assign(p_.size(), -1);
    const std::array<Index, 4>& s = *simplex;
    // Faces of the positive tet s (each opposite one corner, outward).
    constexpr std::array<std::array<int, 3>, 4> kFaces = {{{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}};
    for (const auto& f : kFaces) add_tri(s[f[0]], s[f[1]], s[f[2]]);
    for (Index t = 0; t < 4; ++t)
      for (int i = 0; i < 3; ++i) {
        const Index a = tris_[t].v[i], b = tris_[t].v[(i + 1) % 3];
        for (Index u = 0; u < 4; ++u)
          if (u != t && edge_index(tris_[u].v, b, a) >= 0) tris_[t].adj[i] = u;
      }
    std::vector<Index> all;
    for (Index i = 0; i < static_cast<Index>(p_.size()); ++i)
      if (i != s[0] && i != s[1] && i != s[2] && i != s[3]) all.push_back(i);
    assign(all, 0, 4);
    std::vector<Index> work = {3, 2, 1, 0};
    while (!work.empty()) {
      const Index t = work.back();
      work.pop_back();
      if (!tris_[t].alive || tris_[t].outside < 0) continue;
      add_point(t, work);
    }
    return {};
  }

  const std::vector<Tri>& triangles() const { return tris_; }

 private:
  double dist(const Tri& t, Index q) const { return t.normal.dot(p_[q]) - t.offset; }
  // Whether q is strictly above triangle t's plane (exact).
  bool visible(Index t, Index q) const {
    const auto& v = tris_[t].v;
    return orient3d(p_[v[0]], p_[v[1]], p_[v[2]], p_[q]) > 0;
  }

  Index add_tri(Index a, Index b, Index c) {
    Tri t;
    t.v = {a, b, c};
    const Vec3 n = area_vector2(p_[a], p_[b], p_[c]);
    const double len = n.norm();
    t.normal = len > 0 ? Vec3(n / len) : Vec3::UnitX();
    t.offset = t.normal.dot((p_[a] + p_[b] + p_[c]) / 3.0);
    tris_.push_back(t);
    return static_cast<Index>(tris_.size()) - 1;
  }

  // Each point goes to the first triangle of [begin, end) it is more than the tolerance above (and
  // above exactly: a sliver's plane may be off by more than the tolerance far from it); the others
  // are inside the hull (within the tolerance) and dropped.
  void assign(const std::vector<Index>& pts, Index begin, Index end) {
    for (Index q : pts)
      for (Index t = begin; t < end; ++t)
        if (dist(tris_[t], q) > 0.5 * tol_ && visible(t, q)) {
          next_point_[q] = tris_[t].outside;
          tris_[t].outside = q;
          break;
        }
  }

  Result<std::array<Index, 4>> initial_simplex() const {
    const auto n = static_cast<Index>(p_.size());
    // The two extreme points along the axis of largest extent.
    Index i0 = 0, i1 = 0;
    double best = -1;
    for (int axis = 0; axis < 3; ++axis) {
      Index lo = 0, hi = 0;
      for (Index i = 1; i < n; ++i) {
        if (p_[i][axis] < p_[lo][axis]) lo = i;
        if (p_[i][axis] > p_[hi][axis]) hi = i;
      }
      const double e = p_[hi][axis] - p_[lo][axis];
      if (e > best) best = e, i0 = lo, i1 = hi;
    }
    if ((p_[i1] - p_[i0]).norm() <= tol_)
      return make_error("convex hull: all points coincide (within the tolerance " + std::to_string(tol_) + ")");
    // The point farthest from the line i0-i1.
    const Vec3 dir = (p_[i1] - p_[i0]).normalized();
    Index i2 = -1;
    best = -1;
    for (Index i = 0; i < n; ++i) {
      const double d = dir.cross(p_[i] - p_[i0]).norm();
      if (d > best) best = d, i2 = i;
    }
    if (best <= tol_) return make_error("convex hull: the points are collinear (within the tolerance)");
    // The point farthest from the plane i0-i1-i2.
    const Vec3 normal = (p_[i1] - p_[i0]).cross(p_[i2] - p_[i0]).normalized();
    Index i3 = -1;
    best = -1;
    for (Index i = 0; i < n; ++i) {
      const double d = std::abs(normal.dot(p_[i] - p_[i0]));
      if (d > best) best = d, i3 = i;
    }
    if (best <= tol_) return make_error("convex hull: the points are coplanar (within the tolerance)");
    if (normal.dot(p_[i3] - p_[i0]) < 0) std::swap(i1, i2);  // positive orientation
    return std::array<Index, 4>{i0, i1, i2, i3};
  }

  // Add the farthest outside point of triangle t.
  void add_point(Index t, std::vector<Index>& work) {
    Index eye = -1;
    double far = -1;
    for (Index q = tris_[t].outside; q >= 0; q = next_point_[q]) {
      const double d = dist(tris_[t], q);
      if (d > far) far = d, eye = q;
    }
    if (!find_horizon(t, eye)) {
      // The visible region's border is not one simple loop (not expected with exact visibility;
      // a safety net): give up this point rather than make a broken mesh.
      for (Index v : visible_) tris_[v].visible = false;
      Index* link = &tris_[t].outside;
      while (*link != eye) link = &next_point_[*link];
      *link = next_point_[eye];
      work.push_back(t);
      return;
    }
    // One new triangle per horizon edge (a, b, eye), linked in a fan around the eye.
    const auto first = static_cast<Index>(tris_.size());
    const auto h = static_cast<Index>(horizon_.size());
    for (Index j = 0; j < h; ++j) {
      const auto [f, i] = horizon_[static_cast<std::size_t>(j)];
      const Index a = tris_[f].v[i], b = tris_[f].v[(i + 1) % 3], across = tris_[f].adj[i];
      const Index nt = add_tri(a, b, eye);
      tris_[nt].adj = {across, first + (j + 1) % h, first + (j + h - 1) % h};
      tris_[across].adj[edge_index(tris_[across].v, b, a)] = nt;
    }
    // The outside points of the removed triangles go to the new ones (a point outside the new hull
    // that was above a removed triangle is above a new one: Barber et al., section 3).
    moved_.clear();
    for (Index v : visible_) {
      tris_[v].alive = false;
      for (Index q = tris_[v].outside; q >= 0; q = next_point_[q])
        if (q != eye) moved_.push_back(q);
    }
    assign(moved_, first, first + h);
    for (Index j = h - 1; j >= 0; --j)
      if (tris_[first + j].outside >= 0) work.push_back(first + j);
  }

  // Depth-first growth of the region of triangles the eye is strictly above, from triangle t; the horizon edges come out in counter-clockwise order. False when they do not
  // form one simple loop.
  bool find_horizon(Index t, Index eye) {
    visible_.clear();
    horizon_.clear();
    stack_.clear();
    tris_[t].visible = true;
    visible_.push_back(t);
    stack_.push_back({t, 0, 3, 0});
    while (!stack_.empty()) {
      Frame& top = stack_.back();
      if (top.k == top.count) {
        stack_.pop_back();
        continue;
      }
      const Index tri = top.tri;
      const int i = (top.first + top.k++) % 3;
      const Index nb = tris_[tri].adj[i];
      if (tris_[nb].visible) continue;
      if (visible(nb, eye)) {
        tris_[nb].visible = true;
        visible_.push_back(nb);
        const int e = edge_index(tris_[nb].v, tris_[tri].v[(i + 1) % 3], tris_[tri].v[i]);
        if (e < 0) return false;
        stack_.push_back({nb, (e + 1) % 3, 2, 0});
      } else {
        horizon_.emplace_back(tri, i);
      }
    }
    const std::size_t h = horizon_.size();
    if (h < 3) return false;
    loop_.clear();
    for (std::size_t j = 0; j < h; ++j) {
      const auto [f, i] = horizon_[j];
      const auto [g, k] = horizon_[(j + 1) % h];
      if (tris_[f].v[(i + 1) % 3] != tris_[g].v[k]) return false;
      loop_.push_back(tris_[f].v[i]);
    }
    std::sort(loop_.begin(), loop_.end());
    return std::adjacent_find(loop_.begin(), loop_.end()) == loop_.end();
  }

  std::span<const Vec3> p_;
  double tol_;
  std::vector<Tri> tris_;
  std::vector<Index> next_point_;  // outside-list links (#points)
  // Scratch of add_point.
  std::vector<Index> visible_, moved_, loop_;
  std::vector<std::pair<Index, int>> horizon_;
  struct Frame {
    Index tri;     // triangle whose edges are being walked
    int first;     // its first edge to walk
    int count, k;  // edges to walk, walked so far
  };
  std::vector<Frame> stack_;
};

// Stage 2 input: the live triangles, compacted.
struct Surface {
  std::vector<std::array<Index, 3>> v;    // input point indices
  std::vector<std::array<Index, 3>> adj;  // compacted neighbours
  std::vector<Vec3> area;                 // twice the area vector
};

Surface compact(const std::vector<Tri>& tris, std::span<const Vec3> p) {
  std::vector<Index> map(tris.size(), -1);
  Surface s;
  for (std::size_t t = 0; t < tris.size(); ++t)
    if (tris[t].alive) map[t] = static_cast<Index>(s.v.size()), s.v.push_back(tris[t].v);
  for (const Tri& tri : tris) {
    if (!tri.alive) continue;
    const auto& a = tri.adj;
    s.adj.push_back({map[a[0]], map[a[1]], map[a[2]]});
    s.area.push_back(area_vector2(p[tri.v[0]], p[tri.v[1]], p[tri.v[2]]));
  }
  return s;
}

// Disjoint sets whose root is always the lowest member (so labels do not depend on merge order).
struct Clusters {
  std::vector<Index> parent;
  explicit Clusters(Index n) : parent(static_cast<std::size_t>(n)) { std::iota(parent.begin(), parent.end(), 0); }
  Index find(Index a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  // Joins the sets of a and b; returns {kept root, absorbed root}.
  std::pair<Index, Index> unite(Index a, Index b) {
    a = find(a), b = find(b);
    if (b < a) std::swap(a, b);
    parent[b] = a;
    return {a, b};
  }
};

// Greedy clustering: adjacent triangles, flattest pairs first, join while all the cluster's vertices
// lie within a slab of width `tol` across the cluster's mean normal. Frozen triangles stay alone.
void cluster_flat(const Surface& s, std::span<const Vec3> p, double tol, const std::vector<char>& frozen,
                  Clusters& clusters) {
  const auto n = static_cast<Index>(s.v.size());
  struct Pair {
    double cosine;
    Index t;
    int i;
  };
  std::vector<Pair> pairs;
  for (Index t = 0; t < n; ++t)
    for (int i = 0; i < 3; ++i) {
      const Index u = s.adj[t][i];
      if (u > t && !frozen[t] && !frozen[u])
        pairs.push_back({s.area[t].normalized().dot(s.area[u].normalized()), t, i});
    }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    if (a.cosine != b.cosine) return a.cosine > b.cosine;
    return a.t != b.t ? a.t < b.t : a.i < b.i;
  });
  std::vector<Vec3> area = s.area;
  std::vector<std::vector<Index>> verts(static_cast<std::size_t>(n));
  for (Index t = 0; t < n; ++t) verts[t].assign(s.v[t].begin(), s.v[t].end());
  for (const Pair& pr : pairs) {
    const Index ra = clusters.find(pr.t), rb = clusters.find(s.adj[pr.t][pr.i]);
    if (ra == rb) continue;
    const Vec3 sum = area[ra] + area[rb];
    const double len = sum.norm();
    if (!(len > 0)) continue;
    const Vec3 normal = sum / len;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (Index r : {ra, rb})
      for (Index q : verts[r]) {
        const double d = normal.dot(p[q]);
        lo = std::min(lo, d), hi = std::max(hi, d);
      }
    if (hi - lo > tol) continue;
    const auto [keep, gone] = clusters.unite(ra, rb);
    area[keep] = sum;
    verts[keep].insert(verts[keep].end(), verts[gone].begin(), verts[gone].end());
    std::sort(verts[keep].begin(), verts[keep].end());
    verts[keep].erase(std::unique(verts[keep].begin(), verts[keep].end()), verts[keep].end());
    verts[gone] = {};
  }
}

// The faces of a clustering: each cluster's boundary loop (input point indices, counter-clockwise
// from outside) and the cluster's root triangle.
struct Polygons {
  std::vector<std::vector<Index>> loops;
  std::vector<Index> root;
  std::vector<std::vector<Index>> members;  // every vertex of the cluster's triangles (sets the offset)
};

// Walks every cluster's boundary. Clusters that are not bounded by one simple loop (a ring around
// another cluster, or pinched at a vertex) are listed in `bad`; returns whether there were none.
bool extract_loops(const Surface& s, Clusters& clusters, Polygons& out, std::vector<Index>& bad) {
  const auto n = static_cast<Index>(s.v.size());
  std::vector<Index> label(static_cast<std::size_t>(n));
  for (Index t = 0; t < n; ++t) label[t] = clusters.find(t);
  std::vector<char> used(static_cast<std::size_t>(3 * n), 0);
  std::vector<Index> root_face(static_cast<std::size_t>(n), -1);
  out = {};
  bad.clear();
  for (Index t = 0; t < n; ++t)
    for (int i = 0; i < 3; ++i) {
      const Index r = label[t];
      if (label[s.adj[t][i]] == r || used[3 * t + i]) continue;
      std::vector<Index> loop;
      Index ct = t;
      int ci = i;
      do {
        used[3 * ct + ci] = 1;
        loop.push_back(s.v[ct][ci]);
        // Turn about the edge's end vertex w, inside the cluster, to the next boundary edge.
        const Index w = s.v[ct][(ci + 1) % 3];
        int ne = (ci + 1) % 3;
        Index steps = 0;
        while (label[s.adj[ct][ne]] == r && ++steps <= n) {
          const Index u = s.adj[ct][ne];
          const int k = edge_index(s.v[u], s.v[ct][(ne + 1) % 3], w);
          if (k < 0) return bad.push_back(r), false;
          ct = u;
          ne = (k + 1) % 3;
        }
        ci = ne;
        if (steps > n || static_cast<Index>(loop.size()) > 3 * n) return bad.push_back(r), false;
      } while (!(ct == t && ci == i));
      std::vector<Index> sorted = loop;
      std::sort(sorted.begin(), sorted.end());
      const bool broken = std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end();
      if (root_face[r] >= 0 || broken) {
        bad.push_back(r);
        continue;
      }
      root_face[r] = static_cast<Index>(out.loops.size());
      out.loops.push_back(std::move(loop));
      out.root.push_back(r);
    }
  std::sort(bad.begin(), bad.end());
  bad.erase(std::unique(bad.begin(), bad.end()), bad.end());
  out.members.resize(out.loops.size());
  for (Index t = 0; t < n; ++t)
    if (root_face[label[t]] >= 0) {
      auto& m = out.members[root_face[label[t]]];
      m.insert(m.end(), s.v[t].begin(), s.v[t].end());
    }
  return bad.empty();
}

// Vertices that only two faces share lie on the edge between them (within the tolerance).
// Removing them would leave a face with fewer than 3 vertices only where it meets one neighbour
// along two edges: the two are then coplanar and must be one face. Those pairs (by root) are
// returned; when there are none, the vertices are removed.
std::vector<std::pair<Index, Index>> remove_edge_vertices(std::size_t num_points, Polygons& polys) {
  std::vector<Index> count(num_points, 0), other(num_points, -1);
  for (const auto& loop : polys.loops)
    for (Index q : loop) ++count[q];
  std::vector<std::pair<Index, Index>> merges;
  for (std::size_t f = 0; f < polys.loops.size(); ++f) {
    const auto& loop = polys.loops[f];
    const auto kept = std::count_if(loop.begin(), loop.end(), [&](Index q) { return count[q] != 2; });
    if (kept >= 3) continue;
    // The other face at one of the removable vertices.
    for (std::size_t g = 0; g < polys.loops.size() && merges.size() < polys.loops.size(); ++g) {
      if (g == f) continue;
      const auto& og = polys.loops[g];
      if (std::any_of(og.begin(), og.end(),
                      [&](Index q) { return count[q] == 2 && std::find(loop.begin(), loop.end(), q) != loop.end(); })) {
        merges.emplace_back(polys.root[f], polys.root[g]);
        break;
      }
    }
  }
  if (!merges.empty()) return merges;
  for (auto& loop : polys.loops)
    loop.erase(std::remove_if(loop.begin(), loop.end(), [&](Index q) { return count[q] == 2; }), loop.end());
  return merges;
}

// Vertex values along `normal` of faces a and b: whether they fit in a slab of width tol.
bool flat_along(const ConvexHull& hull, Index fa, Index fb, const Vec3& normal, double tol) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (Index f : {fa, fb}) {
    Index e = hull.faces[f].edge;
    for (std::size_t guard = 0; guard <= hull.edges.size(); ++guard) {
      const double d = normal.dot(hull.vertices[hull.edges[e].origin]);
      lo = std::min(lo, d), hi = std::max(hi, d);
      e = hull.edges[e].next;
      if (e == hull.faces[f].edge) break;
    }
  }
  return hi - lo <= tol;
}

// Adjacent faces a and b count as coplanar when the vertices of both fit in a slab of width tol
// across either face's normal.
bool coplanar(const ConvexHull& hull, Index fa, Index fb, double tol) {
  return flat_along(hull, fa, fb, hull.faces[fa].normal, tol) || flat_along(hull, fa, fb, hull.faces[fb].normal, tol);
}

// The half-edge hull of the polygons. False when the loops do not pair up into a closed surface.
bool assemble(std::span<const Vec3> p, const Polygons& polys, ConvexHull& hull) {
  hull = {};
  std::vector<Index> used;
  for (const auto& loop : polys.loops) used.insert(used.end(), loop.begin(), loop.end());
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  std::vector<Index> vertex_of(p.size(), -1);
  for (std::size_t k = 0; k < used.size(); ++k) {
    vertex_of[used[k]] = static_cast<Index>(k);
    hull.vertices.push_back(p[used[k]]);
  }
  struct Directed {
    Index a, b;  // new vertex indices
    Index slot;  // position in the face-major order
  };
  std::vector<Directed> directed;
  std::vector<Index> face_start;
  for (const auto& loop : polys.loops) {
    face_start.push_back(static_cast<Index>(directed.size()));
    for (std::size_t j = 0; j < loop.size(); ++j)
      directed.push_back(
          {vertex_of[loop[j]], vertex_of[loop[(j + 1) % loop.size()]], static_cast<Index>(directed.size())});
  }
  face_start.push_back(static_cast<Index>(directed.size()));
  if (directed.size() % 2 != 0) return false;
  std::vector<Directed> sorted = directed;
  std::sort(sorted.begin(), sorted.end(), [](const Directed& x, const Directed& y) {
    const auto kx = std::make_tuple(std::min(x.a, x.b), std::max(x.a, x.b), x.a > x.b);
    const auto ky = std::make_tuple(std::min(y.a, y.b), std::max(y.a, y.b), y.a > y.b);
    return kx < ky;
  });
  std::vector<Index> edge_of_slot(directed.size());
  for (std::size_t k = 0; k < sorted.size(); k += 2) {
    const Directed& x = sorted[k];
    const Directed& y = sorted[k + 1];
    if (x.a != y.b || x.b != y.a || x.a == x.b) return false;
    edge_of_slot[x.slot] = static_cast<Index>(k);
    edge_of_slot[y.slot] = static_cast<Index>(k + 1);
  }
  hull.edges.resize(directed.size());
  for (std::size_t f = 0; f + 1 < face_start.size(); ++f) {
    const Index begin = face_start[f], end = face_start[f + 1];
    Vec3 c = Vec3::Zero();
    for (Index s = begin; s < end; ++s) c += hull.vertices[directed[s].a];
    c /= static_cast<double>(end - begin);
    Vec3 normal = Vec3::Zero();  // Newell: the polygon's area vector, about its vertex mean
    for (Index s = begin; s < end; ++s) {
      const Index e = edge_of_slot[s];
      hull.edges[e] = {directed[s].a, edge_of_slot[s + 1 < end ? s + 1 : begin], static_cast<Index>(f)};
      normal += (hull.vertices[directed[s].a] - c).cross(hull.vertices[directed[s].b] - c);
    }
    if (!(normal.norm() > 0)) return false;
    normal.normalize();
    // The plane through the highest vertex of the face's triangles (those inside it and on its
    // edges dropped included), so every point is on or behind it within the tolerance.
    double offset = -std::numeric_limits<double>::infinity();
    for (Index q : polys.members[f]) offset = std::max(offset, normal.dot(p[q]));
    hull.faces.push_back({normal, offset, edge_of_slot[begin]});
  }
  return true;
}

// Volume, centroid, radius and bounds: exact integrals over the fan of each face (from its first
// vertex) and a reference point inside.
void finish(ConvexHull& hull) {
  Vec3 ref = Vec3::Zero();
  for (const Vec3& v : hull.vertices) ref += v;
  ref /= static_cast<double>(hull.vertices.size());
  double volume6 = 0;
  Vec3 moment = Vec3::Zero();
  for (const HullFace& face : hull.faces) {
    const Vec3& a = hull.vertices[hull.edges[face.edge].origin];
    for (Index e = hull.edges[face.edge].next; hull.edges[e].next != face.edge; e = hull.edges[e].next) {
      const Vec3& b = hull.vertices[hull.edges[e].origin];
      const Vec3& c = hull.vertices[hull.edges[hull.edges[e].next].origin];
      const double v6 = (a - ref).dot((b - ref).cross(c - ref));
      volume6 += v6;
      moment += v6 * (a + b + c - 3 * ref) / 4.0;
    }
  }
  hull.volume = volume6 / 6.0;
  hull.centroid = ref + moment / volume6;
  hull.radius = 0;
  hull.bounds = {};
  for (const Vec3& v : hull.vertices) {
    hull.radius = std::max(hull.radius, (v - hull.centroid).norm());
    hull.bounds.extend(v);
  }
}

}  // namespace

Index ConvexHull::support(const Vec3& d) const {
  Index best = 0;
  double best_dot = -std::numeric_limits<double>::infinity();
  for (Index i = 0; i < static_cast<Index>(vertices.size()); ++i) {
    const double s = vertices[i].dot(d);
    if (s > best_dot) best_dot = s, best = i;
  }
  return best;
}

ConvexHull translated_hull(ConvexHull hull, const Vec3& shift) {
  for (Vec3& v : hull.vertices) v += shift;
  // A face plane moves by normal . shift; its own vertices are taken too, so that each stays on or
  // behind its plane after the round-off of both.
  for (HullFace& face : hull.faces) {
    double offset = face.offset + face.normal.dot(shift);
    Index e = face.edge;
    do {
      offset = std::max(offset, face.normal.dot(hull.vertices[hull.edges[e].origin]));
      e = hull.edges[e].next;
    } while (e != face.edge);
    face.offset = offset;
  }
  finish(hull);
  return hull;
}

namespace {

// Checks the input; the tolerance HullOptions asks for, resolved for these points, m.
Result<double> hull_tolerance(std::span<const Vec3> points, const HullOptions& options) {
  if (points.size() < 4)
    return make_error("convex hull: needs at least 4 points, got " + std::to_string(points.size()));
  if (points.size() > static_cast<std::size_t>(std::numeric_limits<Index>::max() / 8))
    return make_error("convex hull: too many points");
  Vec3 lo = points[0], hi = points[0];
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) return make_error("convex hull: point " + std::to_string(i) + " is not finite");
    lo = lo.cwiseMin(points[i]), hi = hi.cwiseMax(points[i]);
  }
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance))
    return make_error("convex hull: the tolerance must be finite and >= 0");
  const double magnitude = lo.cwiseAbs().cwiseMax(hi.cwiseAbs()).sum();
  return options.tolerance > 0 ? options.tolerance : 1e-9 * (hi - lo).maxCoeff() + 8 * kEps * magnitude;
}

}  // namespace

Result<double> convex_hull_volume(std::span<const Vec3> points, const HullOptions& options) {
  SHATTER_TRY(tol, hull_tolerance(points, options));
  TriangleHull tri_hull(points, *tol);
  SHATTER_TRY(built, tri_hull.build());
  // Sum of the signed tets from a corner of the initial simplex to each triangle (the surface is
  // closed, so the sum does not depend on that point).
  double volume = 0;
  const Vec3& o = points[tri_hull.triangles().front().v[0]];
  for (const auto& tri : tri_hull.triangles())
    if (tri.alive) {
      const auto& v = tri.v;
      volume += (points[v[0]] - o).dot((points[v[1]] - o).cross(points[v[2]] - o));
    }
  return volume / 6;
}

Result<ConvexHull> build_convex_hull(std::span<const Vec3> points, const HullOptions& options) {
  SHATTER_TRY(tolerance, hull_tolerance(points, options));
  const double tol = *tolerance;

  TriangleHull tri_hull(points, tol);
  SHATTER_TRY(built, tri_hull.build());
  const Surface s = compact(tri_hull.triangles(), points);
  const auto n = static_cast<Index>(s.v.size());

  // Cluster, extract the faces and merge faces still coplanar with a neighbour. A cluster that does
  // not come out as one simple polygon is broken up into triangles kept apart (round-off corner
  // cases), and the clustering starts again.
  std::vector<char> frozen(static_cast<std::size_t>(n), 0);
  std::vector<Index> bad;
  ConvexHull hull;
  for (;;) {
    Clusters clusters(n);
    cluster_flat(s, points, tol, frozen, clusters);
    bool restart = false;
    for (;;) {
      Polygons polys;
      if (!extract_loops(s, clusters, polys, bad)) {
        std::size_t newly = 0;
        for (Index t = 0; t < n; ++t)
          if (!frozen[t] && std::binary_search(bad.begin(), bad.end(), clusters.find(t))) frozen[t] = 1, ++newly;
        if (newly == 0) return make_error("convex hull: inconsistent surface (round-off); try a larger tolerance");
        restart = true;
        break;
      }
      const auto merges = remove_edge_vertices(points.size(), polys);
      for (const auto& [a, b] : merges) clusters.unite(a, b);
      if (!merges.empty()) continue;
      if (!assemble(points, polys, hull))
        return make_error("convex hull: inconsistent surface (round-off); try a larger tolerance");
      // Each face joins at most one neighbour per pass: coplanarity is not transitive (a ~ b and
      // b ~ c with a and c apart by more than the tolerance), so a chain is re-checked on the
      // merged faces next pass.
      bool merged = false;
      std::vector<char> joined(hull.faces.size(), 0);
      for (std::size_t k = 0; k < hull.edges.size(); k += 2) {
        const Index fa = hull.edges[k].face, fb = hull.edges[k + 1].face;
        const Index ra = polys.root[fa], rb = polys.root[fb];
        if (joined[fa] || joined[fb] || frozen[ra] || frozen[rb] || clusters.find(ra) == clusters.find(rb)) continue;
        if (coplanar(hull, fa, fb, tol)) clusters.unite(ra, rb), merged = true, joined[fa] = joined[fb] = 1;
      }
      if (!merged) break;
    }
    if (!restart) break;
  }
  finish(hull);
  hull.tolerance = tol;
  return hull;
}

std::string check_convex_hull(const ConvexHull& hull, double tolerance) {
  std::ostringstream err;
  const auto nv = static_cast<Index>(hull.vertices.size());
  const auto ne = static_cast<Index>(hull.edges.size());
  const auto nf = static_cast<Index>(hull.faces.size());
  if (nv < 4 || nf < 4 || ne < 12 || ne % 2 != 0) {
    err << "too small or odd: " << nv << " vertices, " << ne << " half-edges, " << nf << " faces";
    return err.str();
  }
  for (Index e = 0; e < ne; ++e) {
    const HullHalfEdge& h = hull.edges[e];
    if (h.origin < 0 || h.origin >= nv || h.next < 0 || h.next >= ne || h.face < 0 || h.face >= nf) {
      err << "half-edge " << e << " has an index out of range";
      return err.str();
    }
  }
  for (Index e = 0; e < ne; ++e) {
    const HullHalfEdge& h = hull.edges[e];
    const HullHalfEdge& t = hull.edges[ConvexHull::twin(e)];
    if (t.origin != hull.edges[h.next].origin || h.origin == t.origin) {
      err << "half-edge " << e << " and its twin do not join the same two vertices in opposite directions";
      return err.str();
    }
    if (t.face == h.face) {
      err << "half-edge " << e << " has the same face on both sides";
      return err.str();
    }
  }
  std::vector<char> seen(static_cast<std::size_t>(ne), 0), vertex_used(static_cast<std::size_t>(nv), 0);
  for (Index f = 0; f < nf; ++f) {
    const HullFace& face = hull.faces[f];
    if (face.edge < 0 || face.edge >= ne || hull.edges[face.edge].face != f) {
      err << "face " << f << ": its edge is not on it";
      return err.str();
    }
    if (std::abs(face.normal.norm() - 1) > 1e-9) {
      err << "face " << f << ": normal not unit";
      return err.str();
    }
    Index count = 0, e = face.edge;
    do {
      if (hull.edges[e].face != f || seen[e]) {
        err << "face " << f << ": its loop passes half-edge " << e << " of another face or twice";
        return err.str();
      }
      seen[e] = 1;
      vertex_used[hull.edges[e].origin] = 1;
      // Its own vertices on its plane: a slab of the tolerance below the highest (twice that
      // allowed for round-off in the normal).
      const double below = face.offset - face.normal.dot(hull.vertices[hull.edges[e].origin]);
      if (below > 2 * tolerance) {
        err << "face " << f << ": vertex " << hull.edges[e].origin << " is " << below << " below its plane";
        return err.str();
      }
      e = hull.edges[e].next;
    } while (e != face.edge && ++count <= ne);
    if (count < 2 || count > ne) {
      err << "face " << f << ": loop of " << count + 1 << " edges";
      return err.str();
    }
  }
  for (Index e = 0; e < ne; ++e)
    if (!seen[e]) {
      err << "half-edge " << e << " is on no face loop";
      return err.str();
    }
  for (Index v = 0; v < nv; ++v)
    if (!vertex_used[v]) {
      err << "vertex " << v << " is on no edge";
      return err.str();
    }
  if (nv - ne / 2 + nf != 2) {
    err << "Euler characteristic V - E + F = " << nv - ne / 2 + nf << ", not 2";
    return err.str();
  }
  for (Index f = 0; f < nf; ++f)
    for (Index v = 0; v < nv; ++v) {
      const double d = hull.faces[f].normal.dot(hull.vertices[v]) - hull.faces[f].offset;
      if (d > tolerance) {
        err << "vertex " << v << " is " << d << " above face " << f;
        return err.str();
      }
    }
  for (Index e = 0; e < ne; e += 2)
    if (coplanar(hull, hull.edges[e].face, hull.edges[e + 1].face, tolerance)) {
      err << "faces " << hull.edges[e].face << " and " << hull.edges[e + 1].face << " are coplanar";
      return err.str();
    }
  return {};
}

}  // namespace shatter
