// Convex hull: exact boxes however their points come (corners plus interior points, tet-mesh nodes,
// face grids with round-off noise), random clouds checked against brute force (every point inside,
// every vertex extreme, the volume of the brute-force supporting planes), support mapping, bad input.
// Random vectors are built with braces, which draw left to right (parentheses leave the order of the
// draws to the compiler).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "collide/collide_shapes.h"
#include "shatter/collide/convex_hull.h"
#include "shatter/core/random.h"
#include "shatter/mesh/generate.h"

namespace shatter {
namespace {

using shapes::random_ball;

// Largest height of any point above any face plane of the hull.
double max_height_above(const ConvexHull& hull, std::span<const Vec3> points) {
  double worst = -std::numeric_limits<double>::infinity();
  for (const HullFace& f : hull.faces)
    for (const Vec3& p : points) worst = std::max(worst, f.normal.dot(p) - f.offset);
  return worst;
}

// Number of vertices of face f (its loop length).
int face_size(const ConvexHull& hull, Index f) {
  int n = 0;
  Index e = hull.faces[f].edge;
  do ++n, e = hull.edges[e].next;
  while (e != hull.faces[f].edge);
  return n;
}

// Expects the hull of a box with the given corners: 8 vertices, 12 edges, 6 quads, exact volume.
void expect_box(const ConvexHull& hull, const Vec3& lo, const Vec3& hi, double volume_tol) {
  ASSERT_EQ(hull.vertices.size(), 8u);
  ASSERT_EQ(hull.edges.size(), 24u);
  ASSERT_EQ(hull.faces.size(), 6u);
  for (Index f = 0; f < 6; ++f) EXPECT_EQ(face_size(hull, f), 4);
  EXPECT_NEAR(hull.volume, (hi - lo).prod(), volume_tol);
  EXPECT_LT((hull.centroid - (lo + hi) / 2).norm(), volume_tol);
  EXPECT_NEAR(hull.radius, (hi - lo).norm() / 2, 1e-9);
  EXPECT_EQ(check_convex_hull(hull, hull.tolerance), "");
}

TEST(ConvexHull, BoxCornersAmongInteriorPoints) {
  Random rng(11);
  const Vec3 lo(-1, 0, 0.5), hi(1, 1, 3.5);
  std::vector<Vec3> points;
  for (int i = 0; i < 300; ++i)
    points.push_back(lo + Vec3{rng.uniform(), rng.uniform(), rng.uniform()}.cwiseProduct(hi - lo));  // drawn in order
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
    points.insert(points.begin() + static_cast<std::ptrdiff_t>(rng.below(points.size())), corner);
    points.push_back(corner);  // duplicates are dropped
  }
  auto hull = build_convex_hull(points);
  ASSERT_TRUE(hull.ok()) << hull.error().to_string();
  expect_box(*hull, lo, hi, 1e-12);
  for (const HullFace& f : hull->faces) EXPECT_NEAR(f.normal.cwiseAbs().maxCoeff(), 1.0, 1e-15);
  EXPECT_EQ(hull->bounds.min, lo);
  EXPECT_EQ(hull->bounds.max, hi);
}

TEST(ConvexHull, TetMeshOfABoxGivesSixFaces) {
  for (auto pattern : {BoxMeshDef::Pattern::six, BoxMeshDef::Pattern::five}) {
    const TetMesh mesh = make_box_mesh(
        {.min = Vec3(0, 0, 0), .max = Vec3(0.3, 0.2, 0.5), .cells = {4, 3, 6}, .pattern = pattern, .jitter = 0.2});
    auto hull = build_convex_hull(mesh.positions);
    ASSERT_TRUE(hull.ok()) << hull.error().to_string();
    expect_box(*hull, Vec3(0, 0, 0), Vec3(0.3, 0.2, 0.5), 1e-14);
  }
}

TEST(ConvexHull, NoisyFaceGridsOfACubeMergeIntoSixFaces) {
  Random rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    // A 7 x 7 grid on each face of a cube, each point moved by up to 1e-12, the cube rotated.
    const Vec3 axis = rng.unit_vec3();
    const Mat3 r = trial == 0 ? Mat3::Identity() : Eigen::AngleAxisd(rng.uniform(0, M_PI), axis).toRotationMatrix();
    std::vector<Vec3> points;
    for (int face = 0; face < 6; ++face)
      for (int i = 0; i <= 6; ++i)
        for (int j = 0; j <= 6; ++j) {
          Vec3 p;
          const int axis0 = face / 2;
          p[axis0] = (face % 2) ? 1.0 : -1.0;
          p[(axis0 + 1) % 3] = -1.0 + i / 3.0;
          p[(axis0 + 2) % 3] = -1.0 + j / 3.0;
          points.push_back(r * p + rng.uniform_vec3(-1e-12, 1e-12));
        }
    auto hull = build_convex_hull(points);
    ASSERT_TRUE(hull.ok()) << hull.error().to_string();
    ASSERT_EQ(hull->faces.size(), 6u) << "trial " << trial;
    ASSERT_EQ(hull->vertices.size(), 8u) << "trial " << trial;
    ASSERT_EQ(hull->edges.size(), 24u) << "trial " << trial;
    EXPECT_NEAR(hull->volume, 8.0, 1e-9);
    EXPECT_LT(hull->centroid.norm(), 1e-9);
    EXPECT_EQ(check_convex_hull(*hull, hull->tolerance), "");
    EXPECT_LE(max_height_above(*hull, points), hull->tolerance);
  }
}

// The half-spaces of every point triple whose plane has all points on one side (O(n^4)).
std::vector<std::pair<Vec3, double>> brute_force_planes(const std::vector<Vec3>& p) {
  std::vector<std::pair<Vec3, double>> planes;
  const auto n = p.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      for (std::size_t k = j + 1; k < n; ++k) {
        Vec3 normal = (p[j] - p[i]).cross(p[k] - p[i]).normalized();
        double above = 0, below = 0;
        for (const Vec3& q : p) {
          const double d = normal.dot(q - p[i]);
          above = std::max(above, d), below = std::min(below, d);
        }
        if (above > 1e-12 && below < -1e-12) continue;
        if (above > 1e-12) normal = -normal;
        planes.emplace_back(normal, normal.dot(p[i]));
      }
  return planes;
}

TEST(ConvexHull, RandomCloudsMatchBruteForce) {
  Random rng(2025);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 4 + static_cast<int>(rng.below(40));
    std::vector<Vec3> points;
    if (trial % 2 == 0) {
      points = random_ball(rng, n, 1.0);
    } else {
      for (int i = 0; i < n; ++i) points.push_back(rng.uniform_vec3(-1, 1).cwiseProduct(Vec3(3.0, 0.2, 1.0)));
    }
    const Vec3 shift = rng.uniform_vec3(-100, 100);
    for (Vec3& p : points) p += shift;
    auto hull = build_convex_hull(points);
    ASSERT_TRUE(hull.ok()) << hull.error().to_string();
    ASSERT_EQ(check_convex_hull(*hull, hull->tolerance), "") << "trial " << trial;
    EXPECT_LE(max_height_above(*hull, points), hull->tolerance) << "trial " << trial;
    // Vertices are input points, in input order, and each is extreme: outside the hull of the others.
    std::size_t next = 0;
    for (const Vec3& v : hull->vertices) {
      while (next < points.size() && points[next] != v) ++next;
      ASSERT_LT(next, points.size()) << "trial " << trial << ": a vertex that is no input point (or out of order)";
      std::vector<Vec3> others = points;
      others.erase(others.begin() + static_cast<std::ptrdiff_t>(next));
      auto without = build_convex_hull(others);
      if (!without.ok()) continue;  // the others are flat
      EXPECT_GT(max_height_above(*without, std::span<const Vec3>(&v, 1)), hull->tolerance) << "trial " << trial;
      ++next;
    }
    // Volume: Monte-Carlo over the box against the brute-force supporting planes.
    const auto planes = brute_force_planes(points);
    int inside = 0;
    const int samples = 20000;
    const Aabb box = hull->bounds;
    for (int s = 0; s < samples; ++s) {
      const Vec3 x = box.min + Vec3{rng.uniform(), rng.uniform(), rng.uniform()}.cwiseProduct(box.extent());
      bool in = true;
      for (const auto& [normal, offset] : planes) in = in && normal.dot(x) <= offset;
      inside += in;
    }
    const double frac = static_cast<double>(inside) / samples;
    const double estimate = frac * box.extent().prod();
    const double sigma = std::sqrt(frac * (1 - frac) / samples) * box.extent().prod();
    EXPECT_NEAR(hull->volume, estimate, 5 * sigma + 1e-9) << "trial " << trial;
    auto volume = convex_hull_volume(points);
    ASSERT_TRUE(volume.ok());
    EXPECT_NEAR(*volume, hull->volume, 1e-12 * hull->volume) << "trial " << trial;
    // Centroid inside, radius covers every vertex.
    for (const HullFace& f : hull->faces) EXPECT_LT(f.normal.dot(hull->centroid) - f.offset, 0);
  }
}

TEST(ConvexHull, TranslatedHullIsTheHullOfTheMovedPoints) {
  // A fragment keeps the hull of a piece the cut left whole, moved into its own frame: it must be
  // the hull of the moved points (the same vertices bitwise, every point behind every face, the
  // same volume, centroid and bounds), on boxes with coplanar points and on random clouds.
  Random rng(77);
  for (int trial = 0; trial < 30; ++trial) {
    std::vector<Vec3> points;
    if (trial % 3 == 0) {
      const TetMesh box = make_box_mesh({.max = Vec3(0.3, 0.1, 0.2), .cells = {3, 2, 2}});
      points = box.positions;
    } else {
      points = random_ball(rng, 5 + static_cast<int>(rng.below(60)), 0.2);
    }
    const Vec3 shift = rng.uniform_vec3(-3, 3);
    auto hull = build_convex_hull(points);
    ASSERT_TRUE(hull.ok()) << hull.error().to_string();
    std::vector<Vec3> moved_points = points;
    for (Vec3& p : moved_points) p += shift;
    auto rebuilt = build_convex_hull(moved_points);
    ASSERT_TRUE(rebuilt.ok());
    const ConvexHull moved = translated_hull(*hull, shift);
    ASSERT_EQ(check_convex_hull(moved, moved.tolerance), "") << "trial " << trial;
    ASSERT_EQ(moved.vertices.size(), hull->vertices.size());
    for (std::size_t i = 0; i < moved.vertices.size(); ++i)
      EXPECT_EQ(moved.vertices[i], Vec3(hull->vertices[i] + shift)) << "trial " << trial;
    EXPECT_LE(max_height_above(moved, moved_points), moved.tolerance) << "trial " << trial;
    EXPECT_EQ(moved.faces.size(), rebuilt->faces.size()) << "trial " << trial;
    EXPECT_NEAR(moved.volume, rebuilt->volume, 1e-12 * rebuilt->volume) << "trial " << trial;
    EXPECT_LT((moved.centroid - rebuilt->centroid).norm(), 1e-12) << "trial " << trial;
    EXPECT_NEAR(moved.radius, rebuilt->radius, 1e-12) << "trial " << trial;
    EXPECT_LT((moved.bounds.min - rebuilt->bounds.min).norm() + (moved.bounds.max - rebuilt->bounds.max).norm(), 1e-15)
        << "trial " << trial;
  }
}

TEST(ConvexHull, DegenerateCloudsGiveValidHulls) {
  // Integer grids (many coplanar and cospherical points), random polytopes sampled on their faces
  // with noise near the tolerance, cylinders: always a valid hull holding every point.
  Random rng(77);
  for (int trial = 0; trial < 1000; ++trial) {
    std::vector<Vec3> points;
    const int kind = trial % 4;
    if (kind == 0) {
      const int m = 2 + static_cast<int>(rng.below(4));
      for (int i = 0; i < 60; ++i)
        points.push_back(Vec3{static_cast<double>(rng.below(m)), static_cast<double>(rng.below(m)),
                              static_cast<double>(rng.below(m))});
      points.push_back(Vec3(0, 0, 0)), points.push_back(Vec3(1, 0, 0));
      points.push_back(Vec3(0, 1, 0)), points.push_back(Vec3(0, 0, 1));
    } else if (kind == 1 || kind == 2) {
      // Points on the faces of the hull of a few random points, moved by noise of about 1e-10..1e-8
      // of the size (below and above the default tolerance).
      std::vector<Vec3> seeds = random_ball(rng, 6 + static_cast<int>(rng.below(10)), 1.0);
      auto base = build_convex_hull(seeds);
      if (!base.ok()) continue;
      const double noise = kind == 1 ? 1e-10 : 1e-8 * rng.uniform();
      for (const HullFace& f : base->faces) {
        std::vector<Vec3> corners;
        Index e = f.edge;
        do corners.push_back(base->vertices[base->edges[e].origin]), e = base->edges[e].next;
        while (e != f.edge);
        for (int k = 0; k < 10; ++k) {
          const std::size_t a = rng.below(corners.size()), b = rng.below(corners.size());
          const double s = rng.uniform(), t = rng.uniform();
          const Vec3 q = corners[0] + s * (corners[a] - corners[0]) + t * (1 - s) * (corners[b] - corners[a]);
          points.push_back(q + noise * rng.uniform_vec3(-1, 1));
        }
        for (const Vec3& c : corners) points.push_back(c + noise * rng.uniform_vec3(-1, 1));
      }
    } else {
      const int ring = 3 + static_cast<int>(rng.below(30));
      for (int k = 0; k < ring; ++k)
        for (double y : {-0.5, 0.0, 0.25, 0.5}) {
          const double a = 2 * M_PI * k / ring;
          points.push_back(Vec3(std::cos(a), y, std::sin(a)));
        }
    }
    auto hull = build_convex_hull(points);
    ASSERT_TRUE(hull.ok()) << "trial " << trial << ": " << hull.error().to_string();
    ASSERT_EQ(check_convex_hull(*hull, hull->tolerance), "") << "trial " << trial;
    // Noise at the tolerance's own scale: merged faces may leave a point slightly more than the
    // tolerance out (about 1 in 5,000 such clouds, by < 1.2x).
    EXPECT_LE(max_height_above(*hull, points), 1.5 * hull->tolerance) << "trial " << trial;
    // The triangle stage's volume: the same up to faces merged within the tolerance.
    auto volume = convex_hull_volume(points);
    ASSERT_TRUE(volume.ok()) << "trial " << trial;
    EXPECT_NEAR(*volume, hull->volume, 2 * hull->tolerance * 4 * M_PI * hull->radius * hull->radius)
        << "trial " << trial;
    if (kind == 3) {
      EXPECT_EQ(hull->faces.size(), static_cast<std::size_t>((points.size() / 4) + 2));
    }
  }
}

TEST(ConvexHull, PointsOnASphereAreAllVertices) {
  Random rng(3);
  std::vector<Vec3> points;
  for (int i = 0; i < 500; ++i) points.push_back(2.0 * rng.unit_vec3());
  auto hull = build_convex_hull(points);
  ASSERT_TRUE(hull.ok()) << hull.error().to_string();
  EXPECT_EQ(hull->vertices.size(), points.size());
  EXPECT_EQ(hull->vertices, points);  // input order kept
  EXPECT_EQ(check_convex_hull(*hull, hull->tolerance), "");
  const double sphere = 4.0 / 3.0 * M_PI * 8.0;
  EXPECT_LT(hull->volume, sphere);
  EXPECT_GT(hull->volume, 0.95 * sphere);
  EXPECT_LT(hull->centroid.norm(), 0.05);
  EXPECT_NEAR(hull->radius, 2.0, 0.05);
  // Triangles: V - E + F = 2 with 3F = 2E.
  EXPECT_EQ(hull->faces.size(), 2 * points.size() - 4);
}

TEST(ConvexHull, SupportIsTheBruteForceArgmax) {
  Random rng(8);
  std::vector<Vec3> points = random_ball(rng, 400, 1.5);
  auto hull = build_convex_hull(points);
  ASSERT_TRUE(hull.ok());
  for (int k = 0; k < 2000; ++k) {
    const Vec3 direction = rng.unit_vec3();
    const Vec3 d = direction * rng.uniform(0.1, 10);
    Index best = 0;
    for (Index i = 1; i < static_cast<Index>(hull->vertices.size()); ++i)
      if (hull->vertices[i].dot(d) > hull->vertices[best].dot(d)) best = i;
    ASSERT_EQ(hull->support(d), best);
    double all = -1e300;
    for (const Vec3& p : points) all = std::max(all, p.dot(d));
    ASSERT_NEAR(hull->vertices[best].dot(d), all, 1e-12);
  }
  // Ties go to the lowest index: along +x a box has four vertices at the maximum.
  const TetMesh box = make_box_mesh({});
  auto box_hull = build_convex_hull(box.positions);
  ASSERT_TRUE(box_hull.ok());
  const Index s = box_hull->support(Vec3::UnitX());
  for (Index i = 0; i < s; ++i) EXPECT_LT(box_hull->vertices[i].x(), box_hull->vertices[s].x());
}

TEST(ConvexHull, IsDeterministic) {
  Random rng(21);
  const std::vector<Vec3> points = random_ball(rng, 3000, 1.0);
  auto a = build_convex_hull(points);
  auto b = build_convex_hull(points);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->vertices, b->vertices);
  ASSERT_EQ(a->edges.size(), b->edges.size());
  for (std::size_t e = 0; e < a->edges.size(); ++e) {
    EXPECT_EQ(a->edges[e].origin, b->edges[e].origin);
    EXPECT_EQ(a->edges[e].next, b->edges[e].next);
    EXPECT_EQ(a->edges[e].face, b->edges[e].face);
  }
  EXPECT_EQ(a->volume, b->volume);
}

TEST(ConvexHull, DegenerateInputIsAnError) {
  const auto fails = [](const std::vector<Vec3>& p, const std::string& word) {
    auto hull = build_convex_hull(p);
    ASSERT_FALSE(hull.ok());
    EXPECT_NE(hull.error().message.find(word), std::string::npos) << hull.error().message;
    auto volume = convex_hull_volume(p);
    ASSERT_FALSE(volume.ok());
    EXPECT_EQ(volume.error().message, hull.error().message);
  };
  fails({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, "at least 4");
  fails({}, "at least 4");
  fails({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, NAN)}, "not finite");
  fails({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, INFINITY, 0), Vec3(0, 0, 1)}, "not finite");
  fails(std::vector<Vec3>(10, Vec3(1, 2, 3)), "coincide");
  Random rng(4);
  std::vector<Vec3> line, plane;
  for (int i = 0; i < 50; ++i) {
    const double along = rng.uniform(-1, 1);
    line.push_back(Vec3(1, 2, 3) * along + rng.uniform_vec3(-1e-13, 1e-13));
    plane.push_back(Vec3{rng.uniform(-1, 1), 0.5 * rng.uniform(-1, 1), rng.uniform(-1e-12, 1e-12)});
  }
  fails(line, "collinear");
  fails(plane, "coplanar");
  // A given tolerance: points 1e-4 off the plane are flat at 1e-3, not at the default.
  for (Vec3& p : plane) p.z() = rng.uniform(-1e-4, 1e-4);
  EXPECT_FALSE(build_convex_hull(plane, {.tolerance = 1e-3}).ok());
  EXPECT_TRUE(build_convex_hull(plane).ok());
  EXPECT_FALSE(build_convex_hull(plane, {.tolerance = -1}).ok());
}

TEST(ConvexHull, CheckCatchesBrokenHulls) {
  const TetMesh box = make_box_mesh({});
  auto hull = build_convex_hull(box.positions);
  ASSERT_TRUE(hull.ok());
  ASSERT_EQ(check_convex_hull(*hull, 1e-9), "");
  ConvexHull moved = *hull;
  moved.vertices[3] += Vec3(0.1, 0.1, 0.1);
  EXPECT_NE(check_convex_hull(moved, 1e-9), "");
  ConvexHull relinked = *hull;
  std::swap(relinked.edges[0].next, relinked.edges[2].next);
  EXPECT_NE(check_convex_hull(relinked, 1e-9), "");
  ConvexHull flipped = *hull;
  flipped.faces[1].normal = -flipped.faces[1].normal;
  flipped.faces[1].offset = -flipped.faces[1].offset;
  EXPECT_NE(check_convex_hull(flipped, 1e-9), "");
  // A face whose plane is tilted: its own vertices no longer on it (all still behind every plane).
  ConvexHull tilted = *hull;
  tilted.faces[0].normal = (tilted.faces[0].normal + Vec3(0.05, 0.05, 0.05)).normalized();
  double highest = -1e300;
  for (const Vec3& v : tilted.vertices) highest = std::max(highest, tilted.faces[0].normal.dot(v));
  tilted.faces[0].offset = highest;
  EXPECT_NE(check_convex_hull(tilted, 1e-9).find("below its plane"), std::string::npos);
  // A flat box split by a crease of 1e-12: its two halves are coplanar at 1e-9.
  std::vector<Vec3> creased = {Vec3(0, 0, 0),      Vec3(2, 0, 0), Vec3(0, 1, 0), Vec3(2, 1, 0), Vec3(1, 0, -1e-12),
                               Vec3(1, 1, -1e-12), Vec3(0, 0, 1), Vec3(2, 0, 1), Vec3(0, 1, 1), Vec3(2, 1, 1)};
  auto fine = build_convex_hull(creased, {.tolerance = 1e-14});
  ASSERT_TRUE(fine.ok());
  EXPECT_EQ(fine->faces.size(), 7u);
  EXPECT_EQ(check_convex_hull(*fine, 1e-14), "");
  EXPECT_NE(check_convex_hull(*fine, 1e-9), "");
}

}  // namespace
}  // namespace shatter
