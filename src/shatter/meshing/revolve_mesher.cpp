// Structured meshes of surfaces of revolution: triangulated profile swept into prisms.
#include "shatter/meshing/revolve_mesher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <string>
#include <utility>

#include "shatter/mesh/quality.h"
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
    const Vec2& a = poly[i];
    const Vec2& b = poly[(i + 1) % n];
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

// What a sweep at edge length h would hold, computed without building it: the resampled profile's
// points (as resample() counts them), the segments, and about 3 tets per point and segment.
struct SweepSize {
  double points = 0, segments = 0, tets = 0;
};
SweepSize sweep_size(const std::vector<Vec2>& poly, double h, const RevolveDef& def) {
  SweepSize z;
  double scale = 0, rmax = 0;
  for (const Vec2& p : poly) {
    scale = std::max(scale, p.cwiseAbs().maxCoeff());
    rmax = std::max(rmax, p.x());
  }
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const double len = (poly[(i + 1) % poly.size()] - poly[i]).norm();
    if (len > 1e-12 * scale) z.points += std::max(1.0, std::ceil(len / h - 1e-9));
  }
  z.segments = def.segments > 0 ? def.segments
                                : std::max<double>(def.min_segments, std::round(2.0 * std::numbers::pi * rmax / h));
  z.tets = 3.0 * z.points * z.segments;
  return z;
}

// A count for messages: whole numbers as such, astronomically large ones in %g.
std::string count_text(double v) {
  if (v < 1e15) return std::to_string(std::llround(v));
  return format_number(v, 3);
}

// An error when a sweep of that size is beyond the limits of `def`, naming the limit.
Result<void> check_sweep_size(const std::vector<Vec2>& profile, const SweepSize& z, double h, const RevolveDef& def) {
  if (profile.size() > static_cast<std::size_t>(def.max_profile_points))
    return field_error("profile", "the profile has " + std::to_string(profile.size()) + " points (limit " +
                                      std::to_string(def.max_profile_points) + "): expected a simpler profile");
  auto fail = [&](const std::string& what) {
    return field_error("edge_length", "edge length " + format_number(h) + " m gives " + what +
                                          ": expected a larger edge length or fewer segments");
  };
  if (!(z.points <= static_cast<double>(def.max_profile_points)))
    return fail("a profile of about " + count_text(z.points) + " points (limit " +
                std::to_string(def.max_profile_points) + ")");
  if (!(z.segments <= kMaxRevolveSegments))
    return fail(count_text(z.segments) + " segments (limit " + std::to_string(kMaxRevolveSegments) + ")");
  if (!(z.tets <= static_cast<double>(def.max_tets)))
    return fail("about " + count_text(z.tets) + " tets (limit " + std::to_string(def.max_tets) + ")");
  return {};
}

struct Sweep {
  std::vector<Vec2> points;
  std::vector<std::array<Index, 3>> triangles;
  int segments = 0;
  std::vector<int> level;  // angular level per point (segments >> level around the axis)
  // Tet count: exact for triangles swept at one level, estimated for the two-level polytopes.
  [[nodiscard]] std::int64_t tets() const {
    std::int64_t t = 0;
    for (const auto& tri : triangles) {
      int axis = 0, kmin = 1 << 20, kmax = 0;
      for (Index v : tri) {
        if (points[v].x() == 0) {
          ++axis;
          continue;
        }
        const int k = level.empty() ? 0 : level[static_cast<std::size_t>(v)];
        kmin = std::min(kmin, k);
        kmax = std::max(kmax, k);
      }
      const std::int64_t steps = segments >> kmin;
      if (kmax == kmin) {
        t += steps * (3 - axis);
        continue;
      }
      // Two-level polytope: its boundary triangles less about 4 at the joined vertex.
      int tris = 2;
      for (int e = 0; e < 3; ++e) {
        const Index p = tri[static_cast<std::size_t>(e)], q = tri[static_cast<std::size_t>((e + 1) % 3)];
        const bool pa = points[p].x() == 0, qa = points[q].x() == 0;
        if (pa && qa) continue;
        const bool pf = !pa && level[static_cast<std::size_t>(p)] == kmin,
                   qf = !qa && level[static_cast<std::size_t>(q)] == kmin;
        if (pa || qa)
          tris += (pa ? qf : pf) ? 2 : 1;
        else if (pf && qf)
          tris += 4;
        else if (!pf && !qf)
          tris += 2;
        else
          tris += 3;
      }
      t += steps / 2 * (tris - 4);
    }
    return t;
  }
};

// Angular levels: a profile point at level k is swept with N / 2^k segments, so that the spacing
// around the axis (2 pi r / segments) stays near h instead of shrinking toward the axis. Levels of
// the two ends of a profile edge differ by at most 1. Returns the levels (axis points: 0, unused)
// and the largest level L; N must be a multiple of 2^L.
std::vector<int> angular_levels(const Sweep& s, double h, int max_level, int min_segments) {
  const Index np = static_cast<Index>(s.points.size());
  std::vector<int> level(static_cast<std::size_t>(np), 0);
  for (Index i = 0; i < np; ++i) {
    const double r = s.points[static_cast<std::size_t>(i)].x();
    if (r == 0) continue;
    const double want = std::max<double>(min_segments, 2.0 * std::numbers::pi * r / h);
    int k = 0;
    while (k < max_level && static_cast<double>(s.segments >> (k + 1)) >= want &&
           (s.segments >> (k + 1)) >= min_segments)
      ++k;
    level[static_cast<std::size_t>(i)] = k;
  }
  // Neighbouring off-axis points differ by at most one level: lower (refine) the coarser one.
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto& t : s.triangles)
      for (int e = 0; e < 3; ++e) {
        const Index u = t[static_cast<std::size_t>(e)], v = t[static_cast<std::size_t>((e + 1) % 3)];
        if (s.points[static_cast<std::size_t>(u)].x() == 0 || s.points[static_cast<std::size_t>(v)].x() == 0) continue;
        int& ku = level[static_cast<std::size_t>(u)];
        int& kv = level[static_cast<std::size_t>(v)];
        if (ku > kv + 1) {
          ku = kv + 1;
          changed = true;
        }
        if (kv > ku + 1) {
          kv = ku + 1;
          changed = true;
        }
      }
  }
  return level;
}

// Sweep with angular levels (see angular_levels). A profile triangle whose off-axis points share
// one level k is swept in prisms of N / 2^k segments, as the plain sweep does. One with points at
// levels k and k + 1 is swept two fine steps at a time: the polytope between the two end triangles
// has the fine points' middle ring as extra vertices; its faces on a profile edge are split by a
// rule of that edge alone (quadrilaterals through their lowest node; a fine/coarse strip as
// (p0 p1 q0), (p1 p2 q2), (p1 q2 q0)), and it is filled by joining the vertex that gives the best
// worst tet, among those that see every face from inside, to the faces. Returns false when some
// polytope has no such vertex.
bool sweep_with_levels(const Sweep& s, const std::vector<int>& level, TetMesh& m, std::vector<Index>& base) {
  const Index np = static_cast<Index>(s.points.size());
  const int n = s.segments;
  base.assign(static_cast<std::size_t>(np), -1);
  auto on_axis = [&](Index i) { return s.points[static_cast<std::size_t>(i)].x() == 0; };
  for (Index i = 0; i < np; ++i)
    if (on_axis(i)) {
      base[static_cast<std::size_t>(i)] = m.num_nodes();
      m.positions.emplace_back(0.0, s.points[static_cast<std::size_t>(i)].y(), 0.0);
    }
  for (Index i = 0; i < np; ++i)
    if (!on_axis(i)) {
      base[static_cast<std::size_t>(i)] = m.num_nodes();
      const int count = n >> level[static_cast<std::size_t>(i)];
      for (int k = 0; k < count; ++k) {
        const double th = 2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(count);
        const double c = k == 0 ? 1.0 : std::cos(th), sn = k == 0 ? 0.0 : std::sin(th);
        const Vec2& q = s.points[static_cast<std::size_t>(i)];
        m.positions.emplace_back(q.x() * c, q.y(), -q.x() * sn);
      }
    }
  // Node of point i at fine angle index J (a multiple of 2^level(i)).
  auto node = [&](Index i, int J) -> Index {
    if (on_axis(i)) return base[static_cast<std::size_t>(i)];
    const int k = level[static_cast<std::size_t>(i)];
    const int count = n >> k;
    return base[static_cast<std::size_t>(i)] + ((J >> k) % count);
  };
  using Tri = std::array<Index, 3>;
  auto quad = [](std::vector<Tri>& f, Index a, Index b, Index c, Index d) {  // a b c d in cycle order
    const std::array<Index, 4> q{a, b, c, d};
    const int j = static_cast<int>(std::min_element(q.begin(), q.end()) - q.begin());
    f.push_back({q[static_cast<std::size_t>(j)], q[static_cast<std::size_t>((j + 1) % 4)],
                 q[static_cast<std::size_t>((j + 2) % 4)]});
    f.push_back({q[static_cast<std::size_t>(j)], q[static_cast<std::size_t>((j + 2) % 4)],
                 q[static_cast<std::size_t>((j + 3) % 4)]});
  };
  for (const auto& tri : s.triangles) {
    int kmin = 1 << 20;
    for (Index v : tri)
      if (!on_axis(v)) kmin = std::min(kmin, level[static_cast<std::size_t>(v)]);
    const int step = 1 << kmin;
    bool mixed = false;
    for (Index v : tri) mixed |= !on_axis(v) && level[static_cast<std::size_t>(v)] > kmin;
    if (!mixed) {
      for (int J = 0; J < n; J += step) {  // prisms, as in the plain sweep
        std::array<Index, 6> v{};
        for (int c = 0; c < 3; ++c) {
          v[static_cast<std::size_t>(c)] = node(tri[static_cast<std::size_t>(c)], J);
          v[static_cast<std::size_t>(c + 3)] = node(tri[static_cast<std::size_t>(c)], J + step);
        }
        const int m0 = static_cast<int>(std::min_element(v.begin(), v.end()) - v.begin());
        const int col = m0 % 3, lev = m0 / 3;
        const Index apex = v[static_cast<std::size_t>(m0)];
        const int c1 = (col + 1) % 3, c2 = (col + 2) % 3;
        std::vector<Tri> faces;
        quad(faces, v[static_cast<std::size_t>(c1)], v[static_cast<std::size_t>(c2)],
             v[static_cast<std::size_t>(c2 + 3)], v[static_cast<std::size_t>(c1 + 3)]);
        faces.push_back({v[static_cast<std::size_t>(3 * (1 - lev))], v[static_cast<std::size_t>(3 * (1 - lev) + 1)],
                         v[static_cast<std::size_t>(3 * (1 - lev) + 2)]});
        for (const auto& f : faces) {
          TetIndices t{apex, f[0], f[1], f[2]};
          if (t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3]) continue;
          m.tets.push_back(t);
        }
      }
      continue;
    }
    for (int J = 0; J < n; J += 2 * step) {
      const int J1 = J + step, J2 = J + 2 * step;
      // Faces as polygons: a quadrilateral swept by a profile edge is planar (an isosceles
      // trapezoid), so a vertex on it must not be joined to it; it is split through its lowest node.
      std::vector<std::vector<Index>> faces;
      faces.push_back({node(tri[0], J), node(tri[1], J), node(tri[2], J)});
      faces.push_back({node(tri[0], J2), node(tri[1], J2), node(tri[2], J2)});
      for (int e = 0; e < 3; ++e) {
        Index p = tri[static_cast<std::size_t>(e)], q = tri[static_cast<std::size_t>((e + 1) % 3)];
        const bool pa = on_axis(p), qa = on_axis(q);
        if (pa && qa) continue;
        const bool pf = !pa && level[static_cast<std::size_t>(p)] == kmin,
                   qf = !qa && level[static_cast<std::size_t>(q)] == kmin;
        if (pa || qa) {  // fan from the axis point over the other point's ring
          const Index ax = pa ? node(p, 0) : node(q, 0);
          const Index o = pa ? q : p;
          const bool of = pa ? qf : pf;
          if (of) {
            faces.push_back({ax, node(o, J), node(o, J1)});
            faces.push_back({ax, node(o, J1), node(o, J2)});
          } else {
            faces.push_back({ax, node(o, J), node(o, J2)});
          }
        } else if (pf && qf) {
          faces.push_back({node(p, J), node(q, J), node(q, J1), node(p, J1)});
          faces.push_back({node(p, J1), node(q, J1), node(q, J2), node(p, J2)});
        } else if (!pf && !qf) {
          faces.push_back({node(p, J), node(q, J), node(q, J2), node(p, J2)});
        } else {
          if (!pf) std::swap(p, q);  // p fine, q coarse
          faces.push_back({node(p, J), node(p, J1), node(q, J)});
          faces.push_back({node(p, J1), node(p, J2), node(q, J2)});
          faces.push_back({node(p, J1), node(q, J2), node(q, J)});
        }
      }
      std::vector<Index> verts;
      for (const auto& f : faces) verts.insert(verts.end(), f.begin(), f.end());
      std::sort(verts.begin(), verts.end());
      verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
      Vec3 centre = Vec3::Zero();
      for (Index v : verts) centre += m.positions[static_cast<std::size_t>(v)];
      centre /= static_cast<double>(verts.size());
      // Triangles of each face, oriented outward (away from the polytope's centre).
      std::vector<std::vector<Tri>> face_tris;
      for (const auto& f : faces) {
        std::vector<Tri> t;
        if (f.size() == 3)
          t.push_back({f[0], f[1], f[2]});
        else
          quad(t, f[0], f[1], f[2], f[3]);
        for (auto& x : t) {
          const Vec3 a = m.positions[static_cast<std::size_t>(x[0])], b = m.positions[static_cast<std::size_t>(x[1])],
                     c = m.positions[static_cast<std::size_t>(x[2])];
          if ((b - a).cross(c - a).dot(a - centre) < 0) std::swap(x[1], x[2]);
        }
        face_tris.push_back(std::move(t));
      }
      double best = -1;
      std::vector<TetIndices> best_tets;
      for (Index apex : verts) {
        std::vector<TetIndices> tets;
        double worst = std::numeric_limits<double>::infinity();
        bool ok = true;
        const Vec3 x0 = m.positions[static_cast<std::size_t>(apex)];
        for (std::size_t fi = 0; fi < faces.size() && ok; ++fi) {
          const auto& f4 = faces[fi];
          if (std::find(f4.begin(), f4.end(), apex) != f4.end()) {
            // A quadrilateral holding the apex keeps its split only if the diagonal ends there.
            if (f4.size() == 4) {
              const int j = static_cast<int>(std::min_element(f4.begin(), f4.end()) - f4.begin());
              if (apex != f4[static_cast<std::size_t>(j)] && apex != f4[static_cast<std::size_t>((j + 2) % 4)])
                ok = false;
            }
            continue;
          }
          for (const Tri& f : face_tris[fi]) {
            const Vec3 a = m.positions[static_cast<std::size_t>(f[0])], b = m.positions[static_cast<std::size_t>(f[1])],
                       c = m.positions[static_cast<std::size_t>(f[2])];
            const double q = signed_shape_measure(x0, a, b, c);
            if (!(q > 1e-6)) {
              ok = false;
              break;
            }
            worst = std::min(worst, q);
            tets.push_back({apex, f[0], f[1], f[2]});
          }
        }
        if (ok && worst > best) {
          best = worst;
          best_tets = std::move(tets);
        }
      }
      // A new node at the centre of the middle cross-section (fine points at J1, coarse chords'
      // midpoints), joined to every boundary triangle: taken when no vertex sees every face while
      // keeping the shared splits, or when it gives the better worst tet.
      Vec3 mid = Vec3::Zero();
      for (Index v : tri) {
        if (on_axis(v) || level[static_cast<std::size_t>(v)] == kmin)
          mid += m.positions[static_cast<std::size_t>(node(v, J1))];
        else
          mid += 0.5 * (m.positions[static_cast<std::size_t>(node(v, J))] +
                        m.positions[static_cast<std::size_t>(node(v, J2))]);
      }
      mid /= 3.0;
      double mid_worst = std::numeric_limits<double>::infinity();
      for (const auto& ft : face_tris)
        for (const Tri& f : ft) {
          const Vec3 a = m.positions[static_cast<std::size_t>(f[0])], b = m.positions[static_cast<std::size_t>(f[1])],
                     c = m.positions[static_cast<std::size_t>(f[2])];
          mid_worst = std::min(mid_worst, signed_shape_measure(mid, a, b, c));
        }
      if (mid_worst > 1e-6 && mid_worst > best) {
        const Index c = m.num_nodes();
        m.positions.push_back(mid);
        best_tets.clear();
        for (const auto& ft : face_tris)
          for (const Tri& f : ft) best_tets.push_back({c, f[0], f[1], f[2]});
      }
      if (best_tets.empty()) return false;
      m.tets.insert(m.tets.end(), best_tets.begin(), best_tets.end());
    }
  }
  return true;
}

Result<Sweep> plan(const std::vector<Vec2>& profile, double h, const RevolveDef& def, bool levels) {
  if (auto ok = check_sweep_size(profile, sweep_size(profile, h, def), h, def); !ok) return std::move(ok.error());
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
  // Angular levels up to L = log2(r_max / r_min) (at most 4): with automatic segments N is
  // rounded up to a multiple of 2^L; a given N allows as many levels as it has factors of 2.
  double rmin = rmax;
  for (const Vec2& p : s.points)
    if (p.x() > 0) rmin = std::min(rmin, p.x());
  int L = 0;
  while (levels && L < 4 && rmax / rmin >= static_cast<double>(2 << L)) ++L;
  if (def.segments > 0) {
    while (L > 0 && (s.segments % (1 << L)) != 0) --L;
  } else {
    s.segments = (s.segments + (1 << L) - 1) / (1 << L) * (1 << L);
  }
  s.level = angular_levels(s, h, L, def.min_segments);
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
  if (def.segments > kMaxRevolveSegments)
    return field_error("segments", "expected at most " + std::to_string(kMaxRevolveSegments) + " segments, got " +
                                       std::to_string(def.segments));
  if (def.target_tets > def.max_tets)
    return field_error(
        "tets", "expected at most " + std::to_string(def.max_tets) + " tets, got " + std::to_string(def.target_tets));

  // Two sweeps: plain (every profile point at N segments) and with angular levels (fewer segments
  // toward the axis, two-level polytopes between); each sized for the target on its own, and the
  // one with the larger smallest dihedral angle kept (the plain one on a tie).
  const Sdf::Transform& xf = shape->transform;
  struct Candidate {
    TetMesh mesh;
    double h = 0, min_angle = -1;
    int segments = 0, levels = 0;
    Index points = 0, triangles = 0;
  };
  auto build = [&](bool levels) -> Result<Candidate> {
    double h = def.edge_length;
    if (!(h > 0)) {
      // Scan h downwards in 2 % steps from the profile's size; keep the count closest to the target.
      Aabb b = sdf.bounds();
      double hi = b.extent().maxCoeff() / shape->transform.scale;
      std::int64_t best = -1;
      for (double t = hi; t > hi * 1e-4; t *= 0.98) {
        // Finer than the limits allow: the best so far stands (or, if none, plan() says why).
        if (best >= 0 && !check_sweep_size(shape->profile, sweep_size(shape->profile, t, def), t, def).ok()) break;
        auto sw = plan(shape->profile, t, def, levels);
        if (!sw) return std::move(sw.error());
        const std::int64_t c = sw->tets();
        if (best < 0 || std::llabs(c - def.target_tets) < std::llabs(best - def.target_tets)) {
          best = c;
          h = t;
        }
        if (c > 3 * def.target_tets) break;
      }
    }
    auto planned = plan(shape->profile, h, def, levels);
    if (!planned) return std::move(planned.error());
    const Sweep& sw = *planned;
    Candidate c;
    c.h = h;
    c.segments = sw.segments;
    for (int k : sw.level) c.levels = std::max(c.levels, k);
    c.points = static_cast<Index>(sw.points.size());
    c.triangles = static_cast<Index>(sw.triangles.size());
    std::vector<Index> base;
    if (!sweep_with_levels(sw, sw.level, c.mesh, base))
      return make_error("revolve mesher: a two-level polytope could not be filled");
    TetMesh& m = c.mesh;
    for (Vec3& p : m.positions) p = xf.translation + xf.rotation * (xf.scale * p);
    for (TetIndices& t : m.tets)
      if (signed_volume(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]], m.positions[t[3]]) < 0)
        std::swap(t[2], t[3]);
    c.min_angle = mesh_quality(m).min_dihedral_deg;
    return c;
  };
  auto plain = build(false);
  if (!plain) return std::move(plain.error());
  Candidate chosen = std::move(*plain);
  // A level sweep that cannot fill some polytope is dropped: the plain sweep stands (revolve_mesher.h).
  if (auto graded = build(true); graded && graded->min_angle > chosen.min_angle) chosen = std::move(*graded);
  TetMesh m = std::move(chosen.mesh);
  const double h = chosen.h;
  const Index np = chosen.points;
  const Index nseg = chosen.segments;
  const ValidationReport v = validate_mesh(m);
  if (v.has_errors())
    return make_error("revolve mesher: invalid mesh (" + (v.problems.empty() ? std::string() : v.problems[0].message) +
                      ")");
  if (report) {
    report->edge_length = h;
    report->segments = static_cast<int>(nseg);
    report->levels = chosen.levels;
    report->profile_points = np;
    report->triangles = chosen.triangles;
    const double s3 = xf.scale * xf.scale * xf.scale;
    report->exact_volume = Sdf::revolution(shape->profile).analytic_volume().value_or(0.0) * s3;
  }
  return m;
}

}  // namespace shatter
