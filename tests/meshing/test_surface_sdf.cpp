// Closed triangle surfaces: winding number, distance, meshing agrees with the analytic sphere,
// small holes tolerated, bad surfaces rejected with a clear message.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "shatter/core/random.h"
#include "shatter/mesh/quality.h"
#include "shatter/meshing/stuffing.h"
#include "shatter/meshing/surface_sdf.h"
#include "support/test_support.h"

namespace shatter {
namespace {

// Icosphere of `radius` (outward triangles) after `levels` subdivisions.
TriSurface icosphere(double radius, int levels) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  TriSurface s;
  s.positions = {Vec3(-1, t, 0),  Vec3(1, t, 0),  Vec3(-1, -t, 0), Vec3(1, -t, 0), Vec3(0, -1, t),  Vec3(0, 1, t),
                 Vec3(0, -1, -t), Vec3(0, 1, -t), Vec3(t, 0, -1),  Vec3(t, 0, 1),  Vec3(-t, 0, -1), Vec3(-t, 0, 1)};
  s.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<Index, Index>, Index> mid;
    auto midpoint = [&](Index a, Index b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      s.positions.push_back(0.5 * (s.positions[a] + s.positions[b]));
      return mid[key] = static_cast<Index>(s.positions.size() - 1);
    };
    std::vector<TriIndices> next;
    for (const TriIndices& f : s.triangles) {
      const Index ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      next.push_back({f[0], ab, ca});
      next.push_back({f[1], bc, ab});
      next.push_back({f[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    s.triangles = std::move(next);
  }
  for (Vec3& p : s.positions) p = radius * p.normalized();
  return s;
}

TEST(SurfaceSdf, WindingNumberAndDistance) {
  auto d = SurfaceDistance::create(icosphere(0.1, 3), "sphere.obj");
  ASSERT_OK(d);
  // The hierarchy's far-field approximation stays within a few percent of the exact sum.
  EXPECT_NEAR((*d)->winding_number(Vec3(0.01, 0.02, -0.03)), 1.0, 0.02);
  EXPECT_NEAR((*d)->winding_number(Vec3(0.3, 0.0, 0.0)), 0.0, 0.02);
  // Distance against brute force over random points.
  const TriSurface s = icosphere(0.1, 3);
  Random rng(3);
  for (int i = 0; i < 200; ++i) {
    const Vec3 p = rng.uniform_vec3(-0.2, 0.2);
    double brute = 1e30;
    for (const TriIndices& t : s.triangles)
      brute = std::min(brute, point_triangle_distance(p, s.positions[t[0]], s.positions[t[1]], s.positions[t[2]]));
    ASSERT_EQ((*d)->unsigned_distance(p), brute);
    double exact_w = 0;
    for (const TriIndices& t : s.triangles)
      exact_w += triangle_winding(p, s.positions[t[0]], s.positions[t[1]], s.positions[t[2]]);
    EXPECT_NEAR((*d)->winding_number(p), exact_w, 0.02);
    EXPECT_NEAR(exact_w, p.norm() < 0.098 ? 1.0 : 0.0, p.norm() < 0.098 || p.norm() > 0.102 ? 1e-6 : 1.0);
    EXPECT_NEAR(std::abs((*d)->signed_distance(p)), std::abs(p.norm() - 0.1), 0.002);
  }
}

TEST(SurfaceSdf, MeshedSurfaceAgreesWithAnalyticSphere) {
  auto d = SurfaceDistance::create(icosphere(0.1, 4), "sphere.obj");
  ASSERT_OK(d);
  const double h = 0.015;
  auto from_surface = stuff_tets(Sdf::surface(*d), {.edge_length = h});
  auto from_sdf = stuff_tets(Sdf::sphere(0.1), {.edge_length = h});
  ASSERT_OK(from_surface);
  ASSERT_OK(from_sdf);
  const double v1 = total_volume(*from_surface), v2 = total_volume(*from_sdf);
  const double exact = 4.0 / 3.0 * std::numbers::pi * 1e-3;
  EXPECT_NEAR(v1, v2, 0.01 * exact);
  EXPECT_NEAR(v1, exact, 0.03 * exact);
  const QualitySummary q = mesh_quality(*from_surface);
  EXPECT_GT(q.min_dihedral_deg, 10.0);
}

// A tilted box as 12 triangles meshes like the box's own distance function: creases sharpened
// from the surface's normals too, volumes within 0.3 % of each other and of the exact volume.
TEST(SurfaceSdf, MeshedBoxSurfaceAgreesWithTheBoxShape) {
  const Mat3 r = rotation_from_euler_deg(Vec3(20, 30, 10));
  const Vec3 half(0.1, 0.05, 0.075);
  TriSurface box;
  for (int i = 0; i < 8; ++i)
    box.positions.push_back(
        r * Vec3((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(), (i & 4) ? half.z() : -half.z()));
  box.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                   {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  auto d = SurfaceDistance::create(box, "box.obj");
  ASSERT_OK(d);
  const double h = 0.01;
  StuffingReport rs;
  auto from_surface = stuff_tets(Sdf::surface(*d), {.edge_length = h}, &rs);
  auto from_sdf = stuff_tets(Sdf::box(half).rotated(r), {.edge_length = h});
  ASSERT_OK(from_surface);
  ASSERT_OK(from_sdf);
  EXPECT_GT(rs.sharpened, 100);
  const double exact = 8 * half.x() * half.y() * half.z();
  const double v1 = total_volume(*from_surface), v2 = total_volume(*from_sdf);
  std::printf("box volume error: from the surface %.3f %%, from the shape %.3f %%\n", 100 * (v1 - exact) / exact,
              100 * (v2 - exact) / exact);
  EXPECT_NEAR(v1, v2, 0.003 * exact);
  EXPECT_NEAR(v1, exact, 0.003 * exact);
  const QualitySummary q = mesh_quality(*from_surface);
  EXPECT_GE(q.min_dihedral_deg, kStuffingMinDihedralDeg);
  EXPECT_LE(q.max_dihedral_deg, kStuffingMaxDihedralDeg);
}

TEST(SurfaceSdf, ToleratesHolesAndInsideOut) {
  TriSurface s = icosphere(0.1, 3);
  s.triangles.erase(s.triangles.begin() + 17);  // a small hole
  auto holed = SurfaceDistance::create(s, "holed.obj");
  ASSERT_OK(holed);
  EXPECT_GT((*holed)->winding_number(Vec3(0, 0, 0)), 0.9);
  for (TriIndices& t : s.triangles) std::swap(t[1], t[2]);  // inside out
  auto flipped = SurfaceDistance::create(s, "flipped.obj");
  ASSERT_OK(flipped);
  EXPECT_GT((*flipped)->winding_number(Vec3(0, 0, 0)), 0.9);
  EXPECT_LT((*flipped)->signed_distance(Vec3(0, 0, 0)), 0.0);
}

TEST(SurfaceSdf, BadSurfaces) {
  struct Bad {
    const char* name;
    TriSurface surface;
    const char* message_part;
  };
  std::vector<Bad> cases;
  cases.push_back({"empty.obj", TriSurface{}, "empty"});
  TriSurface nan_surface = icosphere(0.1, 1);
  nan_surface.positions[5].y() = std::nan("");
  cases.push_back({"nan.obj", nan_surface, "non-finite"});
  TriSurface flat;
  flat.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};
  flat.triangles = {{0, 1, 2}, {0, 0, 1}};
  cases.push_back({"degenerate.obj", flat, "degenerate"});
  TriSurface bad_index = icosphere(0.1, 0);
  bad_index.triangles[3][1] = 99;
  cases.push_back({"index.obj", bad_index, "refers to vertex 100"});
  TriSurface half = icosphere(0.1, 2);  // keep the upper half only: open beyond repair
  std::erase_if(half.triangles, [&](const TriIndices& t) {
    return (half.positions[t[0]] + half.positions[t[1]] + half.positions[t[2]]).y() < 0;
  });
  cases.push_back({"half.obj", half, "not closed"});
  TriSurface sheet;
  sheet.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  sheet.triangles = {{0, 1, 2}, {0, 2, 3}};
  cases.push_back({"sheet.obj", sheet, "not closed"});
  for (const Bad& c : cases) {
    auto r = SurfaceDistance::create(c.surface, c.name);
    ASSERT_FALSE(r.ok()) << c.name;
    EXPECT_EQ(r.error().file, c.name);
    EXPECT_NE(r.error().message.find(c.message_part), std::string::npos) << r.error().to_string();
  }
}

}  // namespace
}  // namespace shatter
