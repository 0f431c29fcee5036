// Fracture and plasticity from static solutions: a bar in tension breaks perpendicular to its axis
// once the load passes strength x area and not before; a notched bar breaks at the notch; three-
// point bending cracks from the tensile face at mid-span; a bar past yield keeps a permanent set.
#include <gtest/gtest.h>

#include "fracture_checks.h"
#include "shatter/fem/fem_model.h"
#include "shatter/fem/material.h"
#include "shatter/fracture/fracture.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/topology.h"
#include "shatter/solve/static_solver.h"
#include "support/test_support.h"

namespace shatter {
namespace {

constexpr double kL = 0.4, kH = 0.05;

/// Nodal forces of a uniform traction (Pa, vector) on the boundary triangles whose nodes all
/// satisfy `on`.
template <class Pred>
std::vector<Vec3> traction(const TetMesh& m, const Vec3& t, Pred&& on) {
  std::vector<Vec3> f(m.positions.size(), Vec3::Zero());
  const TriSurface s = boundary_surface(m);
  for (const TriIndices& tri : s.triangles) {
    const Vec3 &a = s.positions[tri[0]], &b = s.positions[tri[1]], &c = s.positions[tri[2]];
    if (!on(a) || !on(b) || !on(c)) continue;
    const double area = 0.5 * (b - a).cross(c - a).norm();
    for (Index v : tri) f[s.vertex_node[v]] += area / 3.0 * t;
  }
  return f;
}

/// Bar along x, left end held in x only (free lateral contraction) plus two nodes against rigid
/// motion, pulled by a uniform traction on the right end.
std::vector<Vec3> pull(const TetMesh& m, const Material& mat, double stress) {
  const FemModel model = make_fem_model(m, mat, ModelKind::stvk);
  StaticProblem p;
  p.anchors.assign(m.positions.size(), anchor_none);
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const Vec3& x = m.positions[i];
    if (x.x() == 0) p.anchors[i] = 1;
    if (x.x() == 0 && x.y() == 0 && x.z() == 0) p.anchors[i] = anchor_all;
    if (x.x() == 0 && x.y() == kH && x.z() == 0) p.anchors[i] = 1 | 4;
  }
  p.external_forces = traction(m, Vec3(stress, 0, 0), [](const Vec3& x) { return x.x() == kL; });
  std::vector<Vec3> x = m.positions;
  const auto report = solve_static(model, p, x);
  EXPECT_TRUE(report.ok() && report->converged);
  return x;
}

TEST(FracturePhysics, BarInTensionBreaksAcrossItsAxisPastStrength) {
  const TetMesh m = make_box_mesh({.max = Vec3(kL, kH, kH), .cells = {16, 2, 2}});
  const Material glass = material_preset("glass").value();
  FractureOptions options;
  options.crack.max_cracks = 1;
  {
    const auto x = pull(m, glass, 0.97 * glass.tensile_strength);
    const FractureResult r = fracture(m, make_fem_model(m, glass, ModelKind::stvk), x, options);
    EXPECT_TRUE(r.events.empty());
    EXPECT_EQ(r.fragments.size(), 1u);
    EXPECT_EQ(r.mesh, m);
  }
  const auto x = pull(m, glass, 1.03 * glass.tensile_strength);
  const FractureResult r = fracture(m, make_fem_model(m, glass, ModelKind::stvk), x, options);
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_GT(std::abs(r.events[0].plan.normal.x()), 0.99);
  ASSERT_EQ(r.fragments.size(), 2u);
  double volume = 0;
  for (const Fragment& f : r.fragments) {
    EXPECT_TRUE(test::mesh_is_valid(f.mesh));
    volume += f.mass.volume;
  }
  EXPECT_NEAR(volume, kL * kH * kH, 1e-12 * kL * kH * kH);
  // The cut is flat and across the bar: every fragment node on one side of the crack plane.
  const double x0 = r.events[0].plan.origin.x();
  for (const Fragment& f : r.fragments) {
    const bool left = f.mass.center.x() < x0;
    for (const Vec3& p : f.mesh.positions) EXPECT_TRUE(left ? p.x() <= x0 + 1e-9 : p.x() >= x0 - 1e-9);
  }
}

TEST(FracturePhysics, NotchedBarBreaksAtTheNotch) {
  const TetMesh box = make_box_mesh({.max = Vec3(kL, kH, kH), .cells = {32, 4, 4}});
  // Notch: remove the tets of the top layer in the cell column around x = 0.3.
  std::vector<Index> keep;
  for (Index e = 0; e < box.num_tets(); ++e) {
    const Vec3 c = box.corners(e).rowwise().mean();
    if (!(c.y() > 0.75 * kH && std::abs(c.x() - 0.3) < 0.5 * kL / 32)) keep.push_back(e);
  }
  const TetMesh m = extract_tets(box, keep);
  const Material glass = material_preset("glass").value();
  const auto x = pull(m, glass, 0.75 * glass.tensile_strength);
  FractureOptions options;
  options.crack.max_cracks = 1;
  const FractureResult r = fracture(m, make_fem_model(m, glass, ModelKind::stvk), x, options);
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_NEAR(r.events[0].plan.origin.x(), 0.3, 1.5 * kL / 32);
  EXPECT_GT(r.events[0].plan.origin.y(), 0.5 * kH);
  EXPECT_GT(std::abs(r.events[0].plan.normal.x()), 0.9);
  EXPECT_EQ(r.fragments.size(), 2u);
}

TEST(FracturePhysics, ThreePointBendingCracksFromTheTensileFace) {
  const double L = 0.4, h = 0.05, b = 0.05;
  const TetMesh m = make_box_mesh({.max = Vec3(L, h, b), .cells = {32, 4, 4}});
  const Material glass = material_preset("glass").value();
  const FemModel model = make_fem_model(m, glass, ModelKind::stvk);
  StaticProblem p;
  p.anchors.assign(m.positions.size(), anchor_none);
  std::vector<Index> loaded;
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const Vec3& x = m.positions[i];
    if (x.y() == 0 && (x.x() == 0 || x.x() == L)) p.anchors[i] = 2;  // roller supports
    if (x.y() == 0 && x.x() == 0 && x.z() == 0) p.anchors[i] = anchor_all;
    if (x.y() == 0 && x.x() == L && x.z() == 0) p.anchors[i] = 2 | 4;
    if (x.y() == h && std::abs(x.x() - L / 2) < 1e-12) loaded.push_back(i);
  }
  // Peak bending stress 3 F L / (2 b h^2) = 1.6 sigma_t.
  const double force = 1.6 * glass.tensile_strength * 2 * b * h * h / (3 * L);
  p.external_forces.assign(m.positions.size(), Vec3::Zero());
  for (Index i : loaded) p.external_forces[i] = Vec3(0, -force / static_cast<double>(loaded.size()), 0);
  std::vector<Vec3> x = m.positions;
  const auto report = solve_static(model, p, x);
  ASSERT_TRUE(report.ok() && report->converged);
  FractureOptions options;
  options.crack.max_cracks = 1;
  const FractureResult r = fracture(m, make_fem_model(m, glass, ModelKind::stvk), x, options);
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_LT(r.events[0].plan.origin.y(), 0.3 * h);
  EXPECT_NEAR(r.events[0].plan.origin.x(), L / 2, L / 8);
  EXPECT_GT(std::abs(r.events[0].plan.normal.x()), 0.9);
  for (const Fragment& f : r.fragments) EXPECT_TRUE(test::mesh_is_valid(f.mesh));
}

TEST(FracturePhysics, PlasticBarKeepsAPermanentSetPastYieldOnly) {
  const TetMesh m = make_box_mesh({.max = Vec3(kL, kH, kH), .cells = {16, 2, 2}});
  const Material lead = material_preset("lead").value();
  auto length = [](const std::vector<Vec3>& p) {
    Aabb b;
    for (const Vec3& q : p) b.extend(q);
    return b.extent().x();
  };
  {
    const auto x = pull(m, lead, 0.8 * lead.yield_stress);
    const FractureResult r = fracture(m, make_fem_model(m, lead, ModelKind::stvk), x);
    EXPECT_TRUE(r.plastic.yielded.empty());
    EXPECT_EQ(r.mesh.positions, m.positions);  // springs back
  }
  const auto x = pull(m, lead, 2.0 * lead.yield_stress);
  const FractureResult r = fracture(m, make_fem_model(m, lead, ModelKind::stvk), x);
  EXPECT_EQ(r.plastic.yielded.size(), m.tets.size());
  EXPECT_TRUE(r.events.empty());  // far below the tensile strength
  const double set = length(r.mesh.positions) - kL;
  const double stretch = length(x) - kL;
  EXPECT_GT(set, 0.1 * stretch);
  EXPECT_LT(set, stretch);
  // Held at the same shape, the new rest shape carries less stress (part of it was absorbed).
  const auto after = compute_stresses(make_fem_model(r.mesh, lead, ModelKind::stvk), x);
  for (Index e = 0; e < m.num_tets(); ++e) EXPECT_LT(after[e].von_mises, r.stress[e].von_mises);
}

}  // namespace
}  // namespace shatter
