// Exact and lumped mass properties of tet meshes against closed forms.
#include <gtest/gtest.h>

#include <utility>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/mass_properties.h"

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
                               mass * (d.x() * d.x() + d.y() * d.y()) / 12)
                              .asDiagonal();
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
  m.positions = {Vec3(8.33220, -11.86875, 0.93355), Vec3(0.75523, 5.00000, 16.37072), Vec3(52.61236, 5.00000, -5.38580),
                 Vec3(2.00000, 5.00000, 3.00000)};
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
  EXPECT_NEAR(-p.inertia(1, 2), 4417.66150, 0.01);    // a' in Tonon's notation
  EXPECT_NEAR(-p.inertia(0, 2), -46343.16662, 0.01);  // b'
  EXPECT_NEAR(-p.inertia(0, 1), 11996.20119, 0.01);   // c'
}

}  // namespace
}  // namespace shatter
