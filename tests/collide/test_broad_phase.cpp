// Broad phase: the grid finds exactly the pairs brute force finds, over thousands of random scenes
// with boxes of every size (points, slabs, boxes larger than the scene, empty ones), and the
// result does not depend on the cell size.
#include <gtest/gtest.h>

#include "shatter/collide/broad_phase.h"
#include "shatter/core/random.h"

namespace shatter {
namespace {

Aabb random_box(Random& rng, double scene) {
  Aabb b;
  const Vec3 c = rng.uniform_vec3(-scene, scene);
  switch (rng.below(8)) {
    case 0: b.extend(c); return b;  // a point
    case 1: {                       // a flat slab (zero thickness along y)
      const Vec3 e = rng.uniform_vec3(0.0, 0.3 * scene);
      b.extend(c - Vec3(e.x(), 0, e.z()));
      b.extend(c + Vec3(e.x(), 0, e.z()));
      return b;
    }
    case 2: {  // much larger than the typical box
      const Vec3 e = rng.uniform_vec3(0.5 * scene, 2.0 * scene);
      b.extend(c - e);
      b.extend(c + e);
      return b;
    }
    case 3:
      if (rng.below(4) == 0) return Aabb{};  // empty
      [[fallthrough]];
    default: {
      const Vec3 e = rng.uniform_vec3(0.001 * scene, 0.08 * scene);
      b.extend(c - e);
      b.extend(c + e);
      return b;
    }
  }
}

TEST(BroadPhase, MatchesBruteForceOnRandomScenes) {
  Random rng(2024);
  std::int64_t total_pairs = 0;
  for (int scene = 0; scene < 2000; ++scene) {
    const int n = 1 + static_cast<int>(rng.below(scene < 1900 ? 40 : 400));
    const double size = std::ldexp(1.0, static_cast<int>(rng.below(20)) - 10);  // 1 mm .. 500 m
    std::vector<Aabb> boxes;
    for (int i = 0; i < n; ++i) boxes.push_back(random_box(rng, size));
    // Now and then boxes that touch exactly (a shared face at a cell boundary).
    if (n >= 2 && rng.below(4) == 0) {
      boxes[1] = boxes[0];
      const double w = boxes[0].max.x() - boxes[0].min.x();
      boxes[1].min.x() = boxes[0].max.x();
      boxes[1].max.x() = boxes[0].max.x() + w;
    }
    const auto expected = find_overlapping_pairs_brute_force(boxes);
    BroadPhaseStats stats;
    const auto got = find_overlapping_pairs(boxes, {}, &stats);
    ASSERT_EQ(got, expected) << "scene " << scene << ", " << n << " boxes, cell " << stats.cell_size;
    // Any cell size gives the same pairs.
    const auto coarse = find_overlapping_pairs(boxes, {.cell_size = 3 * size});
    const auto fine = find_overlapping_pairs(boxes, {.cell_size = 0.01 * size, .max_cells_per_box = 1000});
    ASSERT_EQ(coarse, expected) << "scene " << scene;
    ASSERT_EQ(fine, expected) << "scene " << scene;
    total_pairs += static_cast<std::int64_t>(expected.size());
  }
  EXPECT_GT(total_pairs, 10000);  // the scenes are not trivially empty
}

TEST(BroadPhase, TestsFarFewerPairsThanBruteForceOnASpreadScene) {
  // 2,000 pebbles spread over a 20 m square and a ground slab under all of them.
  Random rng(7);
  std::vector<Aabb> boxes;
  Aabb ground;
  ground.extend(Vec3(-11, -1, -11));
  ground.extend(Vec3(11, 0, 11));
  boxes.push_back(ground);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 c{rng.uniform(-10, 10), rng.uniform(0.0, 0.5), rng.uniform(-10, 10)};  // braces: drawn left to right
    Aabb b;
    b.extend(c - Vec3::Constant(0.05));
    b.extend(c + Vec3::Constant(0.05));
    boxes.push_back(b);
  }
  BroadPhaseStats stats;
  const auto got = find_overlapping_pairs(boxes, {}, &stats);
  EXPECT_EQ(got, find_overlapping_pairs_brute_force(boxes));
  EXPECT_EQ(stats.large_boxes, 1);
  EXPECT_LT(stats.box_tests, 20000);  // brute force: ~2 million
}

TEST(BroadPhase, NoBoxesNoPairs) {
  EXPECT_TRUE(find_overlapping_pairs({}).empty());
  EXPECT_TRUE(find_overlapping_pairs({Aabb{}, Aabb{}}).empty());
}

}  // namespace
}  // namespace shatter
