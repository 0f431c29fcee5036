// Body model and state: the body frame, world positions, and the plastic update in place against a
// model rebuilt from scratch.
#include <gtest/gtest.h>

#include <algorithm>
#include <utility>

#include "shatter/fracture/stress.h"
#include "shatter/mesh/generate.h"
#include "shatter/rigid/body.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TEST(Body, ModelIsInTheBodyFrame) {
  const TetMesh m =
      make_box_mesh({.min = Vec3(1, 2, 3), .max = Vec3(1.4, 2.2, 3.1), .cells = {4, 2, 2}, .jitter = 0.1});
  RigidState rigid;
  auto body = make_body_model(m, Material{}, ModelKind::stvk, &rigid);
  ASSERT_OK(body);
  EXPECT_LT(body->mass.center.norm(), 1e-15);
  const MassProperties world = mass_properties(m, Material{}.density);
  EXPECT_LT((rigid.position - world.center).norm(), 1e-15);
  EXPECT_NEAR(body->mass.mass, world.mass, 1e-12 * world.mass);
  EXPECT_LT((body->mass.inertia - world.inertia).norm(), 1e-9 * world.inertia.norm());
  const std::vector<Vec3> x = world_positions(*body, rigid);
  for (std::size_t i = 0; i < x.size(); ++i) EXPECT_LT((x[i] - m.positions[i]).norm(), 1e-15);
  EXPECT_EQ(body->fem.num_tets(), m.num_tets());
  EXPECT_FALSE(body->surface.triangles.empty());
  const BodyState state = make_body_state(*body, rigid);
  EXPECT_EQ(state.plastic_strain.size(), m.tets.size());
  ASSERT_NE(state.solver, nullptr);
  EXPECT_EQ(state.solver->pattern_builds(), 0);
}

TEST(Body, BadInputIsAnError) {
  EXPECT_FALSE(make_body_model(TetMesh{}, Material{}).ok());
  const TetMesh m = make_box_mesh({.max = Vec3(1, 1, 1), .cells = {1, 1, 1}});
  EXPECT_FALSE(make_body_model(m, Material{.density = -1}).ok());
  TetMesh inverted = m;
  std::swap(inverted.tets[0][0], inverted.tets[0][1]);
  EXPECT_FALSE(make_body_model(inverted, Material{}).ok());
}

TEST(Body, PlasticUpdateMatchesARebuiltModelAndKeepsTheMass) {
  const TetMesh m = make_box_mesh({.max = Vec3(0.4, 0.1, 0.1), .cells = {8, 2, 2}});
  Material clay = material_preset("modelling_clay").value();
  RigidState rigid;
  rigid.orientation = Quat(Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()));
  auto body = make_body_model(m, clay, ModelKind::stvk, &rigid);
  ASSERT_OK(body);
  BodyState state = make_body_state(*body, rigid);
  const double mass = body->mass.mass;
  // Stretch the right half past yield and let the rest shape absorb it.
  std::vector<Vec3> x = body->mesh.positions;
  for (Vec3& p : x)
    if (p.x() > 0) p.x() *= 1.05;
  const PlasticResult plastic =
      apply_plasticity(body->fem, body->mesh.positions, x, compute_stresses(body->fem, x), state.plastic_strain);
  ASSERT_FALSE(plastic.moved_nodes.empty());
  const std::vector<Vec3> before = world_positions(*body, state.rigid);
  apply_plastic_update(*body, state, plastic);
  // Mass kept, centre of mass re-centred, world positions of the kept shape unchanged.
  EXPECT_NEAR(body->mass.mass, mass, 1e-12 * mass);
  EXPECT_LT(body->mass.center.norm(), 1e-14);
  const std::vector<Vec3> after = world_positions(*body, state.rigid);
  for (Index i = 0; i < m.num_nodes(); ++i) {
    if (std::find(plastic.moved_nodes.begin(), plastic.moved_nodes.end(), i) != plastic.moved_nodes.end()) continue;
    EXPECT_LT((after[i] - before[i]).norm(), 1e-14) << i;
  }
  // The model updated in place equals one built from the new rest shape.
  const FemModel rebuilt = make_fem_model(body->mesh, clay, ModelKind::stvk);
  ASSERT_EQ(rebuilt.rest.size(), body->fem.rest.size());
  for (std::size_t e = 0; e < rebuilt.rest.size(); ++e) {
    EXPECT_EQ(rebuilt.rest[e].volume, body->fem.rest[e].volume);
    EXPECT_EQ(rebuilt.rest[e].Dm_inv, body->fem.rest[e].Dm_inv);
  }
  EXPECT_EQ(rebuilt.fast.packed, body->fem.fast.packed);
  EXPECT_EQ(state.plastic_strain, plastic.plastic_strain);
}

}  // namespace
}  // namespace shatter
