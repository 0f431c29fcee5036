// The fracture entry point: several cracks per load, maps and conservation, ductile tearing, and
// determinism across runs and thread counts.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "fracture_checks.h"
#include "shatter/core/parallel.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fracture/fracture.h"
#include "shatter/fracture/stress.h"
#include "shatter/mesh/generate.h"
#include "support/test_support.h"

namespace shatter {
namespace {

/// A smooth, wavy displacement field: stretched along x with a ripple, so stresses vary in space.
std::vector<Vec3> wavy(const TetMesh& m, double amplitude) {
  std::vector<Vec3> x;
  for (const Vec3& p : m.positions)
    x.push_back(p + amplitude * Vec3(p.x() + 0.3 * std::sin(7 * p.x() + 3 * p.y()), 0.2 * std::sin(5 * p.z()) * p.y(),
                                     0.1 * std::cos(4 * p.x()) * p.z()));
  return x;
}

TEST(Fracture, SeveralCracksConserveAndMap) {
  const TetMesh m = make_box_mesh({.max = Vec3(1.2, 0.3, 0.3), .cells = {24, 6, 6}, .jitter = 0.15, .seed = 5});
  const Material glass = material_preset("glass").value();
  const auto x = wavy(m, 3e-3);
  FractureOptions options;
  options.crack = {.radius_fraction = 0.25, .max_cracks = 4};
  const FractureResult r = fracture(m, make_fem_model(m, glass, ModelKind::stvk), x, options);
  ASSERT_GE(r.events.size(), 2u);
  EXPECT_GE(r.fragments.size(), 2u);
  EXPECT_TRUE(test::mesh_is_valid(r.mesh));
  EXPECT_NEAR(total_volume(r.mesh), total_volume(m), 1e-12 * total_volume(m));
  ASSERT_EQ(r.deformed.size(), r.mesh.positions.size());
  ASSERT_EQ(r.node_parent.size(), r.mesh.positions.size());
  ASSERT_EQ(r.tet_parent.size(), r.mesh.tets.size());
  ASSERT_EQ(r.plastic_strain.size(), r.mesh.tets.size());
  // Volumes of the pieces of each input tet sum to its volume.
  std::vector<double> piece_volume(m.tets.size(), 0.0);
  for (Index e = 0; e < r.mesh.num_tets(); ++e) piece_volume[r.tet_parent[e]] += signed_volume(r.mesh, e);
  for (Index e = 0; e < m.num_tets(); ++e)
    EXPECT_NEAR(piece_volume[e], signed_volume(m, e), 1e-12 * signed_volume(m, e));
  // Kept nodes deform as their parents; deformed positions of new nodes lie near their parents'.
  for (Index i = 0; i < r.mesh.num_nodes(); ++i) {
    const Index p = r.node_parent[i];
    if (r.mesh.positions[i] == m.positions[p]) {
      EXPECT_EQ(r.deformed[i], x[p]);
    }
    EXPECT_LT((r.deformed[i] - r.mesh.positions[i] - (x[p] - m.positions[p])).norm(), 1e-3);
  }
  double mass = 0;
  for (const Fragment& f : r.fragments) {
    mass += f.mass.mass;
    EXPECT_EQ(connected_components(f.mesh).count, 1);
    EXPECT_TRUE(test::mesh_is_valid(f.mesh));
  }
  EXPECT_NEAR(mass, glass.density * total_volume(m), 1e-12 * mass);
  for (const CrackEvent& ev : r.events) {
    EXPECT_GT(ev.tets_marked, 0);
    EXPECT_GT(ev.plan.stress, glass.tensile_strength);
  }
}

TEST(Fracture, DuctileTearAfterPlasticStrain) {
  const TetMesh m = make_box_mesh({.max = Vec3(0.4, 0.05, 0.05), .cells = {16, 2, 2}});
  const Material lead = material_preset("lead").value();
  std::vector<Vec3> x = m.positions;
  // Uniaxial stress of twice the yield stress (and below the tensile strength).
  const double eps = 2 * lead.yield_stress / lead.youngs_modulus;
  for (Vec3& p : x)
    p = Vec3(p.x() * (1 + eps), p.y() * (1 - lead.poisson_ratio * eps), p.z() * (1 - lead.poisson_ratio * eps));
  FractureOptions options;
  options.plasticity.max_plastic_strain = 0.1 * eps;
  options.crack.max_cracks = 1;
  const FractureResult r = fracture(m, make_fem_model(m, lead, ModelKind::stvk), x, options);
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_TRUE(r.events[0].plan.ductile);
  EXPECT_LT(r.events[0].plan.stress, lead.tensile_strength);
  EXPECT_TRUE(test::mesh_is_valid(r.mesh));
}

TEST(Fracture, TimeAveragedStressIgnoresASpike) {
  const TetMesh m = make_box_mesh({.max = Vec3(0.4, 0.05, 0.05), .cells = {16, 2, 2}});
  const Material glass = material_preset("glass").value();
  const std::vector<Mat3> load(m.tets.size(), 1.5 * glass.tensile_strength * Vec3::UnitX() * Vec3::UnitX().transpose());
  FractureOptions options;
  options.crack.max_cracks = 1;
  StressHistory spike(m.num_tets(), 0.01), sustained(m.num_tets(), 0.01);
  spike.update(load, 0.001);
  for (int i = 0; i < 30; ++i) sustained.update(load, 0.001);
  const FractureResult a = fracture_with_stress(m, make_fem_model(m, glass, ModelKind::stvk), m.positions,
                                                analyze_stresses(spike.averaged()), options);
  const FractureResult b = fracture_with_stress(m, make_fem_model(m, glass, ModelKind::stvk), m.positions,
                                                analyze_stresses(sustained.averaged()), options);
  EXPECT_TRUE(a.events.empty());
  ASSERT_EQ(b.events.size(), 1u);
  EXPECT_EQ(b.fragments.size(), 2u);
  sustained.remap(b.tet_parent);
  EXPECT_EQ(sustained.averaged().size(), b.mesh.tets.size());
}

TEST(Fracture, DeterministicAcrossRunsAndThreads) {
  const TetMesh m = make_box_mesh({.max = Vec3(1, 0.5, 0.5), .cells = {16, 8, 8}, .jitter = 0.2, .seed = 11});
  const Material glass = material_preset("glass").value();
  const auto x = wavy(m, 3e-3);
  FractureOptions options;
  options.crack = {.radius_fraction = 0.3, .max_cracks = 4};
  const int threads = num_threads();
  std::uint64_t hashes[3];
  for (int run = 0; run < 3; ++run) {
    set_num_threads(run == 0 ? 1 : 2);
    const FractureResult r = fracture(m, make_fem_model(m, glass, ModelKind::stvk), x, options);
    EXPECT_GE(r.events.size(), 1u);
    Hasher h;
    h.add(test::mesh_hash(r.mesh));
    h.add(test::fragments_hash(r.fragments));
    h.add_bytes(r.deformed.data(), r.deformed.size() * sizeof(Vec3));
    hashes[run] = h.digest();
  }
  set_num_threads(threads);
  EXPECT_EQ(hashes[0], hashes[1]);
  EXPECT_EQ(hashes[1], hashes[2]);
}

// Tets marked at rest get exactly zero stress; every other tet the bits of the full computation,
// on one thread and two (the deformed tets are regrouped, four to a vector, differently).
TEST(Stresses, AtRestTetsAreZeroAndTheOthersKeepTheirBits) {
  const TetMesh m = make_box_mesh({.max = Vec3(1, 0.5, 0.5), .cells = {16, 8, 8}, .jitter = 0.2, .seed = 5});
  const FemModel model = make_fem_model(m, material_preset("glass").value(), ModelKind::stvk);
  // Deformed only for x > 0.5: the tets wholly below stay at their rest positions.
  std::vector<Vec3> x = wavy(m, 3e-3);
  std::vector<char> at_rest(m.tets.size(), 0);
  for (std::size_t i = 0; i < x.size(); ++i)
    if (m.positions[i].x() <= 0.5) x[i] = m.positions[i];
  std::size_t resting = 0;
  for (std::size_t e = 0; e < m.tets.size(); ++e) {
    bool rest = true;
    for (const Index v : m.tets[e]) rest = rest && m.positions[v].x() <= 0.5;
    // Every third resting tet is left unmarked: it is computed, and its round-off kept.
    at_rest[e] = rest && e % 3 != 0;
    resting += at_rest[e];
  }
  ASSERT_GT(resting, m.tets.size() / 4);
  const int threads = num_threads();
  const std::vector<TetStress> full = compute_stresses(model, x);
  // Computed, most resting tets carry round-off: the mask is seen in the bits.
  std::size_t round_off = 0;
  for (std::size_t e = 0; e < full.size(); ++e) round_off += at_rest[e] && full[e].sigma != Mat3::Zero();
  EXPECT_GT(round_off, resting / 2);
  for (const int n : {1, 2}) {
    set_num_threads(n);
    const std::vector<TetStress> masked = compute_stresses(model, x, at_rest);
    ASSERT_EQ(masked.size(), full.size());
    for (std::size_t e = 0; e < full.size(); ++e) {
      const TetStress& want = at_rest[e] ? TetStress{} : full[e];
      EXPECT_EQ(std::memcmp(masked[e].sigma.data(), want.sigma.data(), sizeof(Mat3)), 0) << "tet " << e;
      EXPECT_EQ(std::memcmp(masked[e].principal.data(), want.principal.data(), sizeof(Vec3)), 0) << "tet " << e;
      EXPECT_EQ(std::memcmp(masked[e].directions.data(), want.directions.data(), sizeof(Mat3)), 0) << "tet " << e;
      EXPECT_EQ(masked[e].von_mises, want.von_mises);
      EXPECT_EQ(masked[e].display, want.display);
      // What a resting tet's computed stress would be: round-off of zero.
      if (at_rest[e]) {
        EXPECT_LT(full[e].sigma.norm(), 1e-6 * model.material.youngs_modulus);
      }
    }
  }
  set_num_threads(threads);
}

}  // namespace
}  // namespace shatter
