// Fragment extraction: maps and masses of the connected components of a cut mesh.
#include <gtest/gtest.h>

#include "fracture_checks.h"
#include "shatter/fracture/cut.h"
#include "shatter/fracture/fragments.h"
#include "shatter/mesh/generate.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TEST(Fragments, MapsAndMassesMatchRecomputation) {
  const TetMesh m = make_box_mesh({.max = Vec3(3, 1, 1), .cells = {6, 2, 2}, .jitter = 0.1});
  std::vector<Index> all(m.tets.size());
  for (Index e = 0; e < m.num_tets(); ++e) all[e] = e;
  CutResult r = cut_mesh(m, {.point = Vec3(1.1, 0, 0), .normal = Vec3(1, 0.1, 0).normalized()}, all);
  r = cut_mesh(r.mesh, {.point = Vec3(2.2, 0, 0), .normal = Vec3(1, 0, -0.2).normalized()}, [&] {
    std::vector<Index> a(r.mesh.tets.size());
    for (Index e = 0; e < r.mesh.num_tets(); ++e) a[e] = e;
    return a;
  }());
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
