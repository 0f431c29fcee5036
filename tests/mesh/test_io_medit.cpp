// MEDIT .mesh reader and writer: hand-written variants, exact round trips, malformed input.
#include <gtest/gtest.h>

#include <sstream>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

void expect_medit_error(const Result<MeshReadResult>& r, const std::string& substring, std::int64_t line) {
  test::expect_read_error(r, substring, line, "t.mesh");
}

const char* kTet =
    "MeshVersionFormatted 1\n"
    "# comment\n"
    "Dimension\n3\n"
    "Vertices\n4\n"
    "0 0 0 1\n1 0 0 1\n0 1 0 2\n0 0 1.0D0 0\n"
    "Triangles 2\n1 2 3 4\n1 2 4 4\n"
    "Edges\n1\n1 2 0\n"
    "Corners 1 1\n"
    "Tetrahedra\n1\n1 2 3 4 7\n"
    "End\n";

TEST(MeditRead, SectionsRefsAndSkips) {
  auto r = parse_medit(kTet, "t.mesh");
  ASSERT_OK(r);
  const TetMesh& m = r->mesh;
  ASSERT_EQ(m.num_nodes(), 4);
  ASSERT_EQ(m.num_tets(), 1);
  EXPECT_EQ(m.positions[3], Vec3(0, 0, 1));
  EXPECT_EQ(m.tets[0], (TetIndices{0, 1, 2, 3}));
  EXPECT_EQ(m.node_tags, (std::vector<std::int32_t>{1, 1, 2, 0}));
  EXPECT_EQ(m.tet_tags, (std::vector<std::int32_t>{7}));
  EXPECT_EQ(r->format, "medit 1 ascii");
  EXPECT_EQ(r->skipped, (std::vector<std::string>{"2 Triangles", "1 Edges", "1 Corners"}));
}

TEST(MeditRead, UnknownSectionAndCrlfAndNoEnd) {
  auto r = parse_medit(
      "\xEF\xBB\xBFMeshVersionFormatted 2\r\nDimension 3\r\nVertices\r\n4\r\n0 0 0 0\r\n1 0 0 0\r\n0 1 0 0\r\n"
      "0 0 1 0\r\nFancyThing\r\n3\r\n1 2 3\r\nTetrahedra 1\r\n1 2 3 4 0\r\n",
      "t.mesh");
  ASSERT_OK(r);
  EXPECT_TRUE(r->mesh.node_tags.empty());
  EXPECT_TRUE(r->mesh.tet_tags.empty());
  EXPECT_EQ(r->skipped, (std::vector<std::string>{"section 'FancyThing'"}));
}

TEST(MeditRead, Malformed) {
  const std::string head = "MeshVersionFormatted 2\nDimension 3\n";
  const std::string verts = head + "Vertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n";
  expect_medit_error(parse_medit("", "t.mesh"), "empty file", 1);
  expect_medit_error(parse_medit("Dimension 3\n", "t.mesh"), "expected 'MeshVersionFormatted'", 1);
  expect_medit_error(parse_medit("MeshVersionFormatted 7\n", "t.mesh"), "version", 1);
  expect_medit_error(parse_medit("MeshVersionFormatted 2\nDimension 2\n", "t.mesh"), "Dimension 3", 2);
  expect_medit_error(parse_medit("MeshVersionFormatted 2\nVertices\n1\n0 0 0 0\n", "t.mesh"), "before 'Dimension 3'",
                     2);
  expect_medit_error(parse_medit(head + "Vertices\n1000000000000000000\n0 0 0 0\n", "t.mesh"), "section size", 4);
  expect_medit_error(parse_medit(head + "Vertices\n100000\n0 0 0 0\n", "t.mesh"), "larger than the", 4);
  expect_medit_error(parse_medit(head + "Vertices\n-1\n", "t.mesh"), "section size", 4);
  expect_medit_error(parse_medit(head + "Vertices\n2\n0 0 0 0\n0 0 # padding padding\n", "t.mesh"),
                     "file ends where vertex coordinate", 7);
  expect_medit_error(parse_medit(head + "Vertices\n1\n0 nan 0 0\n", "t.mesh"), "finite number", 5);
  expect_medit_error(parse_medit(verts + "Tetrahedra\n1\n1 2 3 5 0\n", "t.mesh"), "vertex index in [1, 4]", 11);
  expect_medit_error(parse_medit(verts + "Tetrahedra\n1\n1 2 0 4 0\n", "t.mesh"), "vertex index in [1, 4]", 11);
  expect_medit_error(parse_medit(verts + "Tetrahedra\n1\n1 2 -3 4 0\n", "t.mesh"), "vertex index in [1, 4]", 11);
  expect_medit_error(parse_medit(verts + "Tetrahedra\n3\n1 2 3 4 0\n", "t.mesh"), "larger than the", 10);
  expect_medit_error(parse_medit(verts + "Tetrahedra\n1\n1 2 3 4 # padding\n", "t.mesh"), "tetrahedron reference", 12);
  expect_medit_error(parse_medit(verts + "End\n", "t.mesh"), "without tetrahedra", 9);
  expect_medit_error(parse_medit(head + "End\n", "t.mesh"), "without a 'Vertices'", 3);
  expect_medit_error(parse_medit(head + "Tetrahedra\n1\n1 2 3 4 0\n", "t.mesh"), "before 'Vertices'", 3);
  expect_medit_error(parse_medit(verts + "Triangles\n1\n1 2 x 0\n", "t.mesh"), "expected number", 11);
  expect_medit_error(parse_medit(verts + "12 Tetrahedra\n", "t.mesh"), "expected a keyword", 9);
}

TEST(MeditWrite, RoundTripIsExact) {
  TetMesh m = make_box_mesh({.min = Vec3(-1, 0.1, 0), .max = Vec3(0.3, 1, 1e-3), .cells = {3, 2, 2}, .jitter = 0.25});
  m.node_tags.assign(m.positions.size(), 3);
  m.node_tags[1] = 0;
  m.tet_tags.assign(m.tets.size(), 0);
  m.tet_tags[4] = -2;
  std::ostringstream out;
  ASSERT_OK(write_medit(out, m));
  auto r = parse_medit(out.str(), "t.mesh");
  ASSERT_OK(r);
  EXPECT_TRUE(r->mesh == m);
  std::ostringstream again;
  ASSERT_OK(write_medit(again, r->mesh));
  EXPECT_EQ(out.str(), again.str());
}

}  // namespace
}  // namespace shatter
