// Structured meshers: box-CSG grids (exact volume, sharp corners present, closed boundary) and
// revolved profiles (volume converges to the Pappus volume, axis cases valid, deterministic).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "shatter/mesh/quality.h"
#include "shatter/mesh/topology.h"
#include "shatter/mesh/validate.h"
#include "shatter/meshing/box_csg_mesher.h"
#include "shatter/meshing/revolve_mesher.h"
#include "support/test_support.h"

namespace shatter {
namespace {

void check_valid(const TetMesh& m, int euler) {
  ASSERT_GT(m.num_tets(), 0);
  for (Index e = 0; e < m.num_tets(); ++e) ASSERT_GT(signed_volume(m, e), 0.0) << "tet " << e;
  const ValidationReport vr = validate_mesh(m);
  EXPECT_TRUE(vr.problems.empty()) << vr.problems.front().message;
  EXPECT_EQ(test::closed_manifold_euler(boundary_surface(m)), euler);
  EXPECT_EQ(connected_components(m).count, 1);
}

bool has_node(const TetMesh& m, const Vec3& p) {
  for (const Vec3& q : m.positions)
    if ((q - p).norm() < 1e-12) return true;
  return false;
}

// The cinder block: 390 x 190 x 190 mm minus two 130 x 120 mm cores through the height.
Sdf cinder_block() {
  const Sdf core = Sdf::box(Vec3(0.065, 0.15, 0.06));
  return Sdf::subtract(
      {Sdf::box(Vec3(0.195, 0.095, 0.095)), core.translated(Vec3(-0.095, 0, 0)), core.translated(Vec3(0.095, 0, 0))});
}
constexpr double kCinderVolume = 0.39 * 0.19 * 0.19 - 2 * 0.13 * 0.19 * 0.12;

TEST(BoxCsg, DetectsBoxTrees) {
  EXPECT_TRUE(box_csg_boxes(cinder_block()).has_value());
  EXPECT_EQ(box_csg_boxes(cinder_block())->size(), 3u);
  const Sdf b = Sdf::box(Vec3(0.1, 0.2, 0.3));
  EXPECT_TRUE(box_csg_boxes(b.rotated(rotation_from_euler_deg(Vec3(90, 0, 180)))).has_value());
  EXPECT_FALSE(box_csg_boxes(b.rotated(rotation_from_euler_deg(Vec3(30, 0, 0)))).has_value());
  EXPECT_FALSE(box_csg_boxes(Sdf::unite({b, Sdf::sphere(0.1)})).has_value());
  EXPECT_FALSE(box_csg_boxes(Sdf::smooth_unite({b, b.translated(Vec3(0.1, 0, 0))}, 0.01)).has_value());
  EXPECT_FALSE(mesh_box_csg(Sdf::sphere(0.1), {.edge_length = 0.01}).ok());
}

TEST(BoxCsg, ExactVolumeSharpCornersClosed) {
  // Cinder block, and an L-shaped union with a rotated (90 degrees), scaled box intersected away.
  const Sdf l_shape =
      Sdf::intersect({Sdf::unite({Sdf::box(Vec3(0.2, 0.05, 0.1)),
                                  Sdf::box(Vec3(0.1, 0.05, 0.025))
                                      .transformed(Vec3(-0.15, 0.1, 0), rotation_from_euler_deg(Vec3(90, 0, 0)), 2.0)}),
                      Sdf::box(Vec3(1, 1, 0.08))});
  // The rotated, doubled box spans x [-0.35, 0.05], y [0.05, 0.15], z [-0.1, 0.1] and sits on the
  // first; the slab cuts both to z in [-0.08, 0.08].
  const double l_volume = 0.4 * 0.1 * 0.16 + 0.4 * 0.1 * 0.16;
  struct Case {
    Sdf sdf;
    double volume;
    int euler;
  };
  for (const Case& c : {Case{cinder_block(), kCinderVolume, -2}, Case{l_shape, l_volume, 2}}) {
    for (const double h : {0.05, 0.021}) {
      BoxCsgReport r;
      auto m = mesh_box_csg(c.sdf, {.edge_length = h}, &r);
      ASSERT_OK(m);
      check_valid(*m, c.euler);
      EXPECT_NEAR(total_volume(*m), c.volume, 1e-12 * c.volume) << "h " << h;
      EXPECT_NEAR(r.exact_volume, c.volume, 1e-12 * c.volume);
      const QualitySummary q = mesh_quality(*m);
      EXPECT_GT(q.min_dihedral_deg, 20.0);
    }
  }
  // Every corner of the block and of the cores (where they cut the top and bottom) is a node.
  auto m = mesh_box_csg(cinder_block(), {.edge_length = 0.04});
  ASSERT_OK(m);
  for (double y : {-0.095, 0.095}) {
    for (double x : {-0.195, 0.195})
      for (double z : {-0.095, 0.095}) EXPECT_TRUE(has_node(*m, Vec3(x, y, z))) << x << " " << y << " " << z;
    for (double x : {-0.16, -0.03, 0.03, 0.16})
      for (double z : {-0.06, 0.06}) EXPECT_TRUE(has_node(*m, Vec3(x, y, z))) << x << " " << y << " " << z;
  }
}

TEST(BoxCsg, TargetTetCount) {
  BoxCsgReport r;
  auto m = mesh_box_csg(cinder_block(), {.target_tets = 800}, &r);
  ASSERT_OK(m);
  EXPECT_NEAR(static_cast<double>(m->num_tets()), 800.0, 80.0);
  EXPECT_NEAR(total_volume(*m), kCinderVolume, 1e-12 * kCinderVolume);
  auto big = mesh_box_csg(cinder_block(), {.target_tets = 20000});
  ASSERT_OK(big);
  EXPECT_NEAR(static_cast<double>(big->num_tets()), 20000.0, 2000.0);
}

TEST(Revolve, TriangulatesPolygons) {
  // A thin resampled strip and an L shape, both orientations: n - 2 triangles covering the area.
  std::vector<Vec2> strip;
  for (int i = 0; i <= 20; ++i) strip.emplace_back(0.01 * i, 0.0);
  for (int i = 20; i >= 0; --i) strip.emplace_back(0.01 * i, 0.008);
  const std::vector<Vec2> ell{{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  for (auto poly : {strip, ell}) {
    for (int flip = 0; flip < 2; ++flip) {
      if (flip) std::reverse(poly.begin(), poly.end());
      auto tris = triangulate_polygon(poly);
      ASSERT_OK(tris);
      EXPECT_EQ(tris->size(), poly.size() - 2);
      double area = 0;
      for (const auto& t : *tris) {
        const double a = 0.5 * ((poly[t[1]] - poly[t[0]]).x() * (poly[t[2]] - poly[t[0]]).y() -
                                (poly[t[1]] - poly[t[0]]).y() * (poly[t[2]] - poly[t[0]]).x());
        EXPECT_GT(a, 0);
        area += a;
      }
      EXPECT_NEAR(area, std::abs(polygon_area(poly)), 1e-12);
    }
  }
  // The strip comes out as a ladder of 2 triangles per 10 x 8 mm cell: min angle ~38.7 degrees.
  auto tris = triangulate_polygon(strip);
  ASSERT_OK(tris);
  for (const auto& t : *tris) {
    for (int k = 0; k < 3; ++k) {
      const Vec2 u = strip[t[(k + 1) % 3]] - strip[t[k]], v = strip[t[(k + 2) % 3]] - strip[t[k]];
      EXPECT_GT(std::acos(u.dot(v) / (u.norm() * v.norm())) * 180 / std::numbers::pi, 38.0);
    }
  }
  // A bow tie is not simple.
  EXPECT_FALSE(triangulate_polygon({{0, 0}, {1, 1}, {1, 0}, {0, 1}}).ok());
}

TEST(Revolve, CylinderOnTheAxisIsTheExactPrism) {
  // Rectangle touching the axis along a side: triangles with 1 and 2 axis vertices. The mesh is
  // the regular N-gon prism, volume N/2 r^2 sin(2 pi / N) h.
  const double r = 0.1, h = 0.3;
  const Sdf cyl = Sdf::revolution({{0, 0}, {r, 0}, {r, h}, {0, h}});
  for (int n : {3, 8, 31}) {
    RevolveReport rep;
    auto m = mesh_revolution(cyl, {.edge_length = 0.04, .segments = n}, &rep);
    ASSERT_OK(m);
    check_valid(*m, 2);
    EXPECT_EQ(rep.segments, n);
    const double exact = 0.5 * n * r * r * std::sin(2 * std::numbers::pi / n) * h;
    EXPECT_NEAR(total_volume(*m), exact, 1e-12 * exact) << n;
  }
}

// A bowl: a disc base on the axis and a thin wall out to a wide rim. With every profile point at
// the rim's segment count the tets near the axis are thin around it (6 degrees); fewer segments
// toward the axis (angular levels) keep them fat. The mesh stays conforming (closed 2-manifold
// boundary) and the volume stays that of the chordal polygon's sweep (within 1 % of Pappus).
TEST(Revolve, AngularLevelsKeepTetsNearTheAxisFat) {
  const Sdf bowl = Sdf::revolution({{0.0, 0.0},
                                    {0.04, 0.0},
                                    {0.04, 0.008},
                                    {0.07, 0.022},
                                    {0.095, 0.048},
                                    {0.108, 0.08},
                                    {0.098, 0.08},
                                    {0.086, 0.052},
                                    {0.064, 0.03},
                                    {0.036, 0.018},
                                    {0.0, 0.018}});
  RevolveReport rep;
  auto m = mesh_revolution(bowl, {.target_tets = 3000}, &rep);
  ASSERT_OK(m);
  check_valid(*m, 2);
  const QualitySummary q = mesh_quality(*m);
  EXPECT_GT(q.min_dihedral_deg, 10.0);
  const double exact = *bowl.analytic_volume();
  EXPECT_NEAR(total_volume(*m), exact, 0.01 * exact);
  EXPECT_NEAR(static_cast<double>(m->num_tets()), 3000.0, 600.0);
}

TEST(Revolve, VolumeConvergesToPappus) {
  // A thin-walled cup (base disc on the axis, 6 mm wall) and a ring away from the axis (a torus).
  const std::vector<Vec2> cup{{0, 0}, {0.05, 0}, {0.06, 0.1}, {0.054, 0.1}, {0.044, 0.006}, {0, 0.006}};
  const std::vector<Vec2> ring{{0.05, 0}, {0.07, 0}, {0.07, 0.01}, {0.05, 0.01}};
  for (const auto& [profile, euler] : {std::pair{cup, 2}, std::pair{ring, 0}}) {
    const Sdf s = Sdf::revolution(profile).transformed(Vec3(0.1, 0.2, 0.3), rotation_from_euler_deg(Vec3(10, 20, 30)));
    const double exact = *s.analytic_volume();
    double previous = 1.0;
    for (double h : {0.02, 0.01, 0.005}) {
      auto m = mesh_revolution(s, {.edge_length = h});
      ASSERT_OK(m);
      check_valid(*m, euler);
      const double err = std::abs(total_volume(*m) - exact) / exact;
      EXPECT_LT(err, 0.6 * previous) << "h " << h;
      previous = err;
    }
    EXPECT_LT(previous, 0.005);
  }
  // Deterministic.
  const Sdf cup_sdf = Sdf::revolution(cup);
  auto a = mesh_revolution(cup_sdf, {.target_tets = 3000});
  auto b = mesh_revolution(cup_sdf, {.target_tets = 3000});
  ASSERT_OK(a);
  ASSERT_OK(b);
  EXPECT_TRUE(*a == *b);
  EXPECT_NEAR(static_cast<double>(a->num_tets()), 3000.0, 450.0);
}

TEST(Revolve, RejectsOtherShapes) {
  EXPECT_FALSE(revolved_shape(Sdf::sphere(0.1)).has_value());
  EXPECT_FALSE(revolved_shape(Sdf::unite({Sdf::revolution({{0, 0}, {1, 0}, {0, 1}})})).has_value());
  EXPECT_TRUE(revolved_shape(Sdf::revolution({{0, 0}, {1, 0}, {0, 1}}).scaled(2.0)).has_value());
  EXPECT_FALSE(mesh_revolution(Sdf::sphere(0.1), {.edge_length = 0.01}).ok());
  EXPECT_FALSE(mesh_revolution(Sdf::revolution({{0, 0}, {1, 1}, {1, 0}, {0, 1}}), {.edge_length = 0.1}).ok());
}

}  // namespace
}  // namespace shatter
