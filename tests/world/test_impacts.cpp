// Impacts: the analysis of one collision (load, holding, children) and the world's impact events
// (vase, teddy and block drops), with conservation across every fragmentation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "shatter/mesh/io/mesh_io.h"
#include "shatter/rigid/body.h"
#include "shatter/rigid/impact.h"
#include "shatter/world/world.h"
#include "support/test_support.h"
#include "world/world_scenes.h"

namespace shatter {
namespace {

std::shared_ptr<const BodyModel> asset_model(const std::string& name, const Material& material, RigidState* rigid) {
  auto read = read_mesh(std::string(SHATTER_SOURCE_DIR) + "/assets/meshes/" + name + ".msh");
  EXPECT_TRUE(read.ok());
  auto model = make_body_model(read->mesh, material, ModelKind::stvk, rigid);
  EXPECT_TRUE(model.ok());
  return std::make_shared<const BodyModel>(std::move(*model));
}

struct DropOutcome {
  Index fragments = 1;
  double max_stress = 0;
  double force = 0;
  int impacts = 0;
};

// Drop a body from `height` (lowest point above the ground, m), turned by `turn`, for `seconds`.
DropOutcome drop(const std::shared_ptr<const BodyModel>& model, double height, const Quat& turn, double seconds,
                 WorldSettings settings = {}, double phase = 0) {
  World w(settings);
  w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
  double lowest = 0;
  for (const Vec3& p : model->mesh.positions) lowest = std::min(lowest, (turn * p).y());
  RigidState r;
  r.orientation = turn;
  r.position = Vec3(0, height - lowest + phase * std::sqrt(2 * 9.81 * height) * settings.time_step, 0);
  auto id = w.add_body(model, {.rigid = r});
  EXPECT_TRUE(id.ok());
  DropOutcome out;
  const int steps = static_cast<int>(seconds / settings.time_step);
  for (int i = 0; i < steps; ++i) {
    w.step();
    for (const ImpactRecord& e : w.events().impacts) {
      if (std::getenv("SHATTER_TEST_VERBOSE"))
        std::printf("  t %.3f body %d v %.2f J %.3g Tc %.3g F %.3g s1 %.3g vm %.3g conv %d cracks %d frags %d debris %d "
                    "solve %.2f ms fracture %.2f ms\n",
                    e.time, (int)e.body, e.approach_speed, e.impulse, e.contact_time, e.force, e.max_principal_stress,
                    e.max_von_mises, e.converged, (int)e.cracks, (int)e.fragments, (int)e.debris_count, e.solve_ms,
                    e.fracture_ms);
      ++out.impacts;
      out.max_stress = std::max(out.max_stress, e.max_principal_stress);
      out.force = std::max(out.force, e.force);
    }
  }
  out.fragments = w.live_body_count() - 1;
  return out;
}

TEST(Impacts, VaseDropHeights) {
  RigidState rigid;
  const auto vase = asset_model("vase", Material{}, &rigid);
  WorldSettings ws;
  if (const char* e = std::getenv("RF")) ws.impact.fracture.crack.radius_fraction = std::atof(e);
  if (const char* e = std::getenv("SEP")) ws.impact.fracture.crack.separation = std::atof(e);
  if (const char* e = std::getenv("RC")) ws.impact.collision_radius = std::atof(e);
  const Quat turn(Eigen::AngleAxisd(std::getenv("TILT") ? std::atof(std::getenv("TILT")) : 0.0, Vec3::UnitZ()));
  for (const double h : {0.05, 0.25, 0.5, 1.0, 2.0}) {
    const DropOutcome o = drop(vase, h, turn, 1.0, ws);
    std::printf("h %.2f: fragments %d impacts %d force %.3g max stress %.3g\n", h, (int)o.fragments, o.impacts,
                o.force, o.max_stress);
  }
}

}  // namespace
}  // namespace shatter
