// Interior coarsening by edge collapse; see coarsen.h.
#include "shatter/meshing/coarsen.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <tuple>
#include <vector>

#include "shatter/mesh/quality.h"

namespace shatter {
namespace {

using Face = std::array<Index, 3>;
using Edge = std::array<Index, 2>;

Face sorted_face(Index a, Index b, Index c) {
  Face f{a, b, c};
  std::sort(f.begin(), f.end());
  return f;
}

struct Collapser {
  TetMesh& mesh;
  const CoarsenDef& def;
  double cos_min = std::cos(def.min_dihedral_deg * std::numbers::pi / 180.0);  // cosine of the smallest angle allowed
  double cos_max = std::cos(def.max_dihedral_deg * std::numbers::pi / 180.0);
  std::vector<std::vector<Index>> star;  // node -> live tets containing it
  std::vector<char> tet_alive, boundary, touched;
  std::vector<double> node_size;  // wanted size at each node, or -1 when not yet evaluated

  double size_at(Index v) {
    double& s = node_size[static_cast<std::size_t>(v)];
    if (s < 0) s = def.size(mesh.positions[static_cast<std::size_t>(v)]);
    return s;
  }

  void build() {
    const Index n = mesh.num_nodes();
    star.assign(static_cast<std::size_t>(n), {});
    for (Index e = 0; e < mesh.num_tets(); ++e)
      for (Index v : mesh.tets[static_cast<std::size_t>(e)]) star[static_cast<std::size_t>(v)].push_back(e);
    tet_alive.assign(mesh.tets.size(), 1);
    node_size.assign(static_cast<std::size_t>(n), -1.0);
    // Boundary nodes: on a face that only one tet has.
    std::vector<Face> faces;
    faces.reserve(mesh.tets.size() * 4);
    for (const TetIndices& t : mesh.tets) {
      faces.push_back(sorted_face(t[1], t[2], t[3]));
      faces.push_back(sorted_face(t[0], t[2], t[3]));
      faces.push_back(sorted_face(t[0], t[1], t[3]));
      faces.push_back(sorted_face(t[0], t[1], t[2]));
    }
    std::sort(faces.begin(), faces.end());
    boundary.assign(static_cast<std::size_t>(n), 0);
    for (std::size_t i = 0; i < faces.size();) {
      std::size_t j = i;
      while (j < faces.size() && faces[j] == faces[i]) ++j;
      if (j - i == 1)
        for (Index v : faces[i]) boundary[static_cast<std::size_t>(v)] = 1;
      i = j;
    }
  }

  [[nodiscard]] static bool contains(const TetIndices& t, Index v) {
    return std::find(t.begin(), t.end(), v) != t.end();
  }

  // Lk(a) and Lk(b) may only share what Lk(ab) has (Dey et al. 1999): otherwise the collapse
  // would glue distinct simplices together.
  // Scratch for link_condition (reused: the collapser runs on one thread).
  mutable std::vector<Index> va, vb, vab, common;
  mutable std::vector<Edge> ea, eb, eab, common_edges;
  mutable std::vector<Face> fa, fb, common_faces;

  [[nodiscard]] bool link_condition(Index a, Index b) const {
    for (auto* v : {&va, &vb, &vab, &common}) v->clear();
    for (auto* v : {&ea, &eb, &eab, &common_edges}) v->clear();
    for (auto* v : {&fa, &fb, &common_faces}) v->clear();
    auto add_link = [&](Index x, Index other, std::vector<Index>& verts, std::vector<Edge>& edges,
                        std::vector<Face>& tris) {
      for (Index e : star[static_cast<std::size_t>(x)]) {
        const TetIndices& t = mesh.tets[static_cast<std::size_t>(e)];
        std::array<Index, 3> o{};
        int k = 0;
        for (Index v : t)
          if (v != x) o[static_cast<std::size_t>(k++)] = v;
        for (Index v : o)
          if (v != other) verts.push_back(v);
        if (contains(t, other)) continue;  // simplices with the other end are not in both links
        tris.push_back(sorted_face(o[0], o[1], o[2]));
        for (int i = 0; i < 3; ++i)
          for (int j = i + 1; j < 3; ++j)
            edges.push_back({std::min(o[static_cast<std::size_t>(i)], o[static_cast<std::size_t>(j)]),
                             std::max(o[static_cast<std::size_t>(i)], o[static_cast<std::size_t>(j)])});
      }
    };
    add_link(a, b, va, ea, fa);
    add_link(b, a, vb, eb, fb);
    for (Index e : star[static_cast<std::size_t>(a)]) {
      const TetIndices& t = mesh.tets[static_cast<std::size_t>(e)];
      if (!contains(t, b)) continue;
      std::array<Index, 2> o{};
      int k = 0;
      for (Index v : t)
        if (v != a && v != b) o[static_cast<std::size_t>(k++)] = v;
      vab.push_back(o[0]);
      vab.push_back(o[1]);
      eab.push_back({std::min(o[0], o[1]), std::max(o[0], o[1])});
    }
    auto uniq = [](auto& v) {
      std::sort(v.begin(), v.end());
      v.erase(std::unique(v.begin(), v.end()), v.end());
    };
    uniq(va), uniq(vb), uniq(vab), uniq(ea), uniq(eb), uniq(eab), uniq(fa), uniq(fb);
    std::set_intersection(va.begin(), va.end(), vb.begin(), vb.end(), std::back_inserter(common));
    if (common != vab) return false;
    std::set_intersection(ea.begin(), ea.end(), eb.begin(), eb.end(), std::back_inserter(common_edges));
    for (const Edge& e : common_edges)
      if (!std::binary_search(eab.begin(), eab.end(), e)) return false;
    std::set_intersection(fa.begin(), fa.end(), fb.begin(), fb.end(), std::back_inserter(common_faces));
    return common_faces.empty();
  }

  // Extremes of the dihedral-angle cosines over the tets of star(a) that do not contain b (b = -1:
  // all), with a placed at xa: {largest cosine (smallest angle), smallest cosine (largest angle)};
  // nullopt when one of them is not positively oriented.
  // With early_out, stops (returning nullopt) at the first angle outside the bounds.
  [[nodiscard]] std::optional<std::pair<double, double>> star_cosines(Index a, const Vec3& xa, Index b,
                                                                      bool early_out = false) const {
    double cmax = -1, cmin = 1;
    for (Index e : star[static_cast<std::size_t>(a)]) {
      const TetIndices& t = mesh.tets[static_cast<std::size_t>(e)];
      if (b >= 0 && contains(t, b)) continue;
      std::array<Vec3, 4> x;
      for (int k = 0; k < 4; ++k) {
        const Index v = t[static_cast<std::size_t>(k)];
        x[static_cast<std::size_t>(k)] = v == a ? xa : mesh.positions[static_cast<std::size_t>(v)];
      }
      if (!(signed_volume(x[0], x[1], x[2], x[3]) > 0)) return std::nullopt;
      Mat34 m;
      for (int k = 0; k < 4; ++k) m.col(k) = x[static_cast<std::size_t>(k)];
      for (double c : dihedral_cosines(m)) {
        cmax = std::max(cmax, c);
        cmin = std::min(cmin, c);
        if (early_out && !(c <= cos_min && c >= cos_max)) return std::nullopt;
      }
    }
    return std::pair{cmax, cmin};
  }

  [[nodiscard]] bool in_bounds(const std::optional<std::pair<double, double>>& c) const {
    return c && c->first <= cos_min && c->second >= cos_max;
  }

  // Every tet of star(a) without b, with a moved onto b: positive and inside the angle bounds.
  [[nodiscard]] bool shapes_ok(Index a, Index b) const {
    return in_bounds(star_cosines(a, mesh.positions[static_cast<std::size_t>(b)], b, true));
  }

  // Move interior node v to the centre of its neighbours when that keeps its tets in bounds and
  // makes neither its smallest nor its largest dihedral angle worse (lets later collapses pass the
  // shape test). Returns whether it moved.
  bool smooth(Index v) {
    if (boundary[static_cast<std::size_t>(v)] || star[static_cast<std::size_t>(v)].empty()) return false;
    Vec3 c = Vec3::Zero();
    int n = 0;
    for (Index e : star[static_cast<std::size_t>(v)])
      for (Index w : mesh.tets[static_cast<std::size_t>(e)])
        if (w != v) {
          c += mesh.positions[static_cast<std::size_t>(w)];
          ++n;
        }
    c /= n;  // neighbours weighted by how many tets they share with v
    const auto now = star_cosines(v, mesh.positions[static_cast<std::size_t>(v)], -1);
    const auto moved = star_cosines(v, c, -1);
    if (!now || !in_bounds(moved) || moved->first > now->first || moved->second < now->second) return false;
    mesh.positions[static_cast<std::size_t>(v)] = c;
    node_size[static_cast<std::size_t>(v)] = -1;
    return true;
  }

  void collapse(Index a, Index b) {
    std::vector<Index>& sb = star[static_cast<std::size_t>(b)];
    for (Index e : star[static_cast<std::size_t>(a)]) {
      TetIndices& t = mesh.tets[static_cast<std::size_t>(e)];
      for (Index v : t) touched[static_cast<std::size_t>(v)] = 1;
      if (contains(t, b)) {  // the tets around edge ab vanish
        tet_alive[static_cast<std::size_t>(e)] = 0;
        for (Index v : t) {
          if (v == a) continue;
          auto& s = star[static_cast<std::size_t>(v)];
          s.erase(std::find(s.begin(), s.end(), e));
        }
      } else {
        std::replace(t.begin(), t.end(), a, b);
        sb.insert(std::lower_bound(sb.begin(), sb.end(), e), e);
      }
    }
    star[static_cast<std::size_t>(a)].clear();
  }

  [[nodiscard]] bool try_collapse(Index a, Index b) {
    if (boundary[static_cast<std::size_t>(a)]) return false;
    if (!shapes_ok(a, b) || !link_condition(a, b)) return false;  // the cheaper test first
    collapse(a, b);
    return true;
  }

  // One pass: candidate edges with an end in `active` (every node on the first pass; afterwards the
  // nodes whose stars changed, since a refused collapse only changes its verdict when a star it
  // looks at changes), short for the sizes at their ends, tried shortest first (ties by node ids).
  // Each try checks the mesh as the earlier collapses of the pass left it (an edge that no longer
  // exists is skipped). Returns the nodes whose stars changed.
  std::vector<char> pass(const std::vector<char>& active, int& done) {
    std::vector<std::tuple<double, Index, Index>> shortlist;
    std::vector<Index> nbr;
    for (std::size_t v = 0; v < star.size(); ++v) {
      if (!active[v]) continue;
      nbr.clear();
      for (Index e : star[v])
        for (Index w : mesh.tets[static_cast<std::size_t>(e)]) {
          if (w == static_cast<Index>(v)) continue;
          if (active[static_cast<std::size_t>(w)] && w < static_cast<Index>(v)) continue;  // seen from w
          if (boundary[v] && boundary[static_cast<std::size_t>(w)]) continue;
          nbr.push_back(w);
        }
      std::sort(nbr.begin(), nbr.end());
      nbr.erase(std::unique(nbr.begin(), nbr.end()), nbr.end());
      for (Index w : nbr) {
        const Vec3& pa = mesh.positions[v];
        const Vec3& pb = mesh.positions[static_cast<std::size_t>(w)];
        const double len = (pa - pb).norm();
        if (len < def.collapse_ratio * 0.5 * (size_at(static_cast<Index>(v)) + size_at(w)))
          shortlist.emplace_back(len, std::min(static_cast<Index>(v), w), std::max(static_cast<Index>(v), w));
      }
    }
    std::sort(shortlist.begin(), shortlist.end());
    touched.assign(mesh.positions.size(), 0);
    done = 0;
    for (const auto& [len, a, b] : shortlist) {
      const auto& sa = star[static_cast<std::size_t>(a)];
      if (sa.empty() || star[static_cast<std::size_t>(b)].empty()) continue;  // collapsed away
      if (std::none_of(sa.begin(), sa.end(),
                       [&](Index e) { return contains(mesh.tets[static_cast<std::size_t>(e)], b); }))
        continue;  // no longer an edge
      if (try_collapse(a, b) || try_collapse(b, a)) ++done;
    }
    return touched;
  }
};

}  // namespace

Result<CoarsenReport> coarsen_interior(TetMesh& mesh, const CoarsenDef& def) {
  if (!def.size) return field_error("size", "no sizing function given");
  if (!(def.collapse_ratio > 0 && def.collapse_ratio < 1))
    return field_error("collapse_ratio", "expected a number in (0, 1)");
  CoarsenReport report;
  report.tets_before = mesh.num_tets();
  Collapser c{mesh, def};
  c.build();
  std::vector<char> active(mesh.positions.size(), 1);
  for (int p = 0; p < def.max_passes; ++p) {
    int done = 0;
    active = c.pass(active, done);
    // Smooth the nodes the collapses touched, in node order (deterministic); a moved node's
    // neighbours see new shapes, so they are tried again in the next pass too.
    std::vector<char> moved(active.size(), 0);
    for (std::size_t v = 0; v < active.size(); ++v)
      if (active[v] && c.smooth(static_cast<Index>(v))) {
        ++report.smoothed;
        moved[v] = 1;
      }
    for (std::size_t v = 0; v < moved.size(); ++v)
      if (moved[v])
        for (Index e : c.star[v])
          for (Index w : mesh.tets[static_cast<std::size_t>(e)]) active[static_cast<std::size_t>(w)] = 1;
    report.collapses += done;
    report.passes = p + 1;
    if (done == 0) break;
  }
  // Compact: surviving tets in order, used nodes in order.
  std::vector<TetIndices> tets;
  tets.reserve(mesh.tets.size());
  for (std::size_t e = 0; e < mesh.tets.size(); ++e)
    if (c.tet_alive[e]) tets.push_back(mesh.tets[e]);
  std::vector<Index> node_of(mesh.positions.size(), -1);
  for (const TetIndices& t : tets)
    for (Index v : t) node_of[static_cast<std::size_t>(v)] = 0;
  std::vector<Vec3> positions;
  for (std::size_t v = 0; v < node_of.size(); ++v)
    if (node_of[v] == 0) {
      node_of[v] = static_cast<Index>(positions.size());
      positions.push_back(mesh.positions[v]);
    }
  for (TetIndices& t : tets)
    for (Index& v : t) v = node_of[static_cast<std::size_t>(v)];
  TetMesh out;
  out.positions = std::move(positions);
  out.tets = std::move(tets);
  mesh = std::move(out);
  report.tets_after = mesh.num_tets();
  return report;
}

}  // namespace shatter
