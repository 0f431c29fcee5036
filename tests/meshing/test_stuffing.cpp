// Isosurface stuffing: volumes converge to the analytic volume, tets positive with dihedral angles
// inside the documented bounds, boundaries closed 2-manifolds, identical output across runs and
// thread counts.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <set>

#include "shatter/core/hash.h"
#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/mesh/quality.h"
#include "shatter/mesh/topology.h"
#include "shatter/mesh/validate.h"
#include "shatter/meshing/coarsen.h"
#include "shatter/meshing/stuffing.h"
#include "support/test_support.h"

namespace shatter {
namespace {

// The stencil table's bounds (stuffing.h, checked configuration by configuration in
// test_stuffing_stencil.cpp); every mesh must respect them.
constexpr double kMinDihedralDeg = kStuffingMinDihedralDeg;
constexpr double kMaxDihedralDeg = kStuffingMaxDihedralDeg;

std::uint64_t mesh_hash(const TetMesh& m) {
  Hasher h;
  h.add_bytes(m.positions.data(), m.positions.size() * sizeof(Vec3));
  h.add_bytes(m.tets.data(), m.tets.size() * sizeof(TetIndices));
  return h.digest();
}

void check_mesh(const TetMesh& m, int expected_euler) {
  for (Index e = 0; e < m.num_tets(); ++e) ASSERT_GT(signed_volume(m, e), 0.0) << "tet " << e;
  const ValidationReport vr = validate_mesh(m);
  EXPECT_TRUE(vr.problems.empty()) << vr.problems.front().message;
  const QualitySummary q = mesh_quality(m);
  EXPECT_GE(q.min_dihedral_deg, kMinDihedralDeg);
  EXPECT_LE(q.max_dihedral_deg, kMaxDihedralDeg);
  EXPECT_EQ(test::closed_manifold_euler(boundary_surface(m)), expected_euler);
}

struct Case {
  const char* name;
  Sdf sdf;
  double size;  // characteristic size, m
  int euler;
};

std::vector<Case> convergence_cases() {
  // The box is tilted so that its faces do not fall on lattice planes.
  return {{"sphere", Sdf::sphere(0.1), 0.1, 2},
          {"box", Sdf::box(Vec3(0.137, 0.093, 0.051)).rotated(rotation_from_euler_deg(Vec3(10, 20, 30))), 0.1, 2},
          {"cylinder", Sdf::cylinder(0.08, 0.12), 0.08, 2},
          {"torus", Sdf::torus(0.1, 0.04), 0.05, 0}};
}

TEST(Stuffing, VolumeConvergesToAnalytic) {
  for (const Case& c : convergence_cases()) {
    const double exact = *c.sdf.analytic_volume();
    std::vector<double> hs, errs;
    for (double f : {0.4, 0.2, 0.1}) {
      const double h = f * c.size;
      auto m = stuff_tets(c.sdf, {.edge_length = h});
      ASSERT_OK(m);
      check_mesh(*m, c.euler);
      const double err = std::abs(total_volume(*m) - exact) / exact;
      hs.push_back(h);
      errs.push_back(err);
    }
    for (std::size_t i = 1; i < errs.size(); ++i) {
      const double order = std::log(errs[i - 1] / errs[i]) / std::log(hs[i - 1] / hs[i]);
      std::printf("%-8s h %.5f  relative volume error %.3e  observed order %.2f\n", c.name, hs[i], errs[i], order);
      EXPECT_LT(errs[i], errs[i - 1]) << c.name;
    }
    EXPECT_LT(errs.back(), 0.01) << c.name;
  }
}

TEST(Stuffing, QualityOnCsgShapes) {
  const Sdf block = Sdf::subtract({Sdf::box(Vec3(0.195, 0.095, 0.095)),
                                   Sdf::box(Vec3(0.065, 0.2, 0.06)).translated(Vec3(-0.095, 0, 0)),
                                   Sdf::box(Vec3(0.065, 0.2, 0.06)).translated(Vec3(0.095, 0, 0))});
  auto m = stuff_tets(block, {.edge_length = 0.02});
  ASSERT_OK(m);
  check_mesh(*m, -2);  // genus 2
  const Sdf blob = Sdf::smooth_unite(
      {Sdf::sphere(0.1), Sdf::ellipsoid(Vec3(0.05, 0.08, 0.04)).translated(Vec3(0.1, 0.08, 0)),
       Sdf::capsule(0.03, 0.05).rotated(rotation_from_euler_deg(Vec3(0, 0, 60))).translated(Vec3(-0.1, 0, 0))},
      0.03);
  for (double h : {0.03, 0.015, 0.0075}) {
    auto b = stuff_tets(blob, {.edge_length = h});
    ASSERT_OK(b);
    check_mesh(*b, 2);
  }
}

// Property check over random fat CSG shapes (features no thinner than a few h): every mesh valid,
// positive, with a closed manifold boundary and angles in bounds.
TEST(Stuffing, RandomShapesGiveValidMeshes) {
  Random rng(11);
  for (int trial = 0; trial < 12; ++trial) {
    std::vector<Sdf> parts;
    const int n = 2 + static_cast<int>(rng.below(3));
    for (int i = 0; i < n; ++i) {
      const Mat3 r = rotation_from_euler_deg(rng.uniform_vec3(0, 360));
      const Vec3 t = rng.uniform_vec3(-0.05, 0.05);
      switch (rng.below(4)) {
        case 0: parts.push_back(Sdf::sphere(rng.uniform(0.04, 0.08)).translated(t)); break;
        case 1: parts.push_back(Sdf::box(rng.uniform_vec3(0.03, 0.07)).transformed(t, r)); break;
        case 2: parts.push_back(Sdf::ellipsoid(rng.uniform_vec3(0.03, 0.08)).transformed(t, r)); break;
        default: {
          // Named draws fix the order (function arguments are evaluated in an unspecified order).
          const double half_height = rng.uniform(0.03, 0.08);
          const double radius = rng.uniform(0.03, 0.06);
          parts.push_back(Sdf::cylinder(radius, half_height).transformed(t, r));
          break;
        }
      }
    }
    const Sdf shape = (trial % 2) ? Sdf::smooth_unite(parts, 0.02) : Sdf::unite(parts);
    auto m = stuff_tets(shape, {.edge_length = rng.uniform(0.008, 0.015)});
    ASSERT_OK(m);
    SCOPED_TRACE("trial " + std::to_string(trial));
    check_mesh(*m, 2);
  }
}

TEST(Stuffing, TargetTetCount) {
  for (std::int64_t n : {1000, 20000}) {
    StuffingReport r;
    auto m = stuff_tets(Sdf::cylinder(0.05, 0.2), {.target_tets = n}, &r);
    ASSERT_OK(m);
    EXPECT_NEAR(static_cast<double>(m->num_tets()) / static_cast<double>(n), 1.0, 0.15) << n;
    EXPECT_NEAR(r.edge_length, std::cbrt(12.0 * total_volume(*m) / static_cast<double>(m->num_tets())),
                0.3 * r.edge_length);
  }
}

TEST(Stuffing, DeterministicAcrossRunsAndThreads) {
  const Sdf s = Sdf::smooth_unite(
      {Sdf::sphere(0.1), Sdf::box(Vec3(0.05, 0.15, 0.05)).rotated(rotation_from_euler_deg(Vec3(10, 20, 30)))}, 0.02);
  const int saved = num_threads();
  set_num_threads(1);
  auto a = stuff_tets(s, {.edge_length = 0.01});
  set_num_threads(2);
  auto b = stuff_tets(s, {.edge_length = 0.01});
  auto c = stuff_tets(s, {.edge_length = 0.01});
  set_num_threads(saved);
  ASSERT_OK(a);
  ASSERT_OK(b);
  ASSERT_OK(c);
  EXPECT_GT(a->num_tets(), 10000);
  EXPECT_EQ(mesh_hash(*a), mesh_hash(*b));
  EXPECT_EQ(mesh_hash(*b), mesh_hash(*c));
  EXPECT_TRUE(*a == *b);
}

TEST(Stuffing, TransformsMoveTheMesh) {
  const double h = 0.02;
  auto a = stuff_tets(Sdf::sphere(0.1), {.edge_length = h});
  auto b = stuff_tets(Sdf::sphere(0.05).scaled(2.0).translated(Vec3(1, 2, 3)), {.edge_length = h});
  ASSERT_OK(a);
  ASSERT_OK(b);
  EXPECT_EQ(a->num_tets(), b->num_tets());
  EXPECT_NEAR(total_volume(*a), total_volume(*b), 1e-9);
  const Aabb bb = b->bounds();
  EXPECT_NEAR(0.5 * (bb.min + bb.max).x(), 1.0, 1e-9);
}

TEST(Stuffing, BadParameters) {
  const Sdf s = Sdf::sphere(0.1);
  auto r1 = stuff_tets(s, {.edge_length = -1.0});
  ASSERT_FALSE(r1.ok());
  EXPECT_EQ(r1.error().field, "edge_length");
  auto r2 = stuff_tets(s, {});
  ASSERT_FALSE(r2.ok());
  EXPECT_NE(r2.error().message.find("tet count"), std::string::npos);
  auto ra = stuff_tets(s, {.edge_length = 0.01, .alpha_short = 0.5});
  ASSERT_FALSE(ra.ok());
  EXPECT_EQ(ra.error().field, "alpha_short");
  auto rb = stuff_tets(s, {.edge_length = 0.01, .alpha_long = 0});
  ASSERT_FALSE(rb.ok());
  EXPECT_EQ(rb.error().field, "alpha_long");
  auto r3 = stuff_tets(s, {.edge_length = 1e-5});
  ASSERT_FALSE(r3.ok());
  EXPECT_NE(r3.error().message.find("lattice"), std::string::npos) << r3.error().message;
  auto r4 = stuff_tets(s, {.edge_length = 10.0});
  ASSERT_FALSE(r4.ok());
  EXPECT_NE(r4.error().message.find("thinner"), std::string::npos) << r4.error().message;
  auto r5 = stuff_tets(Sdf(), {.edge_length = 0.1});
  ASSERT_FALSE(r5.ok());
}

}  // namespace
}  // namespace shatter

namespace shatter {
namespace {

std::vector<std::array<double, 9>> boundary_triangles_by_position(const TetMesh& m) {
  const TriSurface s = boundary_surface(m);
  std::vector<std::array<double, 9>> out;
  for (const TriIndices& t : s.triangles) {
    // Rotate so the smallest corner (lexicographic) comes first: same triangle, same key.
    std::array<Vec3, 3> p = {s.positions[t[0]], s.positions[t[1]], s.positions[t[2]]};
    auto less = [](const Vec3& a, const Vec3& b) {
      return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
    };
    int first = 0;
    for (int k = 1; k < 3; ++k)
      if (less(p[k], p[first])) first = k;
    std::array<double, 9> key;
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) key[3 * k + c] = p[(first + k) % 3][c];
    out.push_back(key);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Grading coarsens the inside only: the boundary surface is the same triangles at the same
// positions, the volume is the same, angles stay in bounds and the inside edges grow.
TEST(StuffingGrading, CoarsensTheInsideKeepingBoundaryVolumeAndBounds) {
  const Sdf shape = Sdf::smooth_unite(
      {Sdf::sphere(0.1), Sdf::box(Vec3(0.06, 0.16, 0.06)).rotated(rotation_from_euler_deg(Vec3(10, 20, 30)))}, 0.02);
  const double h = 0.008;
  StuffingReport ru, rg;
  auto uniform = stuff_tets(shape, {.edge_length = h}, &ru);
  auto graded = stuff_tets(shape, {.edge_length = h, .grading = 1.0}, &rg);
  ASSERT_OK(uniform);
  ASSERT_OK(graded);
  EXPECT_EQ(rg.tets_before_grading, uniform->num_tets());
  EXPECT_LT(graded->num_tets(), uniform->num_tets() / 2);
  std::printf("uniform %d tets, graded %d tets\n", uniform->num_tets(), graded->num_tets());
  EXPECT_EQ(boundary_triangles_by_position(*uniform), boundary_triangles_by_position(*graded));
  EXPECT_NEAR(total_volume(*graded), total_volume(*uniform), 1e-10 * total_volume(*uniform));  // sums in another order
  check_mesh(*graded, 2);
  // Mean edge length of tets whose centre is deeper than 4 h: well above h.
  double sum = 0;
  int n = 0;
  for (Index e = 0; e < graded->num_tets(); ++e) {
    const Mat34 x = graded->corners(e);
    if (!(shape(x.rowwise().mean()) < -4 * h)) continue;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j, ++n) sum += (x.col(i) - x.col(j)).norm();
  }
  ASSERT_GT(n, 0);
  EXPECT_GT(sum / n, 1.5 * h);
}

// A tet count asked with grading is the count of the graded mesh (h is searched with grading on).
TEST(StuffingGrading, TargetTetCountIsTheGradedCount) {
  StuffingReport r;
  auto m = stuff_tets(Sdf::ellipsoid(Vec3(0.12, 0.08, 0.1)), {.target_tets = 8000, .grading = 1.0}, &r);
  ASSERT_OK(m);
  EXPECT_NEAR(static_cast<double>(m->num_tets()) / 8000.0, 1.0, 0.15);
  EXPECT_GT(r.tets_before_grading, 3 * m->num_tets() / 2);
}

TEST(StuffingGrading, DeterministicAcrossThreadsAndRejectsBadParameters) {
  const Sdf s = Sdf::ellipsoid(Vec3(0.1, 0.06, 0.08));
  const int saved = num_threads();
  set_num_threads(1);
  auto a = stuff_tets(s, {.edge_length = 0.01, .grading = 0.5});
  set_num_threads(2);
  auto b = stuff_tets(s, {.edge_length = 0.01, .grading = 0.5});
  set_num_threads(saved);
  ASSERT_OK(a);
  ASSERT_OK(b);
  EXPECT_EQ(mesh_hash(*a), mesh_hash(*b));
  EXPECT_FALSE(stuff_tets(s, {.edge_length = 0.01, .grading = -1}));
  EXPECT_FALSE(stuff_tets(s, {.edge_length = 0.01, .grading = std::nan("")}));
  EXPECT_FALSE(stuff_tets(s, {.edge_length = 0.01, .grading = 1, .max_size_ratio = 0.5}));
  TetMesh m = *a;
  EXPECT_FALSE(coarsen_interior(m, {}));
  EXPECT_FALSE(coarsen_interior(m, {.size = [](const Vec3&) { return 1.0; }, .collapse_ratio = 1.5}));
}

}  // namespace
}  // namespace shatter

namespace shatter {
namespace {

// Distance of the mesh's boundary from the shape: |sdf| at the centres and edge midpoints of the
// boundary triangles (mean and max), in units of h.
std::pair<double, double> boundary_deviation(const TetMesh& m, const Sdf& s, double h) {
  const TriSurface b = boundary_surface(m);
  double sum = 0, worst = 0;
  int n = 0;
  for (const TriIndices& t : b.triangles) {
    const Vec3 p0 = b.positions[t[0]], p1 = b.positions[t[1]], p2 = b.positions[t[2]];
    for (const Vec3& q :
         {Vec3((p0 + p1 + p2) / 3.0), Vec3(0.5 * (p0 + p1)), Vec3(0.5 * (p1 + p2)), Vec3(0.5 * (p2 + p0))}) {
      const double d = std::abs(s(q)) / h;
      sum += d;
      worst = std::max(worst, d);
      ++n;
    }
  }
  return {sum / n, worst};
}

// Sharpening moves boundary nodes onto creases and corners: the boundary gets closer to the shape
// on average (the largest deviation, at corners no node can reach within the angle bounds, stays),
// angles stay in the bounds, the boundary stays a closed manifold of the same topology.
TEST(StuffingSharpen, CreasesComeBackInsideTheBounds) {
  // A tilted box (sphere-like boundary, Euler characteristic 2) and a tilted cylinder with a square
  // hole through it (a torus, 0).
  const std::pair<Sdf, int> shapes[] = {
      {Sdf::box(Vec3(0.1, 0.05, 0.075)).rotated(rotation_from_euler_deg(Vec3(20, 30, 10))), 2},
      {Sdf::subtract({Sdf::cylinder(0.05, 0.1).rotated(rotation_from_euler_deg(Vec3(10, 0, 20))),
                      Sdf::box(Vec3(0.02, 0.15, 0.02))}),
       0},
  };
  const double h = 0.01;
  for (const auto& [s, euler] : shapes) {
    StuffingReport r;
    auto sharp = stuff_tets(s, {.edge_length = h}, &r);
    auto round = stuff_tets(s, {.edge_length = h, .sharpen = false});
    ASSERT_OK(sharp);
    ASSERT_OK(round);
    EXPECT_GT(r.sharpened, 0);
    const auto [mean_s, max_s] = boundary_deviation(*sharp, s, h);
    const auto [mean_r, max_r] = boundary_deviation(*round, s, h);
    std::printf("boundary deviation / h: sharpened mean %.4f max %.4f, rounded mean %.4f max %.4f (%lld moves)\n",
                mean_s, max_s, mean_r, max_r, static_cast<long long>(r.sharpened));
    EXPECT_LT(mean_s, mean_r);
    {
      SCOPED_TRACE("rounded");
      check_mesh(*round, euler);
    }
    check_mesh(*sharp, euler);
  }
}

}  // namespace
}  // namespace shatter
