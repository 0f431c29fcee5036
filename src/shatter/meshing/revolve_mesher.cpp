// Structured meshes of surfaces of revolution: triangulated profile swept into prisms.
#include "shatter/meshing/revolve_mesher.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <utility>

#include "shatter/mesh/validate.h"

namespace shatter {
namespace {

double cross2(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

// > 0 when d is strictly inside the circumcircle of the counter-clockwise triangle (a, b, c).
double incircle(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const Vec2 ad = a - d, bd = b - d, cd = c - d;
  const double al = ad.squaredNorm(), bl = bd.squaredNorm(), cl = cd.squaredNorm();
  return ad.x() * (bd.y() * cl - cd.y() * bl) - ad.y() * (bd.x() * cl - cd.x() * bl) +
         al * (bd.x() * cd.y() - cd.x() * bd.y());
}

// 4 sqrt(3) area / sum of squared edges: 1 for the equilateral triangle.
double triangle_quality(const Vec2& a, const Vec2& b, const Vec2& c) {
  const double s = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  return s > 0 ? 4.0 * std::sqrt(3.0) * 0.5 * cross2(a, b, c) / s : 0.0;
}

// The polygon resampled so that no edge is longer than h (original corners kept); r snapped to 0
// within rounding of the axis. Repeated consecutive points dropped.
std::vector<Vec2> resample(const std::vector<Vec2>& poly, double h) {
  double scale = 0;
  for (const Vec2& p : poly) scale = std::max(scale, p.cwiseAbs().maxCoeff());
  std::vector<Vec2> out;
  const std::size_t n = poly.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 a = poly[i], b = poly[(i + 1) % n];
    const double len = (b - a).norm();
    if (!(len > 1e-12 * scale)) continue;
    const auto pieces = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(len / h - 1e-9)));
    for (std::int64_t p = 0; p < pieces; ++p) {
      Vec2 q = p == 0 ? a : a + (b - a) * (static_cast<double>(p) / static_cast<double>(pieces));
      if (q.x() < 1e-12 * scale) q.x() = 0;
      out.push_back(q);
    }
  }
  return out;
}

struct Sweep {
  std::vector<Vec2> points;
  std::vector<std::array<Index, 3>> triangles;
  int segments = 0;
  [[nodiscard]] std::int64_t tets() const {
    std::int64_t t = 0;
    for (const auto& tri : triangles) {
      int k = 0;
      for (Index v : tri) k += points[v].x() == 0 ? 1 : 0;
      t += 3 - k;
    }
    return t * segments;
  }
};

Result<Sweep> plan(const std::vector<Vec2>& profile, double h, const RevolveDef& def) {
  Sweep s;
  s.points = resample(profile, h);
  auto tris = triangulate_polygon(s.points);
  if (!tris) return std::move(tris.error());
  s.triangles = std::move(*tris);
  double rmax = 0;
  for (const Vec2& p : profile) rmax = std::max(rmax, p.x());
  s.segments = def.segments > 0
                   ? def.segments
                   : std::max(def.min_segments, static_cast<int>(std::lround(2.0 * std::numbers::pi * rmax / h)));
  return s;
}

}  // namespace

std::optional<RevolvedShape> revolved_shape(const Sdf& sdf) {
  if (sdf.empty()) return std::nullopt;
  if (sdf.kind() == Sdf::Kind::revolution) return RevolvedShape{sdf.polygon(), {}};
  if (sdf.kind() != Sdf::Kind::transform) return std::nullopt;
  auto inner = revolved_shape(sdf.children()[0]);
  if (!inner) return std::nullopt;
  const Sdf::Transform t = sdf.transform();
  Sdf::Transform c;
  c.translation = t.translation + t.rotation * (t.scale * inner->transform.translation);
  c.rotation = t.rotation * inner->transform.rotation;
  c.scale = t.scale * inner->transform.scale;
  inner->transform = c;
  return inner;
}

Result<std::vector<std::array<Index, 3>>> triangulate_polygon(const std::vector<Vec2>& polygon_in) {
  const Index n = static_cast<Index>(polygon_in.size());
  if (n < 3) return make_error("polygon triangulation: fewer than 3 points");
  std::vector<Vec2> p = polygon_in;
  const bool reversed = polygon_area(p) < 0;
  if (reversed) std::reverse(p.begin(), p.end());
  auto orig = [&](Index i) { return reversed ? n - 1 - i : i; };
  double scale = 0;
  for (const Vec2& q : p) scale = std::max(scale, q.cwiseAbs().maxCoeff());
  const double eps = 1e-14 * scale * scale;

  std::vector<Index> prev(n), next(n);
  for (Index i = 0; i < n; ++i) {
    prev[i] = (i + n - 1) % n;
    next[i] = (i + 1) % n;
  }
  std::vector<char> alive(n, 1);
  std::vector<double> quality(n, -1);  // < 0: not an ear
  auto inside_closed = [&](const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& q) {
    return cross2(a, b, q) >= -eps && cross2(b, c, q) >= -eps && cross2(c, a, q) >= -eps;
  };
  auto evaluate = [&](Index v) {
    const Vec2 &a = p[prev[v]], &b = p[v], &c = p[next[v]];
    quality[v] = -1;
    if (!(cross2(a, b, c) > eps)) return;
    for (Index u = next[next[v]]; u != prev[v]; u = next[u]) {
      if (p[u] == a || p[u] == b || p[u] == c) continue;
      if (inside_closed(a, b, c, p[u])) return;
    }
    quality[v] = triangle_quality(a, b, c);
  };
  for (Index v = 0; v < n; ++v) evaluate(v);
  std::vector<std::array<Index, 3>> tris;
  tris.reserve(static_cast<std::size_t>(n - 2));
  for (Index left = n; left > 3; --left) {
    Index best = -1;
    for (Index v = 0; v < n; ++v)
      if (alive[v] && quality[v] >= 0 && (best < 0 || quality[v] > quality[best])) best = v;
    if (best < 0) return make_error("polygon triangulation: no ear left (the polygon is not simple)");
    tris.push_back({prev[best], best, next[best]});
    alive[best] = 0;
    next[prev[best]] = next[best];
    prev[next[best]] = prev[best];
    evaluate(prev[best]);
    evaluate(next[best]);
  }
  for (Index v = 0; v < n; ++v)
    if (alive[v]) {
      if (!(cross2(p[prev[v]], p[v], p[next[v]]) > eps))
        return make_error("polygon triangulation: degenerate last triangle (the polygon is not simple)");
      tris.push_back({prev[v], v, next[v]});
      break;
    }

  // Lawson flips of interior edges that are not locally Delaunay (strictly), until none is left.
  const double circle_eps = 1e-12 * scale * scale * scale * scale;
  for (int pass = 0; pass < 4 * n; ++pass) {
    std::map<std::pair<Index, Index>, std::pair<Index, int>> edge;  // directed edge -> (tri, corner)
    for (Index t = 0; t < static_cast<Index>(tris.size()); ++t)
      for (int k = 0; k < 3; ++k) edge[{tris[t][k], tris[t][(k + 1) % 3]}] = {t, k};
    std::vector<char> touched(tris.size(), 0);
    bool flipped = false;
    for (const auto& [e, tk] : edge) {
      const auto [t1, k1] = tk;
      if (e.first > e.second) continue;
      const auto it = edge.find({e.second, e.first});
      if (it == edge.end()) continue;  // boundary edge
      const auto [t2, k2] = it->second;
      if (touched[t1] || touched[t2]) continue;
      const Index a = e.first, b = e.second;
      const Index c = tris[t1][(k1 + 2) % 3], d = tris[t2][(k2 + 2) % 3];
      // Triangles (a, b, c) and (b, a, d); flip to (c, a, d)... only when the quad is convex.
      if (!(incircle(p[a], p[b], p[c], p[d]) > circle_eps)) continue;
      if (!(cross2(p[c], p[d], p[a]) < -eps && cross2(p[c], p[d], p[b]) > eps)) continue;
      tris[t1] = {c, a, d};
      tris[t2] = {d, b, c};
      touched[t1] = touched[t2] = 1;
      flipped = true;
    }
    if (!flipped) break;
  }
  for (auto& t : tris)
    for (Index& v : t) v = orig(v);
  return tris;
}

Result<TetMesh> mesh_revolution(const Sdf& sdf, const RevolveDef& def, RevolveReport* report) {
  const auto shape = revolved_shape(sdf);
  if (!shape) return make_error("revolve mesher: the shape is not a single revolution");
  if (auto c = check_polygon(shape->profile, true, "profile"); !c) return std::move(c.error());
  if (!(def.edge_length > 0) && def.target_tets <= 0)
    return field_error("edge_length", "expected an edge length > 0 m or a tet count > 0");
  if (def.segments < 0 || def.min_segments < 3) return field_error("segments", "expected at least 3 segments");

  double h = def.edge_length;
  if (!(h > 0)) {
    // Scan h downwards in 2 % steps from the profile's size; keep the count closest to the target.
    Aabb b = sdf.bounds();
    double hi = b.extent().maxCoeff() / shape->transform.scale;
    std::int64_t best = -1;
    for (double t = hi; t > hi * 1e-4; t *= 0.98) {
      auto s = plan(shape->profile, t, def);
      if (!s) return std::move(s.error());
      const std::int64_t c = s->tets();
      if (best < 0 || std::llabs(c - def.target_tets) < std::llabs(best - def.target_tets)) {
        best = c;
        h = t;
      }
      if (c > 3 * def.target_tets) break;
    }
  }
  auto planned = plan(shape->profile, h, def);
  if (!planned) return std::move(planned.error());
  const Sweep& s = *planned;
  const Index np = static_cast<Index>(s.points.size());
  const Index nseg = s.segments;

  // Nodes: axis vertices first (so they are the lowest vertex of every prism they touch).
  std::vector<Index> base(np, -1);
  TetMesh m;
  for (Index i = 0; i < np; ++i)
    if (s.points[i].x() == 0) {
      base[i] = m.num_nodes();
      m.positions.emplace_back(0.0, s.points[i].y(), 0.0);
    }
  std::vector<double> cs(nseg), sn(nseg);
  for (Index k = 0; k < nseg; ++k) {
    const double th = 2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(nseg);
    cs[k] = k == 0 ? 1.0 : std::cos(th);
    sn[k] = k == 0 ? 0.0 : std::sin(th);
  }
  for (Index i = 0; i < np; ++i)
    if (s.points[i].x() != 0) {
      base[i] = m.num_nodes();
      for (Index k = 0; k < nseg; ++k)
        m.positions.emplace_back(s.points[i].x() * cs[k], s.points[i].y(), -s.points[i].x() * sn[k]);
    }
  auto node = [&](Index i, Index k) { return s.points[i].x() == 0 ? base[i] : base[i] + k % nseg; };

  for (Index k = 0; k < nseg; ++k)
    for (const auto& tri : s.triangles) {
      std::array<Index, 6> v{};  // bottom 0..2 at segment k, top 3..5 at k + 1
      for (int c = 0; c < 3; ++c) {
        v[c] = node(tri[c], k);
        v[c + 3] = node(tri[c], k + 1);
      }
      const int m0 = static_cast<int>(std::min_element(v.begin(), v.end()) - v.begin());
      const int col = m0 % 3, level = m0 / 3;
      const Index apex = v[m0];
      const int c1 = (col + 1) % 3, c2 = (col + 2) % 3;
      const std::array<Index, 4> quad{v[c1], v[c2], v[c2 + 3], v[c1 + 3]};
      const int j = static_cast<int>(std::min_element(quad.begin(), quad.end()) - quad.begin());
      const std::array<std::array<Index, 3>, 3> faces{{
          {quad[j], quad[(j + 1) % 4], quad[(j + 2) % 4]},
          {quad[j], quad[(j + 2) % 4], quad[(j + 3) % 4]},
          {v[3 * (1 - level)], v[3 * (1 - level) + 1], v[3 * (1 - level) + 2]},
      }};
      for (const auto& f : faces) {
        TetIndices t{apex, f[0], f[1], f[2]};
        if (t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3]) continue;
        m.tets.push_back(t);
      }
    }
  const Sdf::Transform& xf = shape->transform;
  for (Vec3& p : m.positions) p = xf.translation + xf.rotation * (xf.scale * p);
  for (TetIndices& t : m.tets)
    if (signed_volume(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]], m.positions[t[3]]) < 0)
      std::swap(t[2], t[3]);
  const ValidationReport v = validate_mesh(m);
  if (v.has_errors())
    return make_error("revolve mesher: invalid mesh (" + (v.problems.empty() ? std::string() : v.problems[0].message) + ")");
  if (report) {
    report->edge_length = h;
    report->segments = static_cast<int>(nseg);
    report->profile_points = np;
    report->triangles = static_cast<std::int64_t>(s.triangles.size());
    const double s3 = xf.scale * xf.scale * xf.scale;
    report->exact_volume = Sdf::revolution(shape->profile).analytic_volume().value_or(0.0) * s3;
  }
  return m;
}

}  // namespace shatter
