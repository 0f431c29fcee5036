// Fragment extraction and exact mass properties.
#include <gtest/gtest.h>

#include "fracture_checks.h"
#include "shatter/fracture/cut.h"
#include "shatter/fracture/fragments.h"
#include "shatter/mesh/generate.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TEST(MassProperties, BoxMatchesClosedForm) {
  const Vec3 lo(1, -2, 3), hi(3, -1.5, 4.2);
  const double rho = 2400;
  for (double jitter : {0.0, 0.2}) {
    const TetMesh m = make_box_mesh({.min = lo, .max = hi, .cells = {3, 2, 4}, .jitter = jitter});
    const MassProperties p = mass_properties(m, rho);
    const Vec3 d = hi - lo;
    const double mass = rho * d.prod();
    EXPECT_NEAR(p.volume, d.prod(), 1e-14);
    EXPECT_NEAR(p.mass, mass, 1e-10 * mass);
    EXPECT_LT((p.center - (lo + hi) / 2).norm(), 1e-13);
    const Mat3 expected = Vec3(mass * (d.y() * d.y() + d.z() * d.z()) / 12, mass * (d.x() * d.x() + d.z() * d.z()) / 12,
                               mass * (d.x() * d.x() + d.y() * d.y()) / 12).asDiagonal();
    EXPECT_LT((p.inertia - expected).norm(), 1e-11 * expected.norm()) << p.inertia;
    // The lumped version is an approximation: right mass and centre (symmetric), different inertia.
    const MassProperties l = lumped_mass_properties(m, rho);
    EXPECT_NEAR(l.mass, mass, 1e-10 * mass);
    if (jitter == 0.0) {
      EXPECT_GT((l.inertia - expected).norm(), 1e-3 * expected.norm());
    }
  }
}

TEST(MassProperties, SingleTetAgainstTonon) {
  // Tonon (2004), example: the tet below has these products of inertia (density 1).
  TetMesh m;
  m.positions = {Vec3(8.33220, -11.86875, 0.93355), Vec3(0.75523, 5.00000, 16.37072),
                 Vec3(52.61236, 5.00000, -5.38580), Vec3(2.00000, 5.00000, 3.00000)};
  m.tets = {{0, 1, 2, 3}};
  if (signed_volume(m, 0) < 0) std::swap(m.tets[0][2], m.tets[0][3]);
  const MassProperties p = mass_properties(m, 1.0);
  EXPECT_NEAR(p.volume, 1873.23, 0.01);
  EXPECT_NEAR(p.center.x(), 15.92492, 1e-4);
  EXPECT_NEAR(p.center.y(), 0.78281, 1e-4);
  EXPECT_NEAR(p.center.z(), 3.72962, 1e-4);
  EXPECT_NEAR(p.inertia(0, 0), 43520.33257, 0.01);
  EXPECT_NEAR(p.inertia(1, 1), 194711.28938, 0.01);
  EXPECT_NEAR(p.inertia(2, 2), 191168.76173, 0.01);
  EXPECT_NEAR(-p.inertia(1, 2), 4417.66150, 0.01);  // a' in Tonon's notation
  EXPECT_NEAR(-p.inertia(0, 2), -46343.16662, 0.01);  // b'
  EXPECT_NEAR(-p.inertia(0, 1), 11996.20119, 0.01); // c'
}

TEST(Fragments, MapsAndMassesMatchRecomputation) {
  const TetMesh m = make_box_mesh({.max = Vec3(3, 1, 1), .cells = {6, 2, 2}, .jitter = 0.1});
  std::vector<Index> all(m.tets.size());
  for (Index e = 0; e < m.num_tets(); ++e) all[e] = e;
  CutResult r = cut_mesh(m, {.point = Vec3(1.1, 0, 0), .normal = Vec3(1, 0.1, 0).normalized()}, all);
  r = cut_mesh(r.mesh, {.point = Vec3(2.2, 0, 0), .normal = Vec3(1, 0, -0.2).normalized()},
               [&] { std::vector<Index> a(r.mesh.tets.size()); for (Index e = 0; e < r.mesh.num_tets(); ++e) a[e] = e; return a; }());
  const double rho = 7850;
  const std::vector<Fragment> f = extract_fragments(r.mesh, rho);
  ASSERT_EQ(f.size(), 3u);
  const MassProperties whole = mass_properties(r.mesh, rho);
  double mass = 0;
  Vec3 moment = Vec3::Zero();
  for (const Fragment& g : f) {
    ASSERT_EQ(g.tet_map.size(), g.mesh.tets.size());
    ASSERT_EQ(g.node_map.size(), g.mesh.positions.size());
    for (std::size_t i = 0; i < g.node_map.size(); ++i) EXPECT_EQ(g.mesh.positions[i], r.mesh.positions[g.node_map[i]]);
    for (std::size_t e = 0; e < g.tet_map.size(); ++e)
      for (int k = 0; k < 4; ++k) EXPECT_EQ(g.node_map[g.mesh.tets[e][k]], r.mesh.tets[g.tet_map[e]][k]);
    // Recompute from the parent's tets directly.
    TetMesh own;
    own.positions = r.mesh.positions;
    for (Index e : g.tet_map) own.tets.push_back(r.mesh.tets[e]);
    const MassProperties p = mass_properties(own, rho);
    EXPECT_NEAR(g.mass.mass, p.mass, 1e-12 * p.mass);
    EXPECT_LT((g.mass.center - p.center).norm(), 1e-12);
    EXPECT_LT((g.mass.inertia - p.inertia).norm(), 1e-10 * p.inertia.norm());
    EXPECT_TRUE(test::mesh_is_valid(g.mesh));
    mass += g.mass.mass;
    moment += g.mass.mass * g.mass.center;
  }
  EXPECT_NEAR(mass, rho * 3.0, 1e-12 * rho * 3.0);
  EXPECT_LT((moment / mass - whole.center).norm(), 1e-12);
}

}  // namespace
}  // namespace shatter
