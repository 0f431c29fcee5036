// Contact manifolds: analytic box-on-box, box-on-plane and crossed-edge cases; the separating-axis
// test against a brute-force one over every face normal and every edge-pair cross product (no
// Gauss-map pruning) on random hull pairs; point reduction against the best 4-subset; feature ids
// that stay the same while a box rests.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <set>
#include <utility>
#include <vector>

#include "shatter/collide/contact.h"
#include "shatter/core/random.h"

namespace shatter {
namespace {

// A hull from its vertices and face vertex loops (any cyclic order; loops are turned counter-
// clockwise seen from outside here). Builds the half-edges (twins 2k, 2k+1), planes, centroid,
// volume, radius and bounds, independently of the library's hull builder.
ConvexHull make_hull(const std::vector<Vec3>& vertices, std::vector<std::vector<Index>> loops) {
  ConvexHull h;
  h.vertices = vertices;
  Vec3 mean = Vec3::Zero();
  for (const Vec3& v : vertices) mean += v;
  mean /= static_cast<double>(vertices.size());
  std::map<std::pair<Index, Index>, Index> edge_of;  // undirected edge -> k
  for (auto& loop : loops) {
    Vec3 n = Vec3::Zero(), c = Vec3::Zero();
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Vec3& p = vertices[static_cast<std::size_t>(loop[i])];
      const Vec3& q = vertices[static_cast<std::size_t>(loop[(i + 1) % loop.size()])];
      n += p.cross(q);  // Newell
      c += p;
    }
    c /= static_cast<double>(loop.size());
    if (n.dot(c - mean) < 0) std::reverse(loop.begin(), loop.end());
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Index u = loop[i], v = loop[(i + 1) % loop.size()];
      edge_of.emplace(std::minmax(u, v), static_cast<Index>(edge_of.size()));
    }
  }
  h.edges.resize(2 * edge_of.size());
  for (std::size_t f = 0; f < loops.size(); ++f) {
    const auto& loop = loops[f];
    std::vector<Index> he;
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Index u = loop[i], v = loop[(i + 1) % loop.size()];
      he.push_back(2 * edge_of.at(std::minmax(u, v)) + (u < v ? 0 : 1));
    }
    Vec3 n = Vec3::Zero(), c = Vec3::Zero();
    for (std::size_t i = 0; i < loop.size(); ++i) {
      HullHalfEdge& e = h.edges[static_cast<std::size_t>(he[i])];
      EXPECT_EQ(e.face, -1) << "edge used twice in one direction";
      e = {loop[i], he[(i + 1) % loop.size()], static_cast<Index>(f)};
      const Vec3& p = vertices[static_cast<std::size_t>(loop[i])];
      n += p.cross(vertices[static_cast<std::size_t>(loop[(i + 1) % loop.size()])]);
      c += p;
    }
    n.normalize();
    c /= static_cast<double>(loop.size());
    h.faces.push_back({n, n.dot(c), he[0]});
  }
  for (const HullHalfEdge& e : h.edges) EXPECT_GE(e.face, 0) << "open surface";
  // Volume and centroid from tets (mean, fan triangle).
  Vec3 moment = Vec3::Zero();
  for (const auto& loop : loops) {
    const Vec3& p0 = vertices[static_cast<std::size_t>(loop[0])];
    for (std::size_t i = 1; i + 1 < loop.size(); ++i) {
      const Vec3& p1 = vertices[static_cast<std::size_t>(loop[i])];
      const Vec3& p2 = vertices[static_cast<std::size_t>(loop[i + 1])];
      const double v = (p0 - mean).dot((p1 - mean).cross(p2 - mean)) / 6;
      h.volume += v;
      moment += v * (mean + p0 + p1 + p2) / 4;
    }
  }
  h.centroid = moment / h.volume;
  for (const Vec3& v : vertices) {
    h.radius = std::max(h.radius, (v - h.centroid).norm());
    h.bounds.extend(v);
  }
  EXPECT_EQ(check_convex_hull(h, 1e-9), "");
  return h;
}

ConvexHull make_box(const Vec3& half, const Mat3& rotation = Mat3::Identity()) {
  std::vector<Vec3> v;
  for (int i = 0; i < 8; ++i)
    v.push_back(rotation *
                Vec3((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(), (i & 4) ? half.z() : -half.z()));
  return make_hull(v, {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}});
}

// Regular n-gon prism along y: circumradius r, height h.
ConvexHull make_prism(int n, double r, double h, const Mat3& rotation = Mat3::Identity()) {
  std::vector<Vec3> v;
  std::vector<std::vector<Index>> loops(2);
  for (int k = 0; k < 2; ++k)
    for (int i = 0; i < n; ++i) {
      const double t = 2 * std::numbers::pi * i / n;
      v.push_back(rotation * Vec3(r * std::cos(t), k == 0 ? -h / 2 : h / 2, r * std::sin(t)));
      loops[static_cast<std::size_t>(k)].push_back(k * n + i);
    }
  for (int i = 0; i < n; ++i) loops.push_back({i, (i + 1) % n, n + (i + 1) % n, n + i});
  return make_hull(v, loops);
}

// Hull of points in general position by brute force: every triple whose plane has all points on
// one side is a triangular face. All the points must be extreme (we draw them on an ellipsoid).
ConvexHull make_triangle_hull(const std::vector<Vec3>& p) {
  const auto n = static_cast<Index>(p.size());
  std::vector<std::vector<Index>> loops;
  for (Index i = 0; i < n; ++i)
    for (Index j = i + 1; j < n; ++j)
      for (Index k = j + 1; k < n; ++k) {
        const Vec3 nrm = (p[j] - p[i]).cross(p[k] - p[i]);
        int above = 0, below = 0;
        for (Index m = 0; m < n; ++m) {
          if (m == i || m == j || m == k) continue;
          const double d = nrm.dot(p[m] - p[i]);
          if (d > 0) ++above;
          if (d < 0) ++below;
        }
        if (above == 0 || below == 0) loops.push_back({i, j, k});
      }
  return make_hull(p, loops);
}

Mat3 random_axis_angle(Random& rng) {
  const Vec3 axis = rng.unit_vec3();
  return Eigen::AngleAxisd(rng.uniform(0, 2 * std::numbers::pi), axis).toRotationMatrix();
}

Mat3 rot(double angle, const Vec3& axis) { return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix(); }

ConvexHull random_hull(Random& rng, int kind) {
  switch (kind) {
    // Each draw in its own statement: the order of a call's arguments is the compiler's choice.
    case 0: {
      const Vec3 half = rng.uniform_vec3(0.1, 1.0);
      return make_box(half, random_axis_angle(rng));
    }
    case 1: {
      const int sides = 3 + static_cast<int>(rng.below(10));
      const double radius = rng.uniform(0.2, 1.0), height = rng.uniform(0.1, 1.5);
      return make_prism(sides, radius, height, random_axis_angle(rng));
    }
    case 2: {  // a tetrahedron of decent shape
      std::vector<Vec3> p;
      for (int i = 0; i < 4; ++i) {
        const Vec3 direction = rng.unit_vec3();
        p.push_back(direction * rng.uniform(0.5, 1.0));
      }
      if (std::abs((p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0]))) < 0.05) return make_box(Vec3(0.3, 0.4, 0.5));
      return make_hull(p, {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}});
    }
    case 4: {  // the hull builder on 8..40 points in a rotated box (some inside)
      const int n = 8 + static_cast<int>(rng.below(33));
      const Vec3 half = rng.uniform_vec3(0.2, 1.0);
      const Mat3 r = random_axis_angle(rng);
      std::vector<Vec3> p;
      for (int i = 0; i < n; ++i) p.push_back(r * rng.uniform_vec3(-1, 1).cwiseProduct(half));
      auto hull = build_convex_hull(p);
      EXPECT_TRUE(hull.ok());
      return hull.ok() ? hull.value() : make_box(half);
    }
    case 5: {  // the hull builder on a box's corners and points on its faces: merged polygon faces
      const Vec3 half = rng.uniform_vec3(0.2, 1.0);
      const Mat3 r = random_axis_angle(rng);
      std::vector<Vec3> p;
      for (int i = 0; i < 8; ++i)
        p.push_back(
            r * Vec3((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(), (i & 4) ? half.z() : -half.z()));
      for (int i = 0; i < 12; ++i) {
        Vec3 q = rng.uniform_vec3(-1, 1);
        const auto axis = static_cast<Eigen::Index>(rng.below(3));
        q[axis] = q[axis] < 0 ? -1 : 1;
        p.push_back(r * q.cwiseProduct(half));
      }
      auto hull = build_convex_hull(p);
      EXPECT_TRUE(hull.ok());
      if (!hull.ok()) return make_box(half);
      EXPECT_EQ(hull.value().faces.size(), 6u);
      return hull.value();
    }
    default: {  // 8..32 points on an ellipsoid
      const int n = 8 + static_cast<int>(rng.below(25));
      const Vec3 axes = rng.uniform_vec3(0.2, 1.0);
      const Mat3 r = random_axis_angle(rng);
      std::vector<Vec3> p;
      for (int i = 0; i < n; ++i) p.push_back(r * rng.unit_vec3().cwiseProduct(axes));
      return make_triangle_hull(p);
    }
  }
}

// The hull in the world: vertices, face normals and offsets, edge directions.
struct WorldHull {
  std::vector<Vec3> vertices, normals, edges;
  std::vector<double> offsets;
};

WorldHull place(const ConvexHull& h, const Transform& t) {
  WorldHull w;
  for (const Vec3& v : h.vertices) w.vertices.push_back(t.apply(v));
  for (const HullFace& f : h.faces) {
    w.normals.push_back(t.rotation * f.normal);
    w.offsets.push_back(w.normals.back().dot(t.apply(f.normal * f.offset)));
  }
  for (std::size_t e = 0; e < h.edges.size(); e += 2)
    w.edges.push_back(t.rotation * (h.vertices[static_cast<std::size_t>(h.edges[e + 1].origin)] -
                                    h.vertices[static_cast<std::size_t>(h.edges[e].origin)]));
  return w;
}

// min over B - max over A along n: the gap between the hulls along n.
double gap_along(const WorldHull& a, const WorldHull& b, const Vec3& n) {
  double hi_a = -1e300, lo_b = 1e300;
  for (const Vec3& v : a.vertices) hi_a = std::max(hi_a, n.dot(v));
  for (const Vec3& v : b.vertices) lo_b = std::min(lo_b, n.dot(v));
  return lo_b - hi_a;
}

// Brute-force separating-axis value: every face normal and every cross product of two edges, both
// signs, separations from all vertices.
double brute_force_sat(const WorldHull& a, const WorldHull& b) {
  double best = -1e300;
  const auto test = [&](const Vec3& n) { best = std::max({best, gap_along(a, b, n), gap_along(a, b, -n)}); };
  for (const Vec3& n : a.normals) test(n);
  for (const Vec3& n : b.normals) test(n);
  for (const Vec3& ea : a.edges)
    for (const Vec3& eb : b.edges) {
      const Vec3 n = ea.cross(eb);
      if (n.norm() > 1e-12 * ea.norm() * eb.norm()) test(n.normalized());
    }
  return best;
}

// Largest distance of p outside the hull's face planes (negative inside).
double outside(const WorldHull& h, const Vec3& p) {
  double d = -1e300;
  for (std::size_t f = 0; f < h.normals.size(); ++f) d = std::max(d, h.normals[f].dot(p) - h.offsets[f]);
  return d;
}

// sin(alpha / 2) of the sharpest face corner alpha of a hull.
double min_half_corner_sine(const ConvexHull& h) {
  double lowest = 1;
  for (const HullHalfEdge& e : h.edges) {
    const HullHalfEdge& f = h.edges[static_cast<std::size_t>(e.next)];
    const Vec3& p = h.vertices[static_cast<std::size_t>(e.origin)];
    const Vec3& q = h.vertices[static_cast<std::size_t>(f.origin)];
    const Vec3& r = h.vertices[static_cast<std::size_t>(h.edges[static_cast<std::size_t>(f.next)].origin)];
    const double angle = std::acos(std::clamp((p - q).normalized().dot((r - q).normalized()), -1.0, 1.0));
    lowest = std::min(lowest, std::sin(angle / 2));
  }
  return lowest;
}

Transform at(const Vec3& translation, const Mat3& rotation = Mat3::Identity()) { return {rotation, translation}; }

std::uint32_t kind_of(std::uint32_t feature) { return feature >> 30; }

// ---------------------------------------------------------------------------------------------

TEST(Contact, UnitBoxRestingOnUnitBox) {
  const ConvexHull box = make_box(Vec3::Constant(0.5));
  for (const double s : {0.0, -1e-4, 1e-4}) {
    const ContactManifold m = collide_hulls(box, at(Vec3::Zero()), box, at(Vec3(0, 1 + s, 0)), 0.01);
    ASSERT_EQ(m.count, 4) << s;
    EXPECT_EQ(m.normal, Vec3(0, 1, 0)) << "normal from A (below) to B (above)";
    std::set<std::pair<int, int>> corners;
    for (int i = 0; i < 4; ++i) {
      const ManifoldPoint& p = m.points[static_cast<std::size_t>(i)];
      EXPECT_NEAR(p.separation, s, 1e-14);
      EXPECT_NEAR(std::abs(p.point.x()), 0.5, 1e-14);
      EXPECT_NEAR(std::abs(p.point.z()), 0.5, 1e-14);
      EXPECT_NEAR(p.point.y(), 0.5 + s / 2, 1e-14) << "midway between the faces";
      EXPECT_EQ(kind_of(p.feature), 0u) << "reference face on A";
      corners.insert({p.point.x() > 0, p.point.z() > 0});
    }
    EXPECT_EQ(corners.size(), 4u);
    // Roles swapped: the normal still points from A (now above) to B.
    const ContactManifold w = collide_hulls(box, at(Vec3(0, 1 + s, 0)), box, at(Vec3::Zero()), 0.01);
    ASSERT_EQ(w.count, 4);
    EXPECT_EQ(w.normal, Vec3(0, -1, 0));
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(w.points[static_cast<std::size_t>(i)].separation, s, 1e-14);
  }
  // Beyond the speculative distance: nothing; within it: a positive separation.
  EXPECT_EQ(collide_hulls(box, at(Vec3::Zero()), box, at(Vec3(0, 1.02, 0)), 0.01).count, 0);
  EXPECT_EQ(collide_hulls(box, at(Vec3::Zero()), box, at(Vec3(0, 1.02, 0)), 0.03).count, 4);
}

// 2D convex polygon (counter-clockwise in (x, z) seen from +y... any consistent order) clipped by
// the square |x|, |z| <= h: an independent Sutherland-Hodgman on plain coordinates.
std::vector<Vec2> clip_to_square(std::vector<Vec2> poly, double h) {
  for (int side = 0; side < 4; ++side) {
    const int axis = side / 2;
    const double sign = side % 2 == 0 ? 1.0 : -1.0;
    std::vector<Vec2> out;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const Vec2 p = poly[i], q = poly[(i + 1) % poly.size()];
      const double dp = sign * p[axis] - h, dq = sign * q[axis] - h;
      if (dp <= 0) out.push_back(p);
      if ((dp <= 0) != (dq <= 0)) out.push_back(p + dp / (dp - dq) * (q - p));
    }
    poly = out;
  }
  return poly;
}

TEST(Contact, RotatedOffsetBoxOnBoxGivesOverlapCorners) {
  const ConvexHull box = make_box(Vec3::Constant(0.5));
  for (const double tilt : {0.0, 0.004}) {
    const Mat3 r = rot(tilt, Vec3::UnitX()) * rot(std::numbers::pi / 6, Vec3::UnitY());
    // B's lowest point 1e-4 below A's top.
    const Vec3 offset(0.3, 0, 0.2);
    double lowest = 1e300;
    for (const Vec3& v : box.vertices) lowest = std::min(lowest, (r * v).y());
    const Transform tb = at(offset + Vec3(0, 0.5 - 1e-4 - lowest, 0), r);
    const ContactManifold m = collide_hulls(box, at(Vec3::Zero()), box, tb, 0.01);
    EXPECT_EQ(m.normal, Vec3(0, 1, 0));
    // Expected: B's bottom face over A's top square, lifted back onto B's bottom plane.
    const Vec3 nb = r * Vec3(0, -1, 0);
    const Vec3 pb = tb.apply(Vec3(0, -0.5, 0));
    std::vector<Vec2> bottom;
    for (const int i : {0, 1, 5, 4}) {
      const Vec3 w = tb.apply(box.vertices[static_cast<std::size_t>(i)]);
      bottom.push_back({w.x(), w.z()});
    }
    const std::vector<Vec2> overlap = clip_to_square(bottom, 0.5);
    std::vector<Vec3> expected;  // (x, separation, z)
    double deepest = 1e300;
    for (const Vec2& q : overlap) {
      // Point of B's bottom plane above (x, z): nb . (x, y, z) = nb . pb.
      const double y = (nb.dot(pb) - nb.x() * q.x() - nb.z() * q.y()) / nb.y();
      expected.push_back({q.x(), y - 0.5, q.y()});
      deepest = std::min(deepest, y - 0.5);
    }
    ASSERT_GE(overlap.size(), 5u) << "the case must need a reduction";
    ASSERT_EQ(m.count, 4);
    double got_deepest = 1e300;
    for (int i = 0; i < m.count; ++i) {
      const ManifoldPoint& p = m.points[static_cast<std::size_t>(i)];
      double nearest = 1e300;
      for (const Vec3& e : expected)
        nearest = std::min(nearest, (Vec3(p.point.x(), p.separation, p.point.z()) - e).norm());
      EXPECT_LT(nearest, 1e-12) << "point " << i << " is not an overlap corner";
      EXPECT_NEAR(p.point.y(), 0.5 + p.separation / 2, 1e-14);
      got_deepest = std::min(got_deepest, p.separation);
    }
    EXPECT_EQ(got_deepest, deepest) << "the deepest corner is kept";
  }
}

TEST(Contact, CrossedEdgesGiveOnePointWithTheAnalyticDepth) {
  // A: unit box turned 45 deg about x, top edge along x at y = sqrt(1/2). B: unit box turned 45 deg
  // about z, bottom edge along z, lowered so the edges overlap by d. No vertex of one is inside the
  // other (the edges are 1 long, the wedges only 2d wide at the crossing).
  const ConvexHull box = make_box(Vec3::Constant(0.5));
  const double h = std::sqrt(0.5), d = 0.05;
  Random rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    // The whole scene in a random rigid placement (the first trial: none).
    const Mat3 g = trial == 0 ? Mat3::Identity() : random_axis_angle(rng);
    const Vec3 shift = trial == 0 ? Vec3::Zero() : rng.uniform_vec3(-5, 5);
    const Transform ta = at(shift, g * rot(std::numbers::pi / 4, Vec3::UnitX()));
    const Transform tb = at(g * Vec3(0, 2 * h - d, 0) + shift, g * rot(std::numbers::pi / 4, Vec3::UnitZ()));
    const WorldHull wa = place(box, ta), wb = place(box, tb);
    for (const Vec3& v : wb.vertices) ASSERT_GT(outside(wa, v), 0.01);
    for (const Vec3& v : wa.vertices) ASSERT_GT(outside(wb, v), 0.01);
    const ContactManifold m = collide_hulls(box, ta, box, tb, 0.01);
    ASSERT_EQ(m.count, 1) << trial;
    EXPECT_EQ(kind_of(m.points[0].feature), 2u);
    EXPECT_NEAR((m.normal - g * Vec3::UnitY()).norm(), 0, 1e-12) << "normal along x cross z, from A to B";
    EXPECT_NEAR(m.points[0].separation, -d, 1e-12);
    EXPECT_NEAR((m.points[0].point - (g * Vec3(0, h - d / 2, 0) + shift)).norm(), 0, 1e-12);
    EXPECT_NEAR(hull_separation(box, ta, box, tb), -d, 1e-12);
  }
}

TEST(Contact, RandomPairsMatchBruteForceSeparatingAxes) {
  Random rng(2025);
  int overlapping = 0, separated = 0, edge_manifolds = 0, face_b_manifolds = 0, empty_overlaps = 0, edge_fallbacks = 0;
  double worst = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const ConvexHull a = random_hull(rng, static_cast<int>(rng.below(6)));
    const ConvexHull b = random_hull(rng, static_cast<int>(rng.below(6)));
    const Vec3 pa = rng.uniform_vec3(-2, 2);
    const Transform ta = at(pa, random_axis_angle(rng));
    // B's centroid at a random distance up to the sum of the radii from A's.
    const Vec3 ca = ta.apply(a.centroid);
    const Mat3 rb = random_axis_angle(rng);
    const Vec3 towards = rng.unit_vec3();
    const Vec3 cb = ca + towards * rng.uniform(0.0, 1.1) * (a.radius + b.radius);
    const Transform tb = at(cb - rb * b.centroid, rb);
    const WorldHull wa = place(a, ta), wb = place(b, tb);
    const double sharpest_a = min_half_corner_sine(a), sharpest_b = min_half_corner_sine(b);
    const double brute = brute_force_sat(wa, wb);
    SatCache axis;
    const double sat = hull_separation(a, ta, b, tb, &axis);
    EXPECT_LE(sat, brute + 1e-9) << trial << ": every tested axis is a true separation";
    if (brute <= 0) {
      ++overlapping;
      EXPECT_NEAR(sat, brute, 1e-9) << trial;
      worst = std::max(worst, std::abs(sat - brute));
    } else {
      ++separated;
    }
    // (1) Empty with no speculative distance exactly when the brute force finds a separating axis.
    const ContactManifold m0 = collide_hulls(a, ta, b, tb, 0.0);
    if (std::abs(brute) > 1e-9) {
      EXPECT_EQ(m0.count == 0, brute > 0) << trial << " brute " << brute;
    }
    // (3) The manifold with a speculative distance: unit normal from A to B, near the best axis.
    const double spec = 0.05;
    const ContactManifold m = collide_hulls(a, ta, b, tb, spec);
    if (sat > spec) {
      EXPECT_EQ(m.count, 0);
      continue;
    }
    if (m.count == 0) {
      ++empty_overlaps;
      EXPECT_GT(sat, 0) << trial << ": overlapping hulls with no contact point";
      continue;
    }
    EXPECT_NEAR(m.normal.norm(), 1, 1e-12);
    const double along = gap_along(wa, wb, m.normal);
    const double scale = std::min(a.radius, b.radius);
    const std::uint32_t kind = kind_of(m.points[0].feature);
    if (along < sat - 0.13 * std::abs(sat) - 0.0041 * scale - 1e-9) {
      // Only the fallback may give up the best axis: the incident face missed the reference face
      // (hulls side by side), and the edge pair then takes over with its own, smaller separation.
      EXPECT_EQ(kind, 2u) << trial << ": preferred axis too far off";
      EXPECT_NE(axis.kind, 3) << trial << ": the best axis was a face, whose contact missed";
      ++edge_fallbacks;
    }
    EXPECT_LE(along, std::max(sat, brute) + 1e-9);
    // Moving B out along the normal by the gap separates the hulls.
    const Transform moved = at(tb.translation + (-along + 1e-6) * m.normal, tb.rotation);
    EXPECT_GT(brute_force_sat(wa, place(b, moved)), 0.5e-6) << trial;
    edge_manifolds += kind == 2;
    face_b_manifolds += kind == 1;
    std::set<std::uint32_t> features;
    for (int i = 0; i < m.count; ++i) {
      const ManifoldPoint& p = m.points[static_cast<std::size_t>(i)];
      features.insert(p.feature);
      EXPECT_EQ(kind_of(p.feature), kind);
      EXPECT_LE(p.separation, spec);
      EXPECT_GE(p.separation, along - 1e-9) << trial << ": no point deeper than the hulls overlap";
      if (kind != 2 || sat < 0) {
        // The point is midway: half the separation back lies on A, forward on B. Incident
        // vertices up to 0.001 radius outside a side plane are kept: at a face corner of angle
        // alpha that is up to 0.001 radius / sin(alpha / 2) outside the hull.
        const double tol = 0.001 * scale / std::min(sharpest_a, sharpest_b) + 1e-9;
        EXPECT_LE(outside(wa, p.point - 0.5 * p.separation * m.normal), tol)
            << trial << " kind " << kind << " sep " << p.separation << " sat " << sat << " count " << m.count << " nf "
            << a.faces.size() << " " << b.faces.size();
        EXPECT_LE(outside(wb, p.point + 0.5 * p.separation * m.normal), tol) << trial;
      }
    }
    EXPECT_EQ(features.size(), static_cast<std::size_t>(m.count)) << "feature ids unique within a manifold";
    // A cache, fresh or from another pair, changes nothing.
    SatCache cache;
    const ContactManifold c1 = collide_hulls(a, ta, b, tb, spec, &cache);
    const ContactManifold c2 = collide_hulls(a, ta, b, tb, spec, &cache);
    SatCache other{3, 0, 0};
    const ContactManifold c3 = collide_hulls(a, ta, b, tb, spec, &other);
    for (const ContactManifold* c : {&c1, &c2, &c3}) {
      ASSERT_EQ(c->count, m.count);
      EXPECT_EQ(c->normal, m.normal);
      for (int i = 0; i < m.count; ++i)
        EXPECT_EQ(c->points[static_cast<std::size_t>(i)].point, m.points[static_cast<std::size_t>(i)].point);
    }
  }
  std::printf(
      "random pairs: %d overlapping (worst |sat - brute| %.2e), %d separated; %d edge and %d face-of-B manifolds "
      "(%d edge pairs as the fallback), %d empty within the speculative distance\n",
      overlapping, worst, separated, edge_manifolds, face_b_manifolds, edge_fallbacks, empty_overlaps);
  EXPECT_GT(overlapping, 150);
  EXPECT_GT(separated, 100);
  EXPECT_GT(edge_manifolds, 10);
  EXPECT_GT(face_b_manifolds, 10);
  EXPECT_LE(edge_fallbacks, 3);  // rare: the preferred axis is the rule
}

TEST(Contact, CacheStopsAtAStillSeparatingAxis) {
  const ConvexHull box = make_box(Vec3::Constant(0.5));
  SatCache cache;
  EXPECT_EQ(collide_hulls(box, at(Vec3::Zero()), box, at(Vec3(3, 0.2, 0)), 0.01, &cache).count, 0);
  EXPECT_EQ(cache.kind, 1);
  EXPECT_EQ(box.faces[static_cast<std::size_t>(cache.index_a)].normal, Vec3(1, 0, 0));
  // Moved closer along the same axis: the cached face still separates, the cache is kept.
  const SatCache before = cache;
  EXPECT_EQ(collide_hulls(box, at(Vec3::Zero()), box, at(Vec3(2, 0.3, 0)), 0.01, &cache).count, 0);
  EXPECT_EQ(cache.kind, before.kind);
  EXPECT_EQ(cache.index_a, before.index_a);
  // Touching: a manifold, the same as without a cache.
  const ContactManifold m = collide_hulls(box, at(Vec3::Zero()), box, at(Vec3(0.999, 0.3, 0)), 0.01, &cache);
  EXPECT_EQ(m.count, 4);
  EXPECT_EQ(m.normal, Vec3(1, 0, 0));
}

// A curved shard landing on one end and turning fast about it brings its other end down within the
// step. Those vertices are off the incident face (a small facet of the curve at the low end) and
// do not overlap yet, so the face's manifold leaves them out; with the motion given, the manifold
// holds the vertex that the motion takes deepest, as a speculative point with its gap at the step's
// start. Moving away, nothing arrives and the manifold is the same as without motion.
TEST(Contact, PlaneManifoldHoldsTheVertexAFastTurnBringsDown) {
  std::vector<Vec3> points;  // a 2.4 cm wide strip bent along an arc of radius 15 cm, 4 mm thick
  for (int k = 0; k <= 12; ++k) {
    const double a = -0.6 + 0.1 * k;
    for (const double r : {0.15, 0.154})
      for (const double z : {-0.012, 0.012}) points.emplace_back(r * std::sin(a), 0.15 - r * std::cos(a), z);
  }
  const ConvexHull shard = *build_convex_hull(points);
  const Plane ground;
  const Mat3 r = rot(0.5, Vec3::UnitZ());  // the -x end low, the +x end high
  double lowest = 1e300;
  for (const Vec3& v : shard.vertices) lowest = std::min(lowest, (r * v).y());
  const Transform t = at(Vec3(0, -lowest + 0.001, 0), r);
  const double spec = 0.2;  // the world's: 4 mm plus what the motion can close in a step
  const ContactManifold still = collide_hull_plane(shard, t, ground, spec);
  ASSERT_GE(still.count, 1);
  // Falling at 2 m/s and turning at 30 rad/s about z, so that the high end comes down; 1/60 s.
  const HullMotion motion{.linear_velocity = Vec3(0, -2, 0), .angular_velocity = Vec3(0, 0, -30), .dt = 1.0 / 60};
  Index first = -1;  // the vertex the motion takes deepest
  double deepest = 1e300;
  for (std::size_t k = 0; k < shard.vertices.size(); ++k) {
    const Vec3 p = r * shard.vertices[k];
    const double end =
        p.y() + t.translation.y() + motion.dt * (motion.linear_velocity + motion.angular_velocity.cross(p)).y();
    if (end < deepest) {
      deepest = end;
      first = static_cast<Index>(k);
    }
  }
  ASSERT_LT(deepest, -0.01);
  const Vec3 arriving = t.apply(shard.vertices[static_cast<std::size_t>(first)]);
  ASSERT_GT(arriving.y(), 0.01);  // far from the ground at the step's start
  const auto holds = [&arriving](const ContactManifold& m) {
    int held = 0;
    for (int i = 0; i < m.count; ++i) {
      const ManifoldPoint& p = m.points[static_cast<std::size_t>(i)];
      if ((p.point + Vec3(0, 0.5 * p.separation, 0) - arriving).norm() < 1e-12) {
        ++held;
        EXPECT_NEAR(p.separation, arriving.y(), 1e-12);
      }
    }
    return held;
  };
  EXPECT_EQ(holds(still), 0);
  const ContactManifold turning = collide_hull_plane(shard, t, ground, spec, &motion);
  EXPECT_EQ(holds(turning), 1);
  const HullMotion away{.linear_velocity = Vec3(0, 1, 0), .angular_velocity = Vec3::Zero(), .dt = 1.0 / 60};
  const ContactManifold other = collide_hull_plane(shard, t, ground, spec, &away);
  ASSERT_EQ(other.count, still.count);
  for (int i = 0; i < still.count; ++i)
    EXPECT_EQ(other.points[static_cast<std::size_t>(i)].feature, still.points[static_cast<std::size_t>(i)].feature);
}

// A curved strip (a shard of a vase's wall) falling fast onto its low end, not turning: the landing
// stops that end and swings the strip down about it, so its high end comes through the ground
// within the step. Its incident face is a small facet at the low end. With the body's inverse mass
// and inertia the manifold holds a vertex of the high end, the one this swing takes deepest;
// without them (the motion alone) it does not.
TEST(Contact, PlaneManifoldHoldsTheEndALandingSwingsDown) {
  std::vector<Vec3> points;
  for (int k = 0; k <= 12; ++k) {
    const double a = -0.6 + 0.1 * k;
    for (const double r : {0.15, 0.154})
      for (const double z : {-0.012, 0.012}) points.emplace_back(r * std::sin(a), 0.15 - r * std::cos(a), z);
  }
  // Centred on the points' mean, taken as the centre of mass (0.2 kg shared by the points), and
  // their inertia about it.
  Vec3 centre = Vec3::Zero();
  for (const Vec3& p : points) centre += p;
  centre /= static_cast<double>(points.size());
  const double mass = 0.2;
  const double each = mass / static_cast<double>(points.size());
  Mat3 inertia = Mat3::Zero();
  for (Vec3& p : points) {
    p -= centre;
    inertia += each * (p.squaredNorm() * Mat3::Identity() - p * p.transpose());
  }
  const ConvexHull shard = *build_convex_hull(points);
  const Mat3 r = rot(0.5, Vec3::UnitZ());  // the -x end low, the +x end high
  double lowest = 1e300;
  for (const Vec3& v : shard.vertices) lowest = std::min(lowest, (r * v).y());
  const Transform t = at(Vec3(0, -lowest + 0.002, 0), r);
  const Plane ground;
  const double spec = 0.2;  // the world's: 4 mm plus what the motion can close in a step
  const HullMotion falling{.linear_velocity = Vec3(0, -6, 0), .angular_velocity = Vec3::Zero(), .dt = 1.0 / 60};
  HullMotion landing = falling;
  landing.inverse_mass = 1 / mass;
  landing.inverse_inertia = inertia.inverse();
  // The swing, worked out here in the world frame: the impulse at the lowest vertex that stops it,
  // and how deep the motion it leaves takes each vertex within the step.
  std::size_t low = 0;
  for (std::size_t k = 1; k < shard.vertices.size(); ++k)
    if ((r * shard.vertices[k]).y() < (r * shard.vertices[low]).y()) low = k;
  const Vec3 arm = r * shard.vertices[low];
  const Mat3 inverse_world = r * landing.inverse_inertia * r.transpose();
  const Vec3 rn = arm.cross(Vec3::UnitY());
  const double impulse = 6 / (1 / mass + rn.dot(inverse_world * rn));
  const Vec3 v = falling.linear_velocity + impulse / mass * Vec3::UnitY();
  const Vec3 w = impulse * (inverse_world * rn);
  const auto end_of = [&](const Vec3& corner) {
    const Vec3 p = r * corner;
    return p.y() + t.translation.y() + falling.dt * (v + w.cross(p)).y();
  };
  double deepest = 1e300;
  for (const Vec3& corner : shard.vertices) deepest = std::min(deepest, end_of(corner));
  ASSERT_LT(deepest, -0.02);  // through the ground within the step
  const auto high_end = [&](const ContactManifold& m) {
    int held = 0;
    for (int i = 0; i < m.count; ++i) {
      const ManifoldPoint& p = m.points[static_cast<std::size_t>(i)];
      const Vec3 corner = t.apply_inverse(p.point + Vec3(0, 0.5 * p.separation, 0));
      if (corner.x() > 0) {
        ++held;
        EXPECT_GT(p.separation, 0.02);  // far from the ground at the step's start
        EXPECT_NEAR(end_of(corner), deepest, 1e-9);
      }
    }
    return held;
  };
  EXPECT_EQ(high_end(collide_hull_plane(shard, t, ground, spec, &falling)), 0);
  const ContactManifold swung = collide_hull_plane(shard, t, ground, spec, &landing);
  EXPECT_EQ(high_end(swung), 1);
  // Moving away, nothing lands: the manifold of the motion alone.
  HullMotion rising = landing;
  rising.linear_velocity = Vec3(0, 1, 0);
  const ContactManifold still = collide_hull_plane(shard, t, ground, spec, nullptr);
  const ContactManifold up = collide_hull_plane(shard, t, ground, spec, &rising);
  ASSERT_EQ(up.count, still.count);
  for (int i = 0; i < still.count; ++i)
    EXPECT_EQ(up.points[static_cast<std::size_t>(i)].feature, still.points[static_cast<std::size_t>(i)].feature);
}

TEST(Contact, BoxOnPlane) {
  const ConvexHull box = make_box(Vec3(0.5, 0.25, 0.4));
  const Plane ground;  // y = 0
  for (const double s : {0.0, -1e-3, 1e-3}) {
    const ContactManifold m = collide_hull_plane(box, at(Vec3(1, 0.25 + s, 2)), ground, 0.01);
    ASSERT_EQ(m.count, 4);
    EXPECT_EQ(m.normal, Vec3(0, -1, 0));
    for (int i = 0; i < 4; ++i) {
      const ManifoldPoint& p = m.points[static_cast<std::size_t>(i)];
      EXPECT_NEAR(p.separation, s, 1e-15);
      EXPECT_NEAR(p.point.y(), s / 2, 1e-15);
      EXPECT_NEAR(std::abs(p.point.x() - 1), 0.5, 1e-15);
      EXPECT_NEAR(std::abs(p.point.z() - 2), 0.4, 1e-15);
    }
  }
  EXPECT_EQ(collide_hull_plane(box, at(Vec3(0, 0.27, 0)), ground, 0.01).count, 0);
  // Tilted about z: the lowest edge, 2 points; about z then x: one corner.
  const Mat3 r1 = rot(0.2, Vec3::UnitZ());
  const Mat3 r2 = rot(0.1, Vec3::UnitX()) * r1;
  for (const auto& [r, expected] : {std::pair{r1, 2}, std::pair{r2, 1}}) {
    double lowest = 1e300;
    for (const Vec3& v : box.vertices) lowest = std::min(lowest, (r * v).y());
    const ContactManifold m = collide_hull_plane(box, at(Vec3(0, -lowest - 0.002, 0), r), ground, 0.01);
    ASSERT_EQ(m.count, expected);
    for (int i = 0; i < m.count; ++i) EXPECT_NEAR(m.points[static_cast<std::size_t>(i)].separation, -0.002, 1e-14);
  }
  // Random hulls and planes: the candidates are the corners within the speculative distance of the
  // incident face (of the faces around the deepest vertex, the most anti-parallel to the plane
  // normal) and every other vertex that overlaps; all of them when at most 4, else 4 chosen among
  // those that touch (overlap, or lie within 2 % of the radius of the deepest) when at least three
  // do, the deepest among them.
  Random rng(5);
  int off_face = 0;  // points that are vertices off the incident face
  for (int trial = 0; trial < 300; ++trial) {
    const ConvexHull h = random_hull(rng, static_cast<int>(rng.below(6)));
    const Vec3 origin = rng.uniform_vec3(-1, 1);
    const Transform t = at(origin, random_axis_angle(rng));
    const Plane plane{rng.unit_vec3(), rng.uniform(-0.5, 0.5)};
    const double spec = rng.uniform(0.0, 0.3);
    const auto sep_of = [&](Index i) {
      return plane.normal.dot(t.apply(h.vertices[static_cast<std::size_t>(i)])) - plane.offset;
    };
    Index deepest_vertex = 0;
    for (Index i = 1; i < static_cast<Index>(h.vertices.size()); ++i)
      if (sep_of(i) < sep_of(deepest_vertex)) deepest_vertex = i;
    Index incident = -1;
    double most = -1e300;
    for (const HullHalfEdge& e : h.edges) {
      const double d = -(t.rotation * h.faces[static_cast<std::size_t>(e.face)].normal).dot(plane.normal);
      if (e.origin == deepest_vertex && d > most) {
        most = d;
        incident = e.face;
      }
    }
    ASSERT_GE(incident, 0);
    std::vector<Index> candidates;
    std::size_t on_face = 0;  // candidates[0, on_face) are the incident face's
    Index e = h.faces[static_cast<std::size_t>(incident)].edge;
    do {
      if (sep_of(h.edges[static_cast<std::size_t>(e)].origin) <= spec)
        candidates.push_back(h.edges[static_cast<std::size_t>(e)].origin);
      e = h.edges[static_cast<std::size_t>(e)].next;
    } while (e != h.faces[static_cast<std::size_t>(incident)].edge);
    on_face = candidates.size();
    for (Index i = 0; i < static_cast<Index>(h.vertices.size()); ++i)
      if (sep_of(i) < 0 && std::find(candidates.begin(), candidates.end(), i) == candidates.end())
        candidates.push_back(i);
    std::vector<double> seps;
    for (const Index i : candidates) seps.push_back(sep_of(i));
    const double band = seps.empty() ? 0 : std::max(*std::min_element(seps.begin(), seps.end()) + 0.02 * h.radius, 0.0);
    const auto touching = std::count_if(seps.begin(), seps.end(), [band](double s) { return s <= band; });
    const bool among_touching = seps.size() > 4 && touching >= 3 && touching < static_cast<std::ptrdiff_t>(seps.size());
    const ContactManifold m = collide_hull_plane(h, t, plane, spec);
    ASSERT_EQ(m.count, std::min<int>(4, static_cast<int>(among_touching ? touching : seps.size()))) << trial;
    EXPECT_EQ(m.normal, -plane.normal);
    double deepest = 1e300;
    for (int i = 0; i < m.count; ++i) {
      const ManifoldPoint& p = m.points[static_cast<std::size_t>(i)];
      const Vec3 v = t.apply(h.vertices[p.feature & 0x3fffffffu]);
      EXPECT_NEAR(p.separation, plane.normal.dot(v) - plane.offset, 1e-12);
      EXPECT_NEAR((p.point - (v - 0.5 * p.separation * plane.normal)).norm(), 0, 1e-12);
      const auto found = std::find(candidates.begin(), candidates.end(), static_cast<Index>(p.feature & 0x3fffffffu));
      EXPECT_NE(found, candidates.end());
      off_face += found - candidates.begin() >= static_cast<std::ptrdiff_t>(on_face);
      if (among_touching) {
        EXPECT_LE(p.separation, band + 1e-12);
      }
      deepest = std::min(deepest, p.separation);
    }
    if (m.count > 0) {
      EXPECT_NEAR(deepest, *std::min_element(seps.begin(), seps.end()), 1e-12);
    }
  }
  EXPECT_GT(off_face, 20);
}

// Area of the convex hull of points (in the plane normal to n).
double hull_area(std::vector<Vec3> p, const Vec3& n) {
  const Vec3 u = n.unitOrthogonal(), v = n.cross(u);
  std::vector<Vec2> q;
  for (const Vec3& x : p) q.push_back({u.dot(x), v.dot(x)});
  std::sort(q.begin(), q.end(),
            [](const Vec2& a, const Vec2& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  const auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Vec2> h(2 * q.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], q[i]) <= 0) --k;
    h[k++] = q[i];
  }
  for (std::size_t i = q.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 2], h[k - 1], q[i]) <= 0) --k;
    h[k++] = q[i];
  }
  double area = 0;
  for (std::size_t i = 0; i + 1 < k; ++i) area += h[i].x() * h[i + 1].y() - h[i + 1].x() * h[i].y();
  return std::abs(area) / 2;
}

// Random hulls sunk into the top of a large box: the manifold holds B's deepest vertex, though the
// incident face (B's face most anti-parallel to the box's top) need not be around it, and at least
// three points overlap when three vertices do (then the points are chosen among those that touch).
TEST(Contact, HullSunkIntoABlockKeepsItsDeepestVertex) {
  const ConvexHull block = make_box(Vec3(10, 10, 10));
  const Transform tblock = at(Vec3(0, -10, 0));  // the top face at y = 0
  Random rng(17);
  int off_face = 0;  // trials where the deepest vertex is off the incident face
  for (int trial = 0; trial < 400; ++trial) {
    const ConvexHull h = random_hull(rng, static_cast<int>(rng.below(7)));
    double lowest = 1e300, highest = -1e300;
    for (const Vec3& v : h.vertices) {
      lowest = std::min(lowest, v.y());
      highest = std::max(highest, v.y());
    }
    const double depth = rng.uniform(0.05, 0.6) * (highest - lowest);
    const Transform t = at(Vec3(rng.uniform(-1, 1), -depth - lowest, rng.uniform(-1, 1)));
    const ContactManifold m = collide_hulls(block, tblock, h, t, 0.01);
    ASSERT_GT(m.count, 0) << trial;
    EXPECT_NEAR((m.normal - Vec3::UnitY()).norm(), 0, 1e-12) << trial;
    double deepest = 1e300;
    int overlapping = 0;
    for (int i = 0; i < m.count; ++i) {
      deepest = std::min(deepest, m.points[static_cast<std::size_t>(i)].separation);
      overlapping += m.points[static_cast<std::size_t>(i)].separation < 0;
    }
    EXPECT_NEAR(deepest, -depth, 1e-12) << trial;
    const auto sunk =
        std::count_if(h.vertices.begin(), h.vertices.end(), [&](const Vec3& v) { return t.apply(v).y() < 0; });
    EXPECT_GE(overlapping, sunk >= 3 ? 3 : 1) << trial;
    off_face += std::any_of(m.points.begin(), m.points.begin() + m.count, [](const ManifoldPoint& p) {
      return (p.feature >> 7 & 127u) == 127u && (p.feature & 127u) < 127u;
    });
  }
  EXPECT_GT(off_face, 20);
}

TEST(Contact, ReductionKeepsTheDeepestAndNearlyTheLargestArea) {
  Random rng(99);
  double worst_circle = 1, worst_disc = 1;
  for (int trial = 0; trial < 400; ++trial) {
    const bool circle = trial < 200;
    const Vec3 n = rng.unit_vec3();
    const Vec3 u = n.unitOrthogonal(), v = n.cross(u);
    const Vec3 centre = rng.uniform_vec3(-3, 3);
    const int count = circle ? 16 : 5 + static_cast<int>(rng.below(20));
    const double phase = rng.uniform(0, 1);
    std::vector<ManifoldPoint> c;
    for (int i = 0; i < count; ++i) {
      double t, r = 1;
      if (circle) {
        t = 2 * std::numbers::pi * (i + phase) / count;
      } else {
        t = rng.uniform(0, 2 * std::numbers::pi);
        r = std::sqrt(rng.uniform());
      }
      const double sep = rng.uniform(-0.01, 0.0);
      c.push_back(
          {centre + r * (std::cos(t) * u + std::sin(t) * v) + 0.5 * sep * n, sep, static_cast<std::uint32_t>(i)});
    }
    std::array<ManifoldPoint, 4> out;
    const int kept = reduce_manifold_points(n, c, out);
    ASSERT_EQ(kept, 4);
    std::size_t deepest = 0;
    for (std::size_t i = 1; i < c.size(); ++i)
      if (c[i].separation < c[deepest].separation) deepest = i;
    std::set<std::uint32_t> ids;
    std::vector<Vec3> chosen;
    for (const ManifoldPoint& p : out) {
      ids.insert(p.feature);
      chosen.push_back(p.point);
    }
    ASSERT_EQ(ids.size(), 4u);
    EXPECT_TRUE(ids.count(static_cast<std::uint32_t>(deepest))) << "the deepest point is kept";
    double best = 0;
    for (std::size_t i = 0; i < c.size(); ++i)
      for (std::size_t j = i + 1; j < c.size(); ++j)
        for (std::size_t k = j + 1; k < c.size(); ++k) {
          if (i == deepest || j == deepest || k == deepest) continue;
          best = std::max(best, hull_area({c[deepest].point, c[i].point, c[j].point, c[k].point}, n));
        }
    const double ratio = hull_area(chosen, n) / best;
    (circle ? worst_circle : worst_disc) = std::min(circle ? worst_circle : worst_disc, ratio);
  }
  std::printf("reduction: worst area ratio to the best 4-subset %.4f (16 on a circle), %.4f (random in a disc)\n",
              worst_circle, worst_disc);
  EXPECT_GT(worst_circle, 0.97);
  // Greedy (deepest, farthest, one per side) is exact on a circle; inside a disc, with the deepest
  // point anywhere, it keeps at least 0.6 of the best area on these draws.
  EXPECT_GT(worst_disc, 0.55);
  // Up to 4 candidates pass through unchanged.
  std::array<ManifoldPoint, 4> out;
  const std::vector<ManifoldPoint> three = {{Vec3(0, 0, 0), -1, 7}, {Vec3(1, 0, 0), 0, 8}, {Vec3(0, 0, 1), 0, 9}};
  ASSERT_EQ(reduce_manifold_points(Vec3::UnitY(), three, out), 3);
  EXPECT_EQ(out[2].feature, 9u);
}

TEST(Contact, FeatureIdsStayWhileABoxRests) {
  Random rng(3);
  const ConvexHull unit = make_box(Vec3::Constant(0.5));
  const ConvexHull ground = make_box(Vec3(5, 0.5, 5));
  // Equal boxes stacked exactly (corners on the side planes) and a box on a large slab.
  for (const ConvexHull* lower : {&unit, &ground}) {
    const ContactManifold m0 = collide_hulls(*lower, at(Vec3::Zero()), unit, at(Vec3(0, 1 - 1e-4, 0)), 0.01);
    ASSERT_EQ(m0.count, 4);
    std::set<std::uint32_t> ids0;
    for (const ManifoldPoint& p : m0.points) ids0.insert(p.feature);
    ASSERT_EQ(ids0.size(), 4u);
    for (int step = 0; step < 200; ++step) {
      const double eps = 1e-6;
      const Vec3 shift = rng.uniform_vec3(-eps, eps);
      const double angle = rng.uniform(-eps, eps);
      const Transform tb = at(Vec3(0, 1 - 1e-4, 0) + shift, rot(angle, rng.unit_vec3()));
      const ContactManifold m = collide_hulls(*lower, at(Vec3::Zero()), unit, tb, 0.01);
      ASSERT_EQ(m.count, 4) << step;
      for (const ManifoldPoint& p : m.points) {
        EXPECT_TRUE(ids0.count(p.feature)) << step;
        // The same id stays at the same corner.
        for (const ManifoldPoint& q : m0.points)
          if (q.feature == p.feature) {
            EXPECT_LT((q.point - p.point).norm(), 1e-5);
          }
      }
    }
  }
}

}  // namespace
}  // namespace shatter
