// Every volume format by extension: write_mesh then read_mesh gives the same mesh (positions
// bit-exact; ids, tags and sets where the format holds them); surfaces likewise.
#include <gtest/gtest.h>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TetMesh roundtrip_sample() {
  TetMesh m = make_box_mesh(
      {.min = Vec3(-0.5, 0.1, 2), .max = Vec3(0.7, 1.3, 2.01), .cells = {3, 2, 2}, .jitter = 0.2, .seed = 3});
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(FileId(2 * i + 1));
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_ids.push_back(FileId(100 + e));
  return m;
}

struct Holds {
  const char* file;
  bool ids;
};

TEST(MeshRoundTrip, EveryVolumeFormat) {
  test::TempDir dir;
  const TetMesh m = roundtrip_sample();
  for (const Holds& h : {Holds{"a.msh", true}, Holds{"a.node", true}, Holds{"b.ele", true}, Holds{"a.vtk", false},
                         Holds{"a.vtu", false}, Holds{"a.mesh", false}, Holds{"a.inp", true}}) {
    SCOPED_TRACE(h.file);
    const std::string path = dir.file(h.file);
    ASSERT_OK(write_mesh(path, m));
    auto r = read_mesh(path);
    ASSERT_OK(r);
    EXPECT_EQ(r->mesh.positions, m.positions);
    EXPECT_EQ(r->mesh.tets, m.tets);
    if (h.ids) {
      EXPECT_EQ(r->mesh.node_ids, m.node_ids);
      EXPECT_EQ(r->mesh.tet_ids, m.tet_ids);
    }
  }
  EXPECT_TRUE(std::filesystem::exists(dir.file("b.node")));
  EXPECT_EQ(mesh_format_from_path("X.NODE"), MeshFormat::tetgen);
  EXPECT_EQ(mesh_format_from_path("x.vtu.gz"), MeshFormat::unknown);
  EXPECT_FALSE(write_mesh(dir.file("a.xyz"), m).ok());
  EXPECT_FALSE(read_mesh(dir.file("missing.inp")).ok());
  EXPECT_FALSE(read_mesh(dir.file("missing.ele")).ok());
}

// Ids from a format that starts at 0 (TetGen, MEDIT) cannot be Gmsh tags or Abaqus numbers: those
// writers number 1..n with a warning instead of failing after the input was read.
TEST(MeshRoundTrip, IdsThatAreNotPositiveAreRenumbered) {
  test::TempDir dir;
  TetMesh m = roundtrip_sample();
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids[static_cast<std::size_t>(i)] = i;
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_ids[static_cast<std::size_t>(e)] = e;
  for (const char* file : {"z.msh", "z.inp"}) {
    SCOPED_TRACE(file);
    test::ExpectWarnings warnings;
    ASSERT_OK(write_mesh(dir.file(file), m));
    EXPECT_EQ(warnings.messages().size(), 2U);
    auto r = read_mesh(dir.file(file));
    ASSERT_OK(r);
    EXPECT_EQ(r->mesh.positions, m.positions);
    EXPECT_EQ(r->mesh.tets, m.tets);
    for (Index i = 0; i < m.num_nodes(); ++i) EXPECT_EQ(r->mesh.node_id(i), i + 1);
    for (Index e = 0; e < m.num_tets(); ++e) EXPECT_EQ(r->mesh.tet_id(e), e + 1);
  }
}

TEST(MeshRoundTrip, TagsAndSetsWhereHeld) {
  test::TempDir dir;
  TetMesh m = roundtrip_sample();
  m.tet_tags.assign(m.tets.size(), 4);
  m.tet_tags[3] = 9;
  m.node_tags.assign(m.positions.size(), 1);
  m.node_tags[0] = 2;
  for (const char* f : {"t.node", "t.mesh"}) {
    ASSERT_OK(write_mesh(dir.file(f), m));
    auto r = read_mesh(dir.file(f));
    ASSERT_OK(r);
    EXPECT_EQ(r->mesh.tet_tags, m.tet_tags) << f;
    EXPECT_EQ(r->mesh.node_tags, m.node_tags) << f;
  }
  TetMesh s = roundtrip_sample();
  s.node_sets["BOTTOM"] = {0, 1, 2, 3};
  s.tet_sets["LEFT"] = {0, 2};
  ASSERT_OK(write_mesh(dir.file("s.inp"), s));
  auto r = read_mesh(dir.file("s.inp"));
  ASSERT_OK(r);
  EXPECT_TRUE(r->mesh == s);
}

TEST(MeshRoundTrip, InvertedTetsAreRepairedWithAWarning) {
  test::TempDir dir;
  TetMesh m = roundtrip_sample();
  std::swap(m.tets[0][0], m.tets[0][1]);
  ASSERT_OK(write_mesh(dir.file("inv.inp"), m));
  test::ExpectWarnings warnings;
  auto r = read_mesh(dir.file("inv.inp"));
  ASSERT_OK(r);
  EXPECT_GT(signed_volume(r->mesh, 0), 0.0);
  ASSERT_EQ(warnings.messages().size(), 1u);
  EXPECT_NE(warnings.messages()[0].find("reoriented 1"), std::string::npos);
}

TEST(SurfaceRoundTrip, EveryFormat) {
  test::TempDir dir;
  const TriSurface s = boundary_surface(roundtrip_sample());
  for (const char* f : {"s.obj", "s.ply", "s.stl"})
    for (bool binary : {false, true}) {
      if (std::string(f) == "s.obj" && binary) continue;
      if (std::string(f) == "s.stl" && binary) continue;  // float precision: see test_io_surface
      ASSERT_OK(write_surface(dir.file(f), s, {.binary = binary}));
      auto r = read_surface(dir.file(f));
      ASSERT_OK(r);
      ASSERT_EQ(r->surface.triangles.size(), s.triangles.size());
      for (std::size_t t = 0; t < s.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k)
          EXPECT_TRUE(r->surface.positions[r->surface.triangles[t][k]] == s.positions[s.triangles[t][k]]) << f;
    }
}

}  // namespace
}  // namespace shatter
