// Abaqus / CalculiX .inp reader and writer: keywords, sets, continuation lines, quadratic and
// skipped elements, exact round trips, malformed input.
#include <gtest/gtest.h>

#include <sstream>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

void expect_inp_error(const Result<MeshReadResult>& r, const std::string& substring, std::int64_t line) {
  test::expect_read_error(r, substring, line, "t.inp");
}

const char* kTwoTets =
    "** two tets sharing a face\n"
    "*Heading\n"
    " free text line, with commas\n"
    "*node, nset=ALLN\n"
    "10, 0., 0., 0.\n"
    "20, 1.0, 0, 0\n"
    "30, 0, 1.0, 0\n"
    "40, 0, 0, 1.0D0\n"
    "*NODE\n"
    "50, 1, 1, 1\n"
    "*ELEMENT, TYPE=C3D4, ELSET=\"Solid A\"\n"
    "7, 10, 20, 30, 40\n"
    "8, 20, 30,\n"
    "   40, 50\n"
    "*Element, type=S3, elset=SKIN\n"
    "100, 10, 20, 30\n"
    "101, 10, 20, 40\n"
    "*NSET, NSET=BASE\n"
    "10, 20,\n"
    "30\n"
    "*Nset, nset=GEN, generate\n"
    "20, 40, 20\n"
    "*ELSET, ELSET=MIXED\n"
    "8, 100\n"
    "*ELSET,\n"
    " ELSET=BOTH\n"
    "7, mixed\n"
    "*MATERIAL, NAME=STEEL\n"
    "*ELASTIC\n"
    "2.1e11, 0.3\n";

TEST(InpRead, KeywordsSetsAndSkips) {
  auto r = parse_inp(kTwoTets, "t.inp");
  ASSERT_OK(r);
  const TetMesh& m = r->mesh;
  ASSERT_EQ(m.num_nodes(), 5);
  ASSERT_EQ(m.num_tets(), 2);
  EXPECT_EQ(m.node_ids, (std::vector<FileId>{10, 20, 30, 40, 50}));
  EXPECT_EQ(m.tet_ids, (std::vector<FileId>{7, 8}));
  EXPECT_EQ(m.positions[3], Vec3(0, 0, 1));
  EXPECT_EQ(m.tets[1], (TetIndices{1, 2, 3, 4}));
  EXPECT_EQ(m.node_sets.at("ALLN"), (std::vector<Index>{0, 1, 2, 3}));
  EXPECT_EQ(m.node_sets.at("BASE"), (std::vector<Index>{0, 1, 2}));
  EXPECT_EQ(m.node_sets.at("GEN"), (std::vector<Index>{1, 3}));
  EXPECT_EQ(m.tet_sets.at("Solid A"), (std::vector<Index>{0, 1}));
  EXPECT_EQ(m.tet_sets.at("MIXED"), (std::vector<Index>{1}));
  EXPECT_EQ(m.tet_sets.at("BOTH"), (std::vector<Index>{0, 1}));
  EXPECT_TRUE(m.tet_sets.at("SKIN").empty());
  EXPECT_EQ(r->skipped, (std::vector<std::string>{"2 elements of type S3", "*ELASTIC", "*HEADING", "*MATERIAL",
                                                  "1 element set members that are not tetrahedra"}));
}

TEST(InpRead, QuadraticTetsKeepCorners) {
  auto r = parse_inp(
      "*NODE\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n5,.5,0,0\n6,.5,.5,0\n7,0,.5,0\n8,0,0,.5\n9,.5,0,.5\n10,0,.5,.5\n"
      "*NSET,NSET=MID\n5,6,1\n"
      "*ELEMENT,TYPE=C3D10\n1,1,2,3,4,5,6,7,\n8,9,10\n",
      "t.inp");
  ASSERT_OK(r);
  EXPECT_EQ(r->mesh.num_nodes(), 4);
  EXPECT_TRUE(r->mesh.node_ids.empty());
  EXPECT_EQ(r->mesh.node_sets.at("MID"), (std::vector<Index>{0}));
  ASSERT_FALSE(r->skipped.empty());
  EXPECT_NE(r->skipped[0].find("6 mid-edge nodes dropped"), std::string::npos);
}

TEST(InpRead, CrlfAndBom) {
  auto r = parse_inp(
      "\xEF\xBB\xBF*NODE\r\n1,0,0,0\r\n2,1,0,0\r\n3,0,1,0\r\n4,0,0,1\r\n*ELEMENT,TYPE=C3D4H\r\n1,1,2,3,4\r\n", "t.inp");
  ASSERT_OK(r);
  EXPECT_EQ(r->mesh.num_tets(), 1);
}

TEST(InpRead, Malformed) {
  const std::string nodes = "*NODE\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n";  // lines 1-5
  expect_inp_error(parse_inp("", "t.inp"), "empty file", 1);
  expect_inp_error(parse_inp("1, 0, 0, 0\n", "t.inp"), "expected a keyword line", 1);
  expect_inp_error(parse_inp(nodes, "t.inp"), "no C3D4 or C3D10", 6);
  expect_inp_error(parse_inp("*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n", "t.inp"), "no *NODE", 3);
  expect_inp_error(parse_inp(nodes + "*ELEMENT\n1,1,2,3,4\n", "t.inp"), "without TYPE=", 6);
  expect_inp_error(parse_inp(nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3\n", "t.inp"), "3 node numbers", 7);
  expect_inp_error(parse_inp(nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3\n*NSET,NSET=A\n1\n", "t.inp"), "3 node numbers", 7);
  expect_inp_error(parse_inp(nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3,4,5\n", "t.inp"), "5 node numbers", 7);
  expect_inp_error(parse_inp(nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3,9\n", "t.inp"), "node 9", 7);
  expect_inp_error(parse_inp(nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3,-1\n", "t.inp"), "node -1", 7);
  expect_inp_error(parse_inp(nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3,x\n", "t.inp"), "node number", 7);
  expect_inp_error(parse_inp(nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n1,1,2,3,4\n", "t.inp"), "defined twice", 8);
  expect_inp_error(parse_inp("*NODE\n1,0,0,0\n1,1,0,0\n", "t.inp"), "node 1 is defined twice", 3);
  expect_inp_error(parse_inp("*NODE\n1,0,nan,0\n", "t.inp"), "finite number", 2);
  expect_inp_error(parse_inp("*NODE\n1\n", "t.inp"), "node number, x, y, z", 2);
  expect_inp_error(parse_inp("*NODE\n1.5,0,0,0\n", "t.inp"), "node number", 2);
  const std::string tet = nodes + "*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n";  // lines 6-7
  expect_inp_error(parse_inp(tet + "*NSET,NSET=A,GENERATE\n1,1000000000000000000,1\n", "t.inp"),
                   "larger than the 4 nodes", 9);
  expect_inp_error(parse_inp(tet + "*NSET,NSET=A,GENERATE\n4,1\n", "t.inp"), "first <= last", 9);
  expect_inp_error(parse_inp(tet + "*NSET,NSET=A,GENERATE\n1,4,0\n", "t.inp"), "increment > 0", 9);
  expect_inp_error(parse_inp(tet + "*NSET,NSET=A,GENERATE\n1,4,2,1\n", "t.inp"), "first, last", 9);
  expect_inp_error(parse_inp(tet + "*ELSET,ELSET=A,GENERATE\n1,3\n", "t.inp"), "larger than the 1 elements", 9);
  expect_inp_error(parse_inp(tet + "*NSET,NSET=A\n1, 7\n", "t.inp"), "node 7 is not defined", 9);
  expect_inp_error(parse_inp(tet + "*ELSET,ELSET=A\n2\n", "t.inp"), "element 2 is not defined", 9);
  expect_inp_error(parse_inp(tet + "*ELSET,ELSET=A\nNOPE\n", "t.inp"), "set name", 9);
  expect_inp_error(parse_inp(tet + "*NSET\n1\n", "t.inp"), "without NSET=", 8);
}

// Sets that each name the previous set twice, 40 levels deep (about 1 KB): 2^40 members unless
// repeats are dropped as each set is read; they are, so the sets come out right and fast. A set
// naming another set far more often than the mesh is large is refused.
TEST(InpRead, SetExpansionIsBounded) {
  const std::string tet = "*NODE\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n";
  for (const char* kind : {"NSET", "ELSET"}) {
    SCOPED_TRACE(kind);
    std::string s = tet + "*" + kind + "," + kind + "=S0\n1\n";
    for (int k = 1; k <= 40; ++k)
      s += "*" + std::string(kind) + "," + kind + "=S" + std::to_string(k) + "\nS" + std::to_string(k - 1) + ", S" +
           std::to_string(k - 1) + "\n";
    ASSERT_LT(s.size(), 1200u);
    auto r = parse_inp(s, "t.inp");
    ASSERT_OK(r);
    const auto& sets = std::string(kind) == "NSET" ? r->mesh.node_sets : r->mesh.tet_sets;
    ASSERT_EQ(sets.count("S40"), 1u);
    EXPECT_EQ(sets.at("S40"), std::vector<Index>{0});
  }
  // 300,000 references to a 4-node set: more than the bound (1,000,000 + 64 per node and element).
  std::string many = tet + "*NSET,NSET=ALL\n1,2,3,4\n*NSET,NSET=B\n";
  for (int k = 0; k < 300'000; ++k) many += k % 16 == 15 ? "ALL\n" : "ALL,";
  many += "ALL\n";
  auto r = parse_inp(many, "t.inp");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("sets naming sets too many times"), std::string::npos) << r.error().to_string();
  EXPECT_EQ(r.error().file, "t.inp");
}

TEST(InpWrite, RoundTripIsExact) {
  TetMesh m = make_box_mesh({.min = Vec3(-1, 0.1, 0), .max = Vec3(0.3, 1, 1e-3), .cells = {2, 2, 3}, .jitter = 0.25});
  m.node_ids.resize(m.positions.size());
  for (std::size_t i = 0; i < m.node_ids.size(); ++i) m.node_ids[i] = static_cast<FileId>(5 * i + 3);
  m.tet_ids.resize(m.tets.size());
  for (std::size_t e = 0; e < m.tet_ids.size(); ++e) m.tet_ids[e] = static_cast<FileId>(10000000000LL + 7 * e);
  m.node_sets["FIXED"] = {0, 1, 2};
  m.node_sets["Top Face"] = {};
  for (Index i = 0; i < m.num_nodes(); i += 2) m.node_sets["Top Face"].push_back(i);
  m.tet_sets["CORE"] = {1, 5, 6};
  std::ostringstream out;
  ASSERT_OK(write_inp(out, m));
  auto r = parse_inp(out.str(), "t.inp");
  ASSERT_OK(r);
  EXPECT_TRUE(r->mesh == m);
  std::ostringstream again;
  ASSERT_OK(write_inp(again, r->mesh));
  EXPECT_EQ(out.str(), again.str());
  // A set name the format cannot hold is an error, not a broken file.
  m.tet_sets["A,B"] = {0};
  std::ostringstream bad;
  EXPECT_FALSE(write_inp(bad, m).ok());
}

}  // namespace
}  // namespace shatter
