// The committed demo meshes (assets/meshes, made by scripts/make_assets.sh) read back valid:
// positive tets, closed boundary, one piece, volume close to their shape's.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/topology.h"
#include "shatter/mesh/validate.h"
#include "shatter/meshing/shape_json.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TEST(Assets, CommittedMeshesAreValid) {
  const std::filesystem::path root = std::filesystem::path(SHATTER_SOURCE_DIR) / "assets";
  int checked = 0;
  for (const char* name : {"blob", "bowl", "cinder_block", "column", "plate", "teddy", "vase", "wall_slab"}) {
    const std::string mesh_path = (root / "meshes" / (std::string(name) + ".msh")).string();
    auto read = read_mesh(mesh_path);
    ASSERT_OK(read);
    const TetMesh& m = read->mesh;
    EXPECT_GT(m.num_tets(), 700) << name;
    for (Index e = 0; e < m.num_tets(); ++e) ASSERT_GT(signed_volume(m, e), 0.0) << name;
    EXPECT_FALSE(validate_mesh(m).has_errors()) << name;
    EXPECT_EQ(connected_components(m).count, 1) << name;
    // The shape's own inside test agrees with the mesh: every tet centroid is (nearly) inside.
    auto shape = read_shape_json((root / "shapes" / (std::string(name) + ".json")).string());
    ASSERT_OK(shape);
    const double h = m.bounds().extent().maxCoeff();
    for (Index e = 0; e < m.num_tets(); ++e)
      ASSERT_LT(shape->sdf(m.corners(e).rowwise().mean()), 0.05 * h) << name << " tet " << e;
    ++checked;
  }
  EXPECT_EQ(checked, 8);
}

// The paper's demo objects at their tet counts: the cinder block (~0.8k tets, structured, within
// 1 % of its exact volume) and the thin-walled china vase (~1.4k tets, one piece).
TEST(Assets, CinderBlockAndVaseAtPaperSizes) {
  const std::filesystem::path root = std::filesystem::path(SHATTER_SOURCE_DIR) / "assets" / "meshes";
  auto block = read_mesh((root / "cinder_block.msh").string());
  ASSERT_OK(block);
  const double block_volume = 0.39 * 0.19 * 0.19 - 2 * 0.13 * 0.19 * 0.12;
  EXPECT_NEAR(static_cast<double>(block->mesh.num_tets()), 800.0, 100.0);
  EXPECT_NEAR(total_volume(block->mesh), block_volume, 0.01 * block_volume);
  const Aabb b = block->mesh.bounds();
  EXPECT_NEAR((b.max - b.min - Vec3(0.39, 0.19, 0.19)).norm(), 0.0, 1e-12);

  auto vase = read_mesh((root / "vase.msh").string());
  ASSERT_OK(vase);
  const TetMesh& v = vase->mesh;
  EXPECT_NEAR(static_cast<double>(v.num_tets()), 1400.0, 150.0);
  EXPECT_EQ(connected_components(v).count, 1);
  for (Index e = 0; e < v.num_tets(); ++e) ASSERT_GT(signed_volume(v, e), 0.0) << "tet " << e;
  auto shape = read_shape_json((std::filesystem::path(SHATTER_SOURCE_DIR) / "assets/shapes/vase.json").string());
  ASSERT_OK(shape);
  const double exact = *shape->sdf.analytic_volume();
  EXPECT_NEAR(total_volume(v), exact, 0.05 * exact);
}

}  // namespace
}  // namespace shatter
