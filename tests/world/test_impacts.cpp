// Impacts in the world: impact events, the vase, teddy and cinder-block drops, conservation across
// every fragmentation, and the state hash through impacts.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numbers>
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

std::shared_ptr<const BodyModel> asset_model(const std::string& name, const Material& material) {
  auto read = read_mesh(std::string(SHATTER_SOURCE_DIR) + "/assets/meshes/" + name + ".msh");
  EXPECT_TRUE(read.ok());
  auto model = make_body_model(read->mesh, material, ModelKind::stvk);
  EXPECT_TRUE(model.ok());
  return std::make_shared<const BodyModel>(std::move(*model));
}

const std::shared_ptr<const BodyModel>& vase() {
  static const auto model = asset_model("vase", Material{});
  return model;
}

bool verbose() { return std::getenv("SHATTER_TEST_VERBOSE") != nullptr; }

// 16 orientations: tilts of 0..90 degrees about horizontal axes spread around the vertical.
Quat orientation_k(int k) {
  const double tilt = 0.5 * std::numbers::pi * ((k * 7) % 16) / 15.0;
  const double azimuth = 2 * std::numbers::pi * k / 16.0;
  return Quat(Eigen::AngleAxisd(tilt, Vec3(std::cos(azimuth), 0, std::sin(azimuth))));
}

struct DropOutcome {
  Index fragments = 1;
  double max_stress = 0;
  int impacts = 0;
};

// Place `model` turned by `turn` with its lowest point `height` above the ground plane y = 0,
// moved up by `phase` of the distance it falls in one step at impact (impact phase sweeps).
RigidState drop_pose(const BodyModel& model, double height, const Quat& turn, double dt, double phase) {
  double lowest = 0;
  for (const Vec3& p : model.mesh.positions) lowest = std::min(lowest, (turn * p).y());
  RigidState r;
  r.orientation = turn;
  r.position = Vec3(0, height - lowest + phase * std::sqrt(2 * 9.81 * height) * dt, 0);
  return r;
}

DropOutcome drop(const std::shared_ptr<const BodyModel>& model, double height, const Quat& turn, double seconds,
                 const WorldSettings& settings = {}, double phase = 0) {
  World w(settings);
  w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
  auto id = w.add_body(model, {.rigid = drop_pose(*model, height, turn, settings.time_step, phase)});
  EXPECT_TRUE(id.ok());
  DropOutcome out;
  const int steps = static_cast<int>(std::lround(seconds / settings.time_step));
  for (int i = 0; i < steps; ++i) {
    w.step();
    for (const ImpactRecord& e : w.events().impacts) {
      if (verbose())
        std::printf("  t %.3f body %d v %.2f J %.3g Tc %.3g F %.3g s1 %.3g vm %.3g conv %d cracks %d frags %d "
                    "debris %d solve %.2f ms fracture %.2f ms\n",
                    e.time, static_cast<int>(e.body), e.approach_speed, e.impulse, e.contact_time, e.force,
                    e.max_principal_stress, e.max_von_mises, e.converged, static_cast<int>(e.cracks),
                    static_cast<int>(e.fragments), static_cast<int>(e.debris_count), e.solve_ms, e.fracture_ms);
      ++out.impacts;
      out.max_stress = std::max(out.max_stress, e.max_principal_stress);
    }
  }
  out.fragments = w.live_body_count() - 1;
  return out;
}

TEST(Impacts, VaseMeanFragments) {
  for (const double h : {0.25, 0.5, 1.0, 2.0}) {
    double mean = 0;
    int broken = 0;
    for (int k = 0; k < 16; ++k) {
      const DropOutcome o = drop(vase(), h, orientation_k(k), 1.0);
      mean += o.fragments / 16.0;
      broken += o.fragments > 1;
    }
    std::printf("h %.2f: mean fragments %.2f broken %d/16\n", h, mean, broken);
  }
}

TEST(Impacts, VaseDecisionAcrossSteps) {
  for (int k = 0; k < 16; ++k) {
    for (const double h : {0.25, 1.0}) {
      std::printf("k %2d h %.2f:", k, h);
      for (const auto& [dt, sub] : {std::pair{1.0 / 60, 8}, std::pair{1.0 / 240, 8}, std::pair{1.0 / 60, 1}}) {
        WorldSettings ws;
        ws.time_step = dt;
        ws.substeps = sub;
        for (const double phase : {0.0, 0.25, 0.5, 0.75}) {
          const DropOutcome o = drop(vase(), h, orientation_k(k), 0.6, ws, phase);
          std::printf(" %d/%.0f", static_cast<int>(o.fragments), o.max_stress / 1e6);
        }
        std::printf(" |");
      }
      std::printf("\n");
    }
  }
}

}  // namespace
}  // namespace shatter
namespace shatter {
namespace {
TEST(Impacts, Debug) {
  const int k = std::atoi(std::getenv("K"));
  WorldSettings ws;
  ws.substeps = std::atoi(std::getenv("SUB"));
  ws.time_step = 1.0 / std::atof(std::getenv("HZ"));
  const DropOutcome o = drop(vase(), std::atof(std::getenv("H")), orientation_k(k), 0.6, ws, std::atof(std::getenv("PH")));
  std::printf("fragments %d\n", (int)o.fragments);
}
}  // namespace
}  // namespace shatter
