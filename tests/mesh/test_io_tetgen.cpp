// TetGen .node/.ele reader and writer: hand-written variants, exact round trips, malformed input.
#include <gtest/gtest.h>

#include <sstream>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

void expect_tetgen_error(const Result<MeshReadResult>& r, const std::string& substring, std::int64_t line,
                         const std::string& file = "") {
  test::expect_read_error(r, substring, line, file);
}

const char* kNode1 =
    "# a single tet, 1-based\n"
    "4 3 0 1\n"
    "1 0 0 0 7\n"
    "2 1.5 0 0 7   # comment after data\n"
    "3 0 1 0 0\n"
    "4 0 0 2e0 -3\n";
const char* kEle1 = "1 4 1\n1 1 2 3 4 5\n";

TEST(TetgenRead, OneBasedWithMarkersAndRegions) {
  auto r = parse_tetgen(kNode1, "a.node", kEle1, "a.ele");
  ASSERT_OK(r);
  const TetMesh& m = r->mesh;
  ASSERT_EQ(m.num_nodes(), 4);
  ASSERT_EQ(m.num_tets(), 1);
  EXPECT_EQ(m.positions[1], Vec3(1.5, 0, 0));
  EXPECT_EQ(m.positions[3], Vec3(0, 0, 2));
  EXPECT_EQ(m.tets[0], (TetIndices{0, 1, 2, 3}));
  EXPECT_TRUE(m.node_ids.empty());  // 1..n is the default numbering
  EXPECT_EQ(m.node_tags, (std::vector<std::int32_t>{7, 7, 0, -3}));
  EXPECT_EQ(m.tet_tags, (std::vector<std::int32_t>{5}));
}

TEST(TetgenRead, ZeroBasedKeepsIds) {
  auto r = parse_tetgen("4 3 2 0\n0 0 0 0 9 9\n1 1 0 0 9 9\n2 0 1 0 9 9\n3 0 0 1 9 9\n", "b.node",
                        "# tets\n1 4 0\n0 0 1 2 3\n", "b.ele");
  ASSERT_OK(r);
  EXPECT_EQ(r->mesh.node_ids, (std::vector<FileId>{0, 1, 2, 3}));
  EXPECT_EQ(r->mesh.tet_ids, (std::vector<FileId>{0}));
  EXPECT_EQ(r->mesh.tets[0], (TetIndices{0, 1, 2, 3}));
  EXPECT_TRUE(r->mesh.tet_tags.empty());
  EXPECT_TRUE(r->mesh.node_tags.empty());
  ASSERT_EQ(r->skipped.size(), 1u);
  EXPECT_NE(r->skipped[0].find("2 point attribute"), std::string::npos);
}

TEST(TetgenRead, CrlfBomAndShortHeaders) {
  auto r = parse_tetgen(
      "\xEF\xBB\xBF"
      "4 3\r\n1 0 0 0\r\n2 1 0 0\r\n3 0 1 0\r\n4 0 0 1\r\n",
      "c.node", "1\r\n1 4 3 2 1\r\n", "c.ele");
  ASSERT_OK(r);
  EXPECT_EQ(r->mesh.tets[0], (TetIndices{3, 2, 1, 0}));
}

TEST(TetgenRead, QuadraticTetsKeepCorners) {
  std::string node = "10 3 0 0\n";
  const double pts[10][3] = {{0, 0, 0},   {1, 0, 0},  {0, 1, 0},  {0, 0, 1},   {.5, 0, 0},
                             {.5, .5, 0}, {0, .5, 0}, {0, 0, .5}, {.5, 0, .5}, {0, .5, .5}};
  for (int i = 0; i < 10; ++i)
    node += std::to_string(i + 1) + " " + std::to_string(pts[i][0]) + " " + std::to_string(pts[i][1]) + " " +
            std::to_string(pts[i][2]) + "\n";
  auto r = parse_tetgen(node, "q.node", "1 10 0\n1 1 2 3 4 5 6 7 8 9 10\n", "q.ele");
  ASSERT_OK(r);
  EXPECT_EQ(r->mesh.num_nodes(), 4);
  EXPECT_EQ(r->mesh.positions[3], Vec3(0, 0, 1));
  ASSERT_EQ(r->skipped.size(), 1u);
  EXPECT_NE(r->skipped[0].find("6 mid-edge nodes dropped"), std::string::npos);
}

TEST(TetgenRead, Malformed) {
  const std::string ele = "1 4 0\n1 1 2 3 4\n";
  const std::string node4 = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
  expect_tetgen_error(parse_tetgen("", "n", ele, "e"), "empty file", 1, "n");
  expect_tetgen_error(parse_tetgen("# only a comment\n", "n", ele, "e"), "empty file", 2, "n");
  expect_tetgen_error(parse_tetgen(node4, "n", "", "e"), "empty file", 1, "e");
  expect_tetgen_error(parse_tetgen("4 3 0 0\n1 0 0 0\n2 1 0 0\n", "n", ele, "e"), "larger than the", 1);
  expect_tetgen_error(
      parse_tetgen("4 3 0 0\n1 0 0 0\n2 1 0 0 # a comment that is long enough to pass the check\n", "n", ele, "e"),
      "file ends after 2 of 4 points", 4);
  expect_tetgen_error(parse_tetgen("1000000000000000000 3 0 0\n1 0 0 0\n", "n", ele, "e"), "point count", 1);
  expect_tetgen_error(parse_tetgen("2000000 3 0 0\n1 0 0 0\n", "n", ele, "e"), "larger than the", 1);
  expect_tetgen_error(parse_tetgen("4 3 1000000000000000000 0\n", "n", ele, "e"), "attribute count", 1);
  expect_tetgen_error(parse_tetgen("-4 3 0 0\n", "n", ele, "e"), "point count", 1);
  expect_tetgen_error(parse_tetgen("4 2 0 0\n", "n", ele, "e"), "dimension", 1);
  expect_tetgen_error(parse_tetgen("4 3 0 0\n1 0 0 0\n2 nan 0 0\n3 0 1 0\n4 0 0 1\n", "n", ele, "e"), "finite number",
                      3);
  expect_tetgen_error(parse_tetgen("4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 # short row\n4 0 0 1\n", "n", ele, "e"),
                      "line ends where coordinate", 4);
  expect_tetgen_error(parse_tetgen("4 3 0 0\n1 0 0 0\n1 1 0 0\n3 0 1 0\n4 0 0 1\n", "n", ele, "e"), "defined twice", 3);
  expect_tetgen_error(parse_tetgen("4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1 8\n", "n", ele, "e"), "unexpected '8'",
                      5);
  expect_tetgen_error(parse_tetgen(node4 + "5 1 1 1\n", "n", ele, "e"), "after the 4 points", 6);
  expect_tetgen_error(parse_tetgen(node4, "n", "1 4 0\n1 1 2 3 5\n", "e"), "uses point 5", 2, "e");
  // Found by fuzzing: a huge region attribute must be refused before any integer conversion.
  expect_tetgen_error(parse_tetgen(node4, "n", "1 4 1\n1 1 2 3 4 1e111\n", "e"), "32-bit integer", 2, "e");
  expect_tetgen_error(parse_tetgen(node4, "n", "1 4 1\n1 1 2 3 4 -3e9\n", "e"), "32-bit integer", 2, "e");
  expect_tetgen_error(parse_tetgen(node4, "n", "1 4 1\n1 1 2 3 4 2.5\n", "e"), "32-bit integer", 2, "e");
  expect_tetgen_error(parse_tetgen(node4, "n", "1 4 0\n1 1 2 3 -1\n", "e"), "uses point -1", 2, "e");
  expect_tetgen_error(parse_tetgen(node4, "n", "3 4 0\n1 1 2 3 4\n", "e"), "larger than the", 1, "e");
  expect_tetgen_error(parse_tetgen(node4, "n", "2 4 0\n1 1 2 3 4\n# padding\n", "e"), "file ends after 1 of 2", 4, "e");
  expect_tetgen_error(parse_tetgen(node4, "n", "1 5 0\n1 1 2 3 4 4\n", "e"), "4 or 10", 1, "e");
  expect_tetgen_error(parse_tetgen(node4, "n", "1 4 1\n1 1 2 3 4 1.5\n", "e"), "32-bit integer", 2, "e");
  expect_tetgen_error(parse_tetgen(node4, "n", "1 4 0\n1 1 2 3 x\n", "e"), "expected node number", 2, "e");
}

TEST(TetgenWrite, RoundTripIsExact) {
  TetMesh m = make_box_mesh({.min = Vec3(-1, 0.1, 0), .max = Vec3(0.3, 1, 1e-3), .cells = {2, 3, 2}, .jitter = 0.2});
  m.node_ids.resize(m.positions.size());
  for (std::size_t i = 0; i < m.node_ids.size(); ++i) m.node_ids[i] = static_cast<FileId>(3 * i + 10);
  m.tet_ids.resize(m.tets.size());
  for (std::size_t e = 0; e < m.tet_ids.size(); ++e) m.tet_ids[e] = static_cast<FileId>(1000 - e);
  m.node_tags.assign(m.positions.size(), 0);
  m.node_tags[2] = -4;
  m.tet_tags.assign(m.tets.size(), 2);
  m.tet_tags[0] = 1;
  // Sparse point numbers (TetGen itself numbers 0.. or 1..) are kept as ids.
  m.node_ids[0] = 77;
  std::ostringstream node, ele;
  ASSERT_OK(write_tetgen_node(node, m));
  ASSERT_OK(write_tetgen_ele(ele, m));
  auto r = parse_tetgen(node.str(), "n", ele.str(), "e");
  ASSERT_OK(r);
  EXPECT_TRUE(r->mesh == m);
  // Writing the read mesh again gives the same bytes.
  std::ostringstream node2, ele2;
  ASSERT_OK(write_tetgen_node(node2, r->mesh));
  ASSERT_OK(write_tetgen_ele(ele2, r->mesh));
  EXPECT_EQ(node.str(), node2.str());
  EXPECT_EQ(ele.str(), ele2.str());
}

}  // namespace
}  // namespace shatter
