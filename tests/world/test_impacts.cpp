// Impacts in the world: impact events, the vase, teddy and cinder-block drops, conservation across
// every fragmentation, and the state hash through impacts.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "shatter/collide/convex_hull.h"
#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/validate.h"
#include "shatter/meshing/mesh_shape.h"
#include "shatter/meshing/shape_json.h"
#include "shatter/rigid/body.h"
#include "shatter/rigid/impact.h"
#include "shatter/world/world.h"
#include "support/test_support.h"
#include "world/world_scenes.h"

namespace shatter {
namespace {

std::shared_ptr<const BodyModel> asset_model(const std::string& name, const Material& material,
                                             ModelKind kind = ModelKind::stvk) {
  auto read = read_mesh(std::string(SHATTER_SOURCE_DIR) + "/assets/meshes/" + name + ".msh");
  EXPECT_TRUE(read.ok());
  auto model = make_body_model(read->mesh, material, kind);
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
        std::printf(
            "  t %.3f body %d v %.2f J %.3g Tc %.3g F %.3g s1 %.3g vm %.3g conv %d cracks %d frags %d "
            "debris %d solve %.2f ms fracture %.2f ms\n",
            e.time, static_cast<int>(e.body.index), e.approach_speed, e.impulse, e.contact_time, e.force,
            e.max_principal_stress, e.max_von_mises, e.converged, static_cast<int>(e.cracks),
            static_cast<int>(e.fragments), static_cast<int>(e.debris_count), e.solve_ms, e.fracture_ms);
      ++out.impacts;
      out.max_stress = std::max(out.max_stress, e.max_principal_stress);
      EXPECT_EQ(e.yield_scale, 1.0);  // porcelain and stone do not yield: Hertz's load
    }
  }
  out.fragments = w.live_body_count() - 1;
  return out;
}

// Mean fragment count of the vase over the 16 orientations at each height.
double mean_fragments(const std::shared_ptr<const BodyModel>& model, double height, int* broken = nullptr) {
  double mean = 0;
  for (int k = 0; k < 16; ++k) {
    const DropOutcome o = drop(model, height, orientation_k(k), 1.0);
    mean += static_cast<double>(o.fragments) / 16.0;
    if (broken) *broken += o.fragments > 1;
  }
  return mean;
}

TEST(Impacts, VaseBreaksMoreFromHigher) {
  for (int k = 0; k < 16; ++k) EXPECT_EQ(drop(vase(), 0.05, orientation_k(k), 0.5).fragments, 1) << "orientation " << k;
  double last = 1.0;
  for (const double h : {0.25, 0.5, 1.0, 2.0}) {
    int broken = 0;
    const double mean = mean_fragments(vase(), h, &broken);
    std::printf("vase from %.2f m: mean fragments %.2f, broken %d/16\n", h, mean, broken);
    EXPECT_GE(mean, last) << "height " << h;
    last = mean;
    if (h == 1.0) {
      EXPECT_GE(broken, 12);
      EXPECT_GE(mean, 2.0);
    }
  }
}

// The break decision does not depend on the step, the substeps or where in a step the impact falls.
TEST(Impacts, VaseDecisionIndependentOfStepAndPhase) {
  struct Config {
    double dt;
    int substeps;
  };
  const Config configs[] = {{1.0 / 60, 8}, {1.0 / 240, 8}, {1.0 / 60, 1}, {1.0 / 240, 1}};
  auto broke = [&](int k, double h, const Config& c, double phase) {
    WorldSettings ws;
    ws.time_step = c.dt;
    ws.substeps = c.substeps;
    return drop(vase(), h, orientation_k(k), 0.6, ws, phase).fragments > 1;
  };
  for (const int k : {3, 8, 12}) {
    for (const Config& c : configs)
      for (const double phase : {0.0, 0.25, 0.5, 0.75}) {
        EXPECT_FALSE(broke(k, 0.25, c, phase)) << "k " << k << " dt " << c.dt << " substeps " << c.substeps;
        EXPECT_TRUE(broke(k, 1.0, c, phase)) << "k " << k << " dt " << c.dt << " substeps " << c.substeps;
      }
  }
  for (int p = 0; p < 16; ++p) {
    EXPECT_FALSE(broke(12, 0.25, configs[0], p / 16.0)) << "phase " << p << "/16";
    EXPECT_TRUE(broke(12, 1.0, configs[0], p / 16.0)) << "phase " << p << "/16";
  }
}

// The lowest of `heights` from which the vase turned by orientation k breaks (inf: none).
double lowest_breaking_height(const std::shared_ptr<const BodyModel>& model, int k,
                              const std::vector<double>& heights) {
  for (const double h : heights)
    if (drop(model, h, orientation_k(k), 0.8).fragments > 1) return h;
  return std::numeric_limits<double>::infinity();
}

// Refinement: the vase meshed with ten times the tets breaks from about the same height.
TEST(Impacts, VaseBreakHeightHoldsUnderRefinement) {
  auto shape = read_shape_json(std::string(SHATTER_SOURCE_DIR) + "/assets/shapes/vase.json");
  ASSERT_OK(shape);
  MeshShapeDef def;
  def.stuffing.target_tets = shape->target_tets * 10;
  auto meshed = mesh_shape(shape->sdf, def, "vase");
  ASSERT_OK(meshed);
  auto fine_model = make_body_model(meshed->mesh, Material{});
  ASSERT_OK(fine_model);
  const auto fine = std::make_shared<const BodyModel>(std::move(*fine_model));
  EXPECT_GT(fine->mesh.num_tets(), 8 * vase()->mesh.num_tets());
  const std::vector<double> heights = {0.25, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 2.8, 4.0};
  for (const int k : {3, 12}) {
    const double coarse_h = lowest_breaking_height(vase(), k, heights);
    const double fine_h = lowest_breaking_height(fine, k, heights);
    std::printf("orientation %d: lowest breaking height x1 %.2f m, x10 %.2f m\n", k, coarse_h, fine_h);
    ASSERT_TRUE(std::isfinite(coarse_h));
    EXPECT_LE(fine_h, 2.0 * coarse_h);
    EXPECT_GE(fine_h, 0.5 * coarse_h);
  }
}

// Sum of masses of the live dynamic bodies plus what the debris rules removed.
double live_mass(const World& w, double debris) {
  double m = debris;
  for (Index slot = 0; slot < w.body_count(); ++slot) {
    const BodyId i = w.body_id(slot);
    if (!w.removed(i) && w.body_type(i) == BodyType::dynamic && w.model(i)) m += w.model(i)->mass.mass;
  }
  return m;
}

// Every fragmentation keeps the mass (with the debris) and the parent's momentum; children move as
// eq. 22 says.
TEST(Impacts, FragmentationsConserveMassAndMomentum) {
  World w;
  w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
  RigidState r = drop_pose(*vase(), 2.0, orientation_k(2), 1.0 / 60, 0);
  r.angular_velocity = Vec3(0.5, 2, -1);
  r.linear_velocity = Vec3(0.3, 0, 0.1);
  ASSERT_OK(w.add_body(vase(), {.rigid = r}));
  const double mass0 = vase()->mass.mass;
  double debris = 0;
  int fragmentations = 0;
  for (int step = 0; step < 90; ++step) {
    w.step();
    const StepEvents& ev = w.events();
    for (const ImpactRecord& e : ev.impacts) debris += e.debris_mass;
    for (const BodyId parent : ev.removed) {
      ++fragmentations;
      const RigidState& p = w.rigid_state(parent);
      const MassProperties& pm = w.model(parent)->mass;
      Vec3 linear = Vec3::Zero(), angular = Vec3::Zero();
      double child_mass = 0;
      for (const FragmentRecord& f : ev.fragments) {
        if (f.parent != parent) continue;
        const RigidState& c = w.rigid_state(f.body);
        const MassProperties& cm = w.model(f.body)->mass;
        child_mass += cm.mass;
        EXPECT_EQ(w.parent(f.body), parent);
        EXPECT_LT((c.angular_velocity - p.angular_velocity).norm(), 1e-12);
        EXPECT_LT((c.linear_velocity - (p.linear_velocity + p.angular_velocity.cross(c.position - p.position))).norm(),
                  1e-12);
        const Mat3 R = c.orientation.toRotationMatrix();
        linear += cm.mass * c.linear_velocity;
        angular += cm.mass * c.position.cross(c.linear_velocity) + R * cm.inertia * R.transpose() * c.angular_velocity;
      }
      double event_debris = 0;
      for (const ImpactRecord& e : ev.impacts)
        if (e.body == parent) event_debris = e.debris_mass;
      EXPECT_NEAR(child_mass + event_debris, pm.mass, 1e-12 * pm.mass);
      if (event_debris == 0) {
        const Mat3 R = p.orientation.toRotationMatrix();
        const Vec3 p_linear = pm.mass * p.linear_velocity;
        const Vec3 p_angular =
            pm.mass * p.position.cross(p.linear_velocity) + R * pm.inertia * R.transpose() * p.angular_velocity;
        EXPECT_LT((linear - p_linear).norm(), 1e-9 * std::max(1.0, p_linear.norm()));
        EXPECT_LT((angular - p_angular).norm(), 1e-9 * std::max(1.0, p_angular.norm()));
      }
    }
    EXPECT_NEAR(live_mass(w, debris), mass0, 1e-12 * mass0) << "step " << step;
  }
  EXPECT_GE(fragmentations, 1);
  std::printf("%d fragmentations, %d bodies live\n", fragmentations, static_cast<int>(w.live_body_count()));
  // Every live piece is a valid mesh above the ground.
  for (Index slot = 1; slot < w.body_count(); ++slot) {
    const BodyId i = w.body_id(slot);
    if (w.removed(i)) continue;
    EXPECT_FALSE(validate_mesh(w.model(i)->mesh).has_errors());
    EXPECT_GT(w.rigid_state(i).position.y(), -0.01);
    // Its convex pieces, built anew or kept from the parent's and moved into the fragment's frame,
    // are hulls of its own nodes: each vertex is a node (bitwise), each node is inside a piece.
    const std::vector<Vec3>& nodes = w.model(i)->mesh.positions;
    std::set<std::array<double, 3>> node_set;
    for (const Vec3& x : nodes) node_set.insert({x.x(), x.y(), x.z()});
    for (const ConvexHull& piece : w.pieces(i)) {
      EXPECT_EQ(check_convex_hull(piece, piece.tolerance), "");
      for (const Vec3& v : piece.vertices) EXPECT_TRUE(node_set.contains({v.x(), v.y(), v.z()}));
    }
    for (const Vec3& x : nodes) {
      bool inside = false;
      for (const ConvexHull& piece : w.pieces(i)) {
        bool in = true;
        for (const HullFace& f : piece.faces) in = in && f.normal.dot(x) - f.offset <= 2 * piece.tolerance;
        inside = inside || in;
      }
      EXPECT_TRUE(inside);
    }
  }
}

TEST(Impacts, ClayTeddyDentsMoreWithEachDrop) {
  static const auto teddy = asset_model("teddy", *material_preset("modelling_clay"), ModelKind::corotated);
  World w;
  w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
  // Modelling clay stretches far before it tears.
  auto clay = std::make_shared<ImpactSettings>();
  clay->fracture.plasticity.max_plastic_strain = 1.0;
  auto added = w.add_body(teddy, {.rigid = drop_pose(*teddy, 0.5, Quat::Identity(), 1.0 / 60, 0), .impact = clay});
  ASSERT_OK(added);
  const BodyId id = *added;
  double last_strain = 0, last_change = 0;
  const TetMesh& rest0 = teddy->mesh;
  for (int drop_no = 0; drop_no < 5; ++drop_no) {
    int impacts = 0;
    for (int step = 0; step < 45; ++step) {
      w.step();
      impacts += static_cast<int>(w.events().impacts.size());
      for (const ImpactRecord& e : w.events().impacts) {
        if (verbose())
          std::printf(
              "  v %.2f F %.3g s1 %.3g vm %.3g conv %d (load %.3f, %d iterations) cracks %d frags %d dented %d "
              "solve %.1f ms %.1f ms\n",
              e.approach_speed, e.force, e.max_principal_stress, e.max_von_mises, e.converged, e.load_fraction,
              e.newton_iterations, (int)e.cracks, (int)e.fragments, e.dented, e.solve_ms, e.fracture_ms);
        // The record says how much of the load its equilibrium carries (StVK clay under a landing
        // cannot carry all of it, docs/impacts.md "Limits"); every landing here dents, so some.
        EXPECT_GE(e.newton_iterations, 1);
        // Clay yields at any landing speed worth analysing: the load is below the elastic one.
        EXPECT_LT(e.yield_scale, 1.0);
        EXPECT_GT(e.yield_scale, 0.0);
        EXPECT_GT(e.load_fraction, 0.0);
        EXPECT_LE(e.load_fraction, 1.0);
        if (e.converged) {
          EXPECT_EQ(e.load_fraction, 1.0);
        }
      }
      EXPECT_TRUE(w.events().removed.empty());
    }
    ASSERT_FALSE(w.removed(id));
    EXPECT_GE(impacts, 1) << "drop " << drop_no;
    double strain = 0;
    for (const double e : w.plastic_strain(id)) strain += e;
    // Rest-shape change: nodes against the first rest shape, in texture (material) coordinates.
    const BodyModel& m = *w.model(id);
    ASSERT_EQ(m.mesh.num_nodes(), rest0.num_nodes());
    double change = 0;
    for (Index i = 0; i < m.mesh.num_nodes(); ++i)
      change += ((m.mesh.positions[i] + m.material_origin) - (rest0.positions[i] + teddy->material_origin)).norm();
    std::printf("drop %d: plastic strain sum %.4g, rest change %.4g m\n", drop_no, strain, change);
    EXPECT_GT(strain, last_strain);
    EXPECT_GT(change, last_change);
    EXPECT_NEAR(m.mass.mass, teddy->mass.mass, 1e-12 * teddy->mass.mass);
    last_strain = strain;
    last_change = change;
    // Lift it again.
    ASSERT_OK(w.set_rigid_state(id, drop_pose(m, 0.5, w.rigid_state(id).orientation, 1.0 / 60, 0)));
  }
}

// The impact solves' tangent by the body's model (TangentKind::by_model): a StVK body's stiffness
// is always projected, a corotated body's is exact and projected only on demand. The clay teddy's
// first landing (0.5 m): the corotated solve converges at the full load within a few iterations,
// quadratically at the end; always projected, it converges linearly, in at least twice as many.
TEST(Impacts, CorotatedBodiesSolveWithTheExactStiffness) {
  const Material clay = *material_preset("modelling_clay");
  auto first_landing = [&](ModelKind kind, std::optional<TangentKind> tangent) {
    const auto teddy = asset_model("teddy", clay, kind);
    BodyState state = make_body_state(*teddy);
    Vec3 low = teddy->mesh.positions[0];
    for (const Vec3& p : teddy->mesh.positions)
      if (p.y() < low.y()) low = p;
    const ImpactContact contact{.point = low, .normal = Vec3::UnitY(), .normal_impulse = 27.5, .approach_speed = 3.1};
    ImpactSettings settings;
    settings.fracture.plasticity.max_plastic_strain = 1.0;
    settings.solver.record_history = true;
    if (tangent) settings.solver.tangent = *tangent;
    auto r = analyze_impact(*teddy, state, std::span(&contact, 1), settings);
    EXPECT_OK(r);
    return r.ok() ? r->solve : StaticReport{};
  };
  EXPECT_EQ(ImpactSettings{}.solver.tangent, TangentKind::by_model);
  const StaticReport corotated = first_landing(ModelKind::corotated, std::nullopt);
  EXPECT_TRUE(corotated.converged) << corotated.message;
  EXPECT_EQ(corotated.load_fraction, 1.0);
  EXPECT_LE(corotated.newton_iterations, 8);
  EXPECT_LT(corotated.projected_iterations, corotated.newton_iterations);
  // The last residuals fall faster than linearly.
  const std::vector<NewtonIteration>& h = corotated.history;
  ASSERT_GE(h.size(), 3u);
  const double r0 = h[h.size() - 3].relative_residual, r1 = h[h.size() - 2].relative_residual,
               r2 = h.back().relative_residual;
  EXPECT_LT(r2 / r1, 0.1 * r1 / r0);

  const StaticReport projected = first_landing(ModelKind::corotated, TangentKind::projected);
  EXPECT_EQ(projected.projected_iterations, projected.newton_iterations);
  EXPECT_GE(projected.newton_iterations, 2 * corotated.newton_iterations);
  const StaticReport stvk = first_landing(ModelKind::stvk, std::nullopt);
  EXPECT_EQ(stvk.projected_iterations, stvk.newton_iterations);  // by model: projected
  EXPECT_FALSE(stvk.converged);  // StVK's compressive softening: no equilibrium at the full load
  EXPECT_LT(stvk.load_fraction, 1.0);
}

// Both blocks break in one step: their two analyses run side by side on two threads, and the
// world comes out the same as on one.
TEST(Impacts, CinderBlockDroppedOnAnotherBreaksIt) {
  static const auto block = asset_model("cinder_block", *material_preset("concrete"));
  auto run = [&](int threads) -> std::uint64_t {
    const int saved = num_threads();
    set_num_threads(threads);
    World w;
    w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
    const RigidState lower = drop_pose(*block, 0.0005, Quat::Identity(), 1.0 / 60, 0);
    auto lower_id = w.add_body(block, {.rigid = lower});
    EXPECT_TRUE(lower_id.ok());
    RigidState upper = lower;
    upper.position.y() += 0.19 + 1.0;
    upper.orientation = Quat(Eigen::AngleAxisd(0.5 * std::numbers::pi, Vec3::UnitY()));
    auto upper_id = w.add_body(block, {.rigid = upper});
    EXPECT_TRUE(upper_id.ok());
    int impacts = 0;
    bool both_in_one_step = false;
    // The lower block's break in the events: its cracks, its fragments and debris, its removal.
    int lower_cracks = 0, lower_cracks_counted = 0, lower_removed = 0;
    double lower_pieces_mass = 0;
    for (int step = 0; step < 60; ++step) {
      w.step();
      std::set<Index> analysed;
      for (const ImpactRecord& e : w.events().impacts) {
        ++impacts;
        analysed.insert(e.body.index);
        // Every static solve converges, the pieces' too (pieces hit along their length are held by
        // inertia relief, not clamped at one end).
        EXPECT_TRUE(e.converged) << "t " << e.time << " body " << e.body.index;
        if (e.body == *lower_id) {
          lower_cracks_counted += static_cast<int>(e.cracks);
          lower_pieces_mass += e.debris_mass;
        }
      }
      for (const CrackRecord& c : w.events().cracks) {
        if (c.body != *lower_id) continue;
        ++lower_cracks;
        EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
        EXPECT_TRUE(c.origin.allFinite());
        EXPECT_GT(c.radius, 0);
        EXPECT_GT(c.stress, 0);  // a tension (each tet has its own strength: no fixed bound)
      }
      for (const FragmentRecord& f : w.events().fragments)
        if (f.parent == *lower_id) lower_pieces_mass += f.mass;
      for (const BodyId r : w.events().removed) lower_removed += r == *lower_id;
      both_in_one_step |= analysed.count(lower_id->index) > 0 && analysed.count(upper_id->index) > 0;
    }
    EXPECT_TRUE(w.removed(*lower_id)) << "the lower block did not break";
    EXPECT_GE(lower_cracks, 1);
    EXPECT_EQ(lower_cracks, lower_cracks_counted);
    EXPECT_EQ(lower_removed, 1);
    EXPECT_NEAR(lower_pieces_mass, block->mass.mass, 1e-12 * block->mass.mass);  // fragments and debris
    EXPECT_TRUE(both_in_one_step);
    EXPECT_GE(impacts, 2);
    set_num_threads(saved);
    return w.state_hash();
  };
  EXPECT_EQ(run(2), run(1));
}

TEST(Impacts, RestingBodiesNeverCrack) {
  World w;
  w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
  ASSERT_OK(w.add_body(vase(), {.rigid = drop_pose(*vase(), 0.001, Quat::Identity(), 1.0 / 60, 0)}));
  // A tower of five porcelain blocks, placed with small gaps.
  const auto box = scenes::box_model(Vec3(0.1, 0.05, 0.1), Material{}, {2, 1, 2});
  for (int i = 0; i < 5; ++i) {
    RigidState r;
    r.position = Vec3(0.5, 0.05 + 0.1005 * i + 0.001, 0);
    ASSERT_OK(w.add_body(box, {.rigid = r}));
  }
  int impacts = 0;
  for (int step = 0; step < 60 * 60; ++step) {
    w.step();
    impacts += static_cast<int>(w.events().impacts.size());
  }
  EXPECT_EQ(impacts, 0);
  EXPECT_EQ(w.live_body_count(), 7);
}

// A block dropped onto one resting on the ground: neither block's impact is faster than the fall.
// The solver hands the blow down the stack within a substep; the approach speed must not count
// the impulses it applies on the way (measure_approach).
TEST(Impacts, ABlowThroughAStackIsNoFasterThanTheFall) {
  World w;
  w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
  const Material unbreakable{.name = "custom", .youngs_modulus = 30e9, .tensile_strength = kInfinity};
  const auto box = scenes::box_model(Vec3(0.2, 0.1, 0.1), unbreakable, {4, 2, 2});
  RigidState lower;
  lower.position = Vec3(0, 0.1005, 0);
  auto lower_id = w.add_body(box, {.rigid = lower});
  ASSERT_OK(lower_id);
  for (int step = 0; step < 30; ++step) w.step();  // settled on the ground
  const double height = 1.0;
  RigidState upper;
  upper.position = Vec3(0, 0.3 + height, 0);
  upper.orientation = Quat(Eigen::AngleAxisd(0.5 * std::numbers::pi, Vec3::UnitY()));
  auto upper_id = w.add_body(box, {.rigid = upper});
  ASSERT_OK(upper_id);
  const double fall = std::sqrt(2 * 9.81 * height);
  double lower_impact = 0, upper_impact = 0;
  for (int step = 0; step < 40; ++step) {
    w.step();
    for (const ImpactRecord& e : w.events().impacts) {
      if (e.body == *lower_id) lower_impact = std::max(lower_impact, e.approach_speed);
      if (e.body == *upper_id) upper_impact = std::max(upper_impact, e.approach_speed);
    }
  }
  std::printf("fall %.2f m/s: the upper block's impact %.2f m/s, the lower block's %.2f m/s\n", fall, upper_impact,
              lower_impact);
  EXPECT_GT(upper_impact, 0.95 * fall);
  EXPECT_LT(upper_impact, 1.02 * fall);
  EXPECT_GT(lower_impact, 0.5 * fall);  // analysed: it takes the blow between the block and the ground
  EXPECT_LT(lower_impact, 1.02 * fall);
}

std::uint64_t vase_drop_hash(int threads, int restore_at) {
  const int saved = num_threads();
  set_num_threads(threads);
  WorldSettings ws;
  ws.parallel_min_pairs = 0;  // every parallel loop on, so thread counts really differ
  ws.parallel_min_bodies = 0;
  World w(ws);
  w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
  EXPECT_TRUE(w.add_body(vase(), {.rigid = drop_pose(*vase(), 2.0, orientation_k(2), 1.0 / 60, 0)}).ok());
  WorldSnapshot snap;
  const int steps = 80;
  for (int i = 0; i < steps; ++i) {
    if (i == restore_at) snap = w.save();
    w.step();
  }
  if (restore_at >= 0) {
    const std::uint64_t first = w.state_hash();
    EXPECT_TRUE(w.restore(snap).ok());
    for (int i = restore_at; i < steps; ++i) w.step();
    EXPECT_EQ(w.state_hash(), first);
  }
  EXPECT_GT(w.live_body_count(), 2);  // it broke
  set_num_threads(saved);
  return w.state_hash();
}

// The seed: a porcelain vase whose strength scatters (Weibull modulus 8) dropped with several
// seeds breaks differently; the same seed gives the same world on any thread count; fragments keep
// their parent tets' strengths; without scatter the seed changes nothing.
TEST(Impacts, TheSeedDrawsEachTetsStrength) {
  Material scattered;
  scattered.weibull_modulus = 8;
  const auto model = asset_model("vase", scattered);
  struct Outcome {
    std::uint64_t hash = 0;
    Index live = 0;
  };
  auto run = [&](const std::shared_ptr<const BodyModel>& m, std::uint64_t seed, int threads) {
    const int saved = num_threads();
    set_num_threads(threads);
    WorldSettings ws;
    ws.seed = seed;
    World w(ws);
    w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
    const BodyId id = w.add_body(m, {.rigid = drop_pose(*m, 1.5, orientation_k(2), ws.time_step, 0)}).value();
    const std::vector<double> drawn(w.tensile_strength(id).begin(), w.tensile_strength(id).end());
    EXPECT_EQ(drawn.size(), m == model ? m->mesh.tets.size() : 0u);
    for (int i = 0; i < 60; ++i) w.step();
    // Every live piece's tets carry strengths drawn for the vase.
    std::vector<double> sorted = drawn;
    std::sort(sorted.begin(), sorted.end());
    for (Index slot = 0; slot < w.body_count(); ++slot) {
      const BodyId b = w.body_id(slot);
      if (w.removed(b) || !w.model(b)) continue;
      const auto s = w.tensile_strength(b);
      EXPECT_EQ(s.size(), drawn.empty() ? 0u : w.model(b)->mesh.tets.size());
      for (const double v : s) EXPECT_TRUE(std::binary_search(sorted.begin(), sorted.end(), v));
    }
    set_num_threads(saved);
    return Outcome{w.state_hash(), w.live_body_count()};
  };
  const Outcome first = run(model, 1, 1);
  EXPECT_EQ(run(model, 1, 2).hash, first.hash);
  std::set<std::uint64_t> hashes{first.hash};
  std::set<Index> counts{first.live};
  for (std::uint64_t seed = 2; seed <= 4; ++seed) {
    const Outcome o = run(model, seed, 2);
    hashes.insert(o.hash);
    counts.insert(o.live);
  }
  EXPECT_EQ(hashes.size(), 4u);
  EXPECT_GE(counts.size(), 2u) << "four seeds, and every drop broke the same way";
  EXPECT_GT(*counts.rbegin(), 2);                             // it broke
  EXPECT_EQ(run(vase(), 1, 1).hash, run(vase(), 2, 1).hash);  // one strength: nothing to draw
}

// Two bodies of one model draw independent strengths: not the same numbers, nor the same numbers a
// few tets apart (as streams started a fixed step apart in one generator's sequence would be).
TEST(Impacts, BodiesDrawIndependentStrengths) {
  Material scattered;
  scattered.weibull_modulus = 8;
  const auto model = asset_model("vase", scattered);
  World w(WorldSettings{.seed = 5});
  const BodyId a = w.add_body(model, {}).value();
  const BodyId b = w.add_body(model, {.rigid = {.position = Vec3(1, 0, 0)}}).value();
  const auto sa = w.tensile_strength(a), sb = w.tensile_strength(b);
  ASSERT_EQ(sa.size(), model->mesh.tets.size());
  ASSERT_EQ(sb.size(), sa.size());
  for (std::size_t shift = 0; shift < 8; ++shift) {
    std::size_t equal_ab = 0, equal_ba = 0;
    for (std::size_t e = 0; e + shift < sa.size(); ++e) {
      equal_ab += sa[e + shift] == sb[e];
      equal_ba += sb[e + shift] == sa[e];
    }
    EXPECT_EQ(equal_ab, 0u) << "shift " << shift;
    EXPECT_EQ(equal_ba, 0u) << "shift " << shift;
  }
}

TEST(Impacts, StateHashSameOnAnyThreadCountAndThroughRestore) {
  const std::uint64_t one = vase_drop_hash(1, -1);
  EXPECT_EQ(vase_drop_hash(2, -1), one);
  EXPECT_EQ(vase_drop_hash(4, -1), one);
  EXPECT_EQ(vase_drop_hash(2, 30), one);  // saved before the impact, restored after it
}

// Random drops and throws of every asset in every material preset, a soft body among them, and
// the tools (hammer blows, presses, saw cuts) on random bodies at random times: no NaN, no invalid
// mesh, nothing through the ground at any step, mass kept (the debris counted). SHATTER_SOAK=N
// runs N rounds (default 3, 1 under sanitizers); SHATTER_SOAK_SEED=S draws them from another seed.
TEST(Impacts, Soak) {
  const char* env = std::getenv("SHATTER_SOAK");
#if defined(SHATTER_TEST_SANITIZED)
  const int default_rounds = 1;  // ten times slower under the sanitizers
#else
  const int default_rounds = 3;
#endif
  const int rounds = env ? std::max(1, std::atoi(env)) : default_rounds;
  const std::vector<std::string> assets = {"vase",  "cinder_block", "blob",  "bowl",
                                           "plate", "column",       "teddy", "wall_slab"};
  const std::vector<std::string> materials = material_preset_names();
  const char* seed = std::getenv("SHATTER_SOAK_SEED");
  Random rng(seed ? std::strtoull(seed, nullptr, 10) : 20261201);
  int blows = 0;
  for (int round = 0; round < rounds; ++round) {
    World w;
    w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
    double mass0 = 0;
    for (int b = 0; b < 3; ++b) {
      const std::string& name = assets[rng.below(assets.size())];
      const std::string& mat = materials[rng.below(materials.size())];
      const auto model = asset_model(name, *material_preset(mat));
      // Braces draw left to right (a parenthesised call leaves its arguments' order to the compiler).
      const Quat turn(Eigen::AngleAxisd{rng.uniform(0, 3.14),
                                        Vec3{rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)}.normalized()});
      RigidState r = drop_pose(*model, rng.uniform(0.2, 3.0), turn, 1.0 / 60, 0);
      r.position.x() = 0.6 * b;
      r.linear_velocity = Vec3{rng.uniform(-3, 3), rng.uniform(-5, 1), rng.uniform(-3, 3)};
      r.angular_velocity = Vec3{rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5)};
      ASSERT_OK(w.add_body(model, {.rigid = r}));
      mass0 += model->mass.mass;
    }
    {  // and a soft body with full FEM dynamics thrown among them
      const Material rubber{.name = "rubber",
                            .youngs_modulus = rng.uniform(0.3e6, 3e6),
                            .poisson_ratio = 0.4,
                            .density = 1100,
                            .tensile_strength = kInfinity,
                            .yield_stress = kInfinity,
                            .fracture_toughness = kInfinity};
      const auto model = scenes::box_model(Vec3(0.15, 0.1, 0.08), rubber, {4, 3, 2});
      RigidState r = drop_pose(*model, rng.uniform(0.2, 2.0), Quat::Identity(), 1.0 / 60, 0);
      r.position.x() = rng.uniform(0, 1.2);
      r.position.z() = 0.5;
      r.linear_velocity = Vec3{rng.uniform(-2, 2), rng.uniform(-4, 0), rng.uniform(-2, 0)};
      r.angular_velocity = Vec3{rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3)};
      ASSERT_OK(w.add_body(model, {.rigid = r, .deformable = DeformableSettings{.stiffness_damping = 0.005}}));
      mass0 += model->mass.mass;
    }
    double debris = 0;
    for (int step = 0; step < 120; ++step) {
      const double before = live_mass(w, debris);
      if (step % 20 == 10) {  // a tool on a random live body, at a random point of its surface
        std::vector<BodyId> live;
        for (Index slot = 1; slot < w.body_count(); ++slot)
          if (!w.removed(w.body_id(slot))) live.push_back(w.body_id(slot));
        const BodyId id = live[rng.below(live.size())];
        const BodySurface surface = w.surface(id);
        ASSERT_FALSE(surface.positions.empty());
        const Vec3 point = surface.positions[rng.below(surface.positions.size())];
        const Vec3 inward = (w.rigid_state(id).position - point).normalized();
        const double kind = rng.uniform(0, 3);
        // Drawn one statement at a time: a call's arguments are drawn in an order each compiler picks.
        const double size = rng.uniform(0, 1);
        const double speed_or_radius = rng.uniform(0, 1);
        const double radius_or_duration = rng.uniform(0, 1);
        // Strengths for the body's mass, within what the world promises to hold (docs/method.md,
        // "No tunnelling"): a blow or a whole press changes its speed by up to 30 m/s; a press
        // pushes with up to 100 times its weight.
        const double mass = w.model(id)->mass.mass;
        if (kind < 1) {
          blows += w.strike(id, point, mass * (0.5 + 29.5 * size) * inward, 1 + 14 * speed_or_radius,
                            0.02 * radius_or_duration)
                       .ok();
        } else if (kind < 2) {
          const double force = mass * 9.81 * (10 + 90 * size);
          const double dt = w.settings().time_step;  // a press lasts whole steps
          const double duration =
              std::min(0.2 * radius_or_duration, dt * std::max(1.0, std::floor(30 * mass / force / dt)));
          blows += w.press(id, point, force * inward, 0.005 + 0.025 * speed_or_radius, duration).ok();
        } else {
          // A saw through the body's centre (a deformable body is no rigid tet body: an error).
          blows += w.slice(id, w.rigid_state(id).position, rng.uniform_vec3(-1, 1)).ok();
        }
      }
      w.step();
      for (const ImpactRecord& e : w.events().impacts) debris += e.debris_mass;
      EXPECT_NEAR(live_mass(w, debris), before, 1e-12 * mass0) << "round " << round << " step " << step;
      // Nothing through the ground at any step: every rigid piece keeps a point above it.
      for (Index slot = 1; slot < w.body_count(); ++slot) {
        const BodyId i = w.body_id(slot);
        if (w.removed(i) || w.deformable(i) || !w.model(i)) continue;
        double highest = -kInfinity;
        for (const Vec3& x : world_positions(*w.model(i), w.rigid_state(i))) highest = std::max(highest, x.y());
        EXPECT_GT(highest, 0) << "round " << round << " step " << step << " body " << i.index;
      }
    }
    EXPECT_NEAR(live_mass(w, debris), mass0, 1e-12 * mass0) << "round " << round;
    for (Index slot = 1; slot < w.body_count(); ++slot) {
      const BodyId i = w.body_id(slot);
      if (w.removed(i)) continue;
      const RigidState& r = w.rigid_state(i);
      EXPECT_TRUE(r.position.allFinite() && r.linear_velocity.allFinite() && r.angular_velocity.allFinite());
      EXPECT_GT(r.position.y(), -0.05) << "round " << round << " body " << i.index << " fell through the ground";
      EXPECT_FALSE(validate_mesh(w.model(i)->mesh).has_errors());
      for (const Vec3& x : w.node_positions(i)) {
        ASSERT_TRUE(x.allFinite());
        EXPECT_GT(x.y(), -0.05) << "round " << round << " a node of deformable body " << i.index << " fell through";
      }
    }
  }
  EXPECT_GE(blows, 3 * rounds);  // most tools reach a body (a saw on the soft body is refused)
}

TEST(Impacts, IdsOfRemovedAndRestoredBodiesAreCaught) {
  World w;
  w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
  auto vase_id = w.add_body(vase(), {.rigid = drop_pose(*vase(), 2.0, orientation_k(2), 1.0 / 60, 0)});
  ASSERT_OK(vase_id);
  const WorldSnapshot before = w.save();
  std::vector<BodyId> children;
  for (int i = 0; i < 60 && children.empty(); ++i) {
    w.step();
    for (const FragmentRecord& f : w.events().fragments) children.push_back(f.body);
  }
  ASSERT_GE(children.size(), 2U);
  EXPECT_TRUE(w.removed(*vase_id));
  EXPECT_FALSE(w.apply_impulse(*vase_id, Vec3(1, 0, 0), Vec3::Zero()).ok());  // removed
  EXPECT_FALSE(w.set_rigid_state(*vase_id, RigidState{}).ok());
  EXPECT_TRUE(w.valid(children[0]));
  EXPECT_EQ(w.parent(children[0]), *vase_id);
  EXPECT_FALSE(w.apply_impulse(children[0], Vec3(std::nan(""), 0, 0), Vec3::Zero()).ok());
  EXPECT_TRUE(w.apply_impulse(children[0], Vec3(0.1, 0, 0), w.rigid_state(children[0]).position).ok());
  // A child's surface: crack faces, rest coordinates inside the original vase's box.
  const BodySurface surf = w.surface(children[0]);
  ASSERT_EQ(surf.rest.size(), surf.positions.size());
  ASSERT_EQ(surf.crack_face.size(), surf.triangles.size());
  EXPECT_GT(std::count(surf.crack_face.begin(), surf.crack_face.end(), 1), 0);
  EXPECT_GT(std::count(surf.crack_face.begin(), surf.crack_face.end(), 0), 0);
  Aabb original;
  for (const Vec3& p : vase()->mesh.positions) original.extend(p + vase()->material_origin);
  for (const Vec3& r : surf.rest)
    EXPECT_TRUE((r.array() >= original.min.array() - 1e-9).all() && (r.array() <= original.max.array() + 1e-9).all());
  // Back to before the fall: the children's ids are stale; the vase is back; new fragments reuse
  // the slots under new generations.
  ASSERT_OK(w.restore(before));
  EXPECT_FALSE(w.valid(children[0]));
  EXPECT_FALSE(w.removed(*vase_id));
  EXPECT_FALSE(w.wake(children[0]).ok());
  std::vector<BodyId> again;
  for (int i = 0; i < 60 && again.empty(); ++i) {
    w.step();
    for (const FragmentRecord& f : w.events().fragments) again.push_back(f.body);
  }
  ASSERT_EQ(again.size(), children.size());
  EXPECT_EQ(again[0].index, children[0].index);
  EXPECT_NE(again[0].generation, children[0].generation);
  EXPECT_FALSE(w.valid(children[0]));
  EXPECT_TRUE(w.valid(again[0]));
  EXPECT_FALSE(w.exclude_pair(again[0], again[0]).ok());
  EXPECT_FALSE(w.exclude_pair(again[0], children[0]).ok());
}

TEST(Impacts, HammerBreaksAVaseOnlyWhenHardEnough) {
  for (const double speed : {1.5, 8.0}) {
    World w;
    w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
    auto id = w.add_body(vase(), {.rigid = drop_pose(*vase(), 0.0005, Quat::Identity(), 1.0 / 60, 0)});
    ASSERT_OK(id);
    for (int i = 0; i < 40; ++i) w.step();
    EXPECT_FALSE(w.awake(*id));
    // A 0.5 kg hammer swung at `speed` into the belly, sideways.
    const Vec3 belly = w.rigid_state(*id).position + Vec3(-0.088, 0, 0);
    ASSERT_OK(w.strike(*id, belly, Vec3(0.5 * speed, 0, 0), speed));
    w.step();
    ASSERT_EQ(w.events().impacts.size(), 1U);
    const ImpactRecord& e = w.events().impacts[0];
    EXPECT_EQ(e.body, *id);
    EXPECT_EQ(e.other.index, -1);
    std::printf("hammer at %.1f m/s: force %.3g N, stress %.3g Pa, %d fragments\n", speed, e.force,
                e.max_principal_stress, static_cast<int>(e.fragments));
    if (speed < 2)
      EXPECT_FALSE(w.removed(*id));
    else
      EXPECT_TRUE(w.removed(*id));
  }
  World w;
  auto id = w.add_body(vase(), {});
  ASSERT_OK(id);
  EXPECT_FALSE(w.strike(*id, Vec3::Zero(), Vec3(1, 0, 0), 0).ok());
  EXPECT_FALSE(w.strike(*id, Vec3::Zero(), Vec3(1, 0, 0), 1, -0.1).ok());
  EXPECT_FALSE(w.press(*id, Vec3::Zero(), Vec3(1, 0, 0), -1, 1).ok());
  EXPECT_FALSE(w.press(BodyId{7, 0}, Vec3::Zero(), Vec3(1, 0, 0), 0, 1).ok());
}

TEST(Impacts, PressDentsClayWhileHeld) {
  static const auto teddy = asset_model("teddy", *material_preset("modelling_clay"));
  auto clay = std::make_shared<ImpactSettings>();
  clay->fracture.plasticity.max_plastic_strain = 1.0;
  double last = 0;
  for (const double seconds : {0.05, 0.2}) {
    World w({.gravity = Vec3::Zero()});
    auto id = w.add_body(teddy, {.impact = clay});
    ASSERT_OK(id);
    // Press the front-most point backwards with 50 N on a 2 cm pad; an equal force on the back-most
    // point keeps it in place. The load is well below tearing (the largest plastic strain stays a
    // fraction of max_plastic_strain), so round-off cannot decide the outcome.
    const BodySurface surf = w.surface(*id);
    Vec3 front = surf.positions[0], back = surf.positions[0];
    for (const Vec3& p : surf.positions) {
      if (p.z() > front.z()) front = p;
      if (p.z() < back.z()) back = p;
    }
    const double force = 50;
    ASSERT_OK(w.press(*id, front, Vec3(0, 0, -force), 0.02, seconds));
    ASSERT_OK(w.press(*id, back, Vec3(0, 0, force), 0.02, seconds));
    for (int i = 0; i < 20; ++i) w.step();
    double strain = 0, peak = 0;
    for (const double e : w.plastic_strain(*id)) strain += e, peak = std::max(peak, e);
    std::printf("press held %.2f s: plastic strain sum %.4g, largest %.3g\n", seconds, strain, peak);
    EXPECT_GT(strain, last);
    EXPECT_LT(peak, 0.5 * clay->fracture.plasticity.max_plastic_strain);
    EXPECT_FALSE(w.removed(*id));
    last = strain;
  }
}

}  // namespace
}  // namespace shatter

namespace shatter {
namespace {

TEST(Impacts, AWiderHammerFaceSpreadsTheBlow) {
  // The same blow with a point-like face (Hertz's patch) and with a face of 4 cm: the wider face
  // spreads the same force over more of the surface, so the peak stress is lower.
  std::vector<double> stress;
  for (const double radius : {0.0, 0.04}) {
    World w({.enable_impacts = true});
    w.add_plane({.normal = Vec3::UnitY(), .offset = 0});
    auto id = w.add_body(vase(), {.rigid = drop_pose(*vase(), 0.0005, Quat::Identity(), 1.0 / 60, 0)});
    ASSERT_OK(id);
    for (int i = 0; i < 40; ++i) w.step();
    const Vec3 belly = w.rigid_state(*id).position + Vec3(-0.088, 0, 0);
    ASSERT_OK(w.strike(*id, belly, Vec3(0.5, 0, 0), 1.0, radius));
    w.step();
    ASSERT_EQ(w.events().impacts.size(), 1U);
    stress.push_back(w.events().impacts[0].max_principal_stress);
    std::printf("hammer face %.0f mm: force %.3g N, stress %.3g Pa\n", radius * 1000, w.events().impacts[0].force,
                stress.back());
  }
  EXPECT_LT(stress[1], 0.8 * stress[0]);
}

TEST(Impacts, SliceCutsABodyInTwoThatFlyApart) {
  const TetMesh m = make_box_mesh({.min = Vec3(-0.2, 0.3, -0.05), .max = Vec3(0.2, 0.4, 0.05), .cells = {12, 3, 3}});
  RigidState rigid;
  auto model = make_body_model(m, *material_preset("concrete"), ModelKind::stvk, &rigid);
  ASSERT_OK(model);
  World w;
  w.add_plane({});
  rigid.angular_velocity = Vec3(0, 3, 0);
  // Not breakable: the halves land without breaking further, so what is seen is the slice's.
  auto id = w.add_body(std::make_shared<const BodyModel>(std::move(*model)), {.rigid = rigid, .breakable = false});
  ASSERT_OK(id);
  w.step();
  const double mass = w.model(*id)->mass.mass;
  // Miss, then cut at the middle, vertically.
  auto miss = w.slice(*id, Vec3(5, 0, 0), Vec3::UnitX());
  ASSERT_OK(miss);
  EXPECT_EQ(*miss, 0);
  EXPECT_FALSE(w.removed(*id));
  auto pieces = w.slice(*id, w.rigid_state(*id).position, Vec3(1, 0, 0.1));
  ASSERT_OK(pieces);
  EXPECT_EQ(*pieces, 2);
  EXPECT_TRUE(w.removed(*id));
  EXPECT_EQ(w.events().cracks.size(), 1U);
  ASSERT_EQ(w.events().fragments.size(), 2U);
  double total = 0;
  for (const FragmentRecord& f : w.events().fragments) {
    total += f.mass;
    EXPECT_EQ(w.parent(f.body), *id);
  }
  EXPECT_NEAR(total, mass, 1e-12 * mass);
  // The cut's events are also the next step's (a loop that reads events() after each step sees
  // them once), and are gone the step after.
  w.step();
  EXPECT_EQ(w.events().cracks.size(), 1U);
  EXPECT_EQ(w.events().fragments.size(), 2U);
  ASSERT_EQ(w.events().removed.size(), 1U);
  EXPECT_EQ(w.events().removed[0], *id);
  w.step();
  EXPECT_TRUE(w.events().cracks.empty());
  EXPECT_TRUE(w.events().fragments.empty());
  EXPECT_TRUE(w.events().removed.empty());
  // The halves keep spinning apart, then fall and lie on the ground; nothing is lost or tunnels.
  for (int i = 0; i < 120; ++i) w.step();
  Index live = 0;
  for (Index s = 0; s < w.body_count(); ++s) {
    const BodyId b = w.body_id(s);
    if (w.removed(b) || !w.model(b)) continue;
    ++live;
    for (const Vec3& p : w.surface(b).positions) EXPECT_GT(p.y(), -0.01);
  }
  EXPECT_EQ(live, 2);
  // Errors.
  EXPECT_FALSE(w.slice(*id, Vec3::Zero(), Vec3::UnitX()).ok());           // removed
  EXPECT_FALSE(w.slice(BodyId{0, 0}, Vec3::Zero(), Vec3::UnitX()).ok());  // the ground
}

}  // namespace
}  // namespace shatter
