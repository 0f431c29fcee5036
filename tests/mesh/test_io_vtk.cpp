// Legacy VTK reader and writer: round trips (ASCII and binary), hand-written 4.2 / 5.1 files,
// big-endian binary built byte by byte, and a table of malformed inputs.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <limits>
#include <sstream>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TetMesh vtk_sample_mesh() {
  TetMesh m =
      make_box_mesh({.min = Vec3(-2, 0, 0.5), .max = Vec3(1, 1, 1.5), .cells = {3, 2, 2}, .jitter = 0.2, .seed = 5});
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(50 + 3 * FileId(m.num_nodes() - i));
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_ids.push_back((FileId(1) << 40) + 9 * FileId(e));  // needs 64 bits
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_tags.push_back(-3 + e % 5);
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_tags.push_back(i % 2);
  return m;
}

std::string vtk_string(const TetMesh& m, bool binary, const MeshFields& fields = {}) {
  std::ostringstream s;
  MeshWriteOptions o;
  o.binary = binary;
  o.fields = fields;
  const Result<void> r = write_vtk(s, m, o);
  EXPECT_TRUE(r.ok()) << r.error().to_string();
  return s.str();
}

void expect_bit_equal(const TetMesh& a, const TetMesh& b) {
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (std::size_t i = 0; i < a.positions.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a.positions[i][k]), std::bit_cast<std::uint64_t>(b.positions[i][k]));
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.node_ids, b.node_ids);
  EXPECT_EQ(a.node_tags, b.node_tags);
  EXPECT_EQ(a.tet_ids, b.tet_ids);
  EXPECT_EQ(a.tet_tags, b.tet_tags);
}

TEST(VtkRoundTrip, AsciiAndBinaryWithFields) {
  const TetMesh m = vtk_sample_mesh();
  MeshFields fields;
  MeshField speed{"speed", 1, {}}, vel{"velocity", 3, {}}, stress{"stress tensor", 6, {}}, damage{"damage", 1, {}};
  for (Index i = 0; i < m.num_nodes(); ++i) {
    speed.values.push_back(0.5 * i);
    for (int k = 0; k < 3; ++k) vel.values.push_back(i + 0.1 * k);
  }
  for (Index e = 0; e < m.num_tets(); ++e) {
    damage.values.push_back(e / 100.0);
    for (int k = 0; k < 6; ++k) stress.values.push_back(1e9 * e + k);
  }
  fields.node_fields = {speed, vel};
  fields.tet_fields = {stress, damage};
  for (bool binary : {false, true}) {
    const std::string bytes = vtk_string(m, binary, fields);
    const Result<MeshReadResult> r = parse_vtk(bytes, "rt.vtk");
    ASSERT_TRUE(r.ok()) << r.error().to_string();
    EXPECT_EQ(r->format, binary ? "vtk 4.2 binary" : "vtk 4.2 ascii");
    EXPECT_TRUE(r->skipped.empty());
    expect_bit_equal(m, r->mesh);
    EXPECT_NE(bytes.find("stress%20tensor"), std::string::npos);
  }
}

TEST(VtkRoundTrip, PlainMeshHasNoIdArrays) {
  const TetMesh m = make_box_mesh({.cells = {2, 1, 1}});
  const std::string bytes = vtk_string(m, false);
  EXPECT_EQ(bytes.find("POINT_DATA"), std::string::npos);
  const Result<MeshReadResult> r = parse_vtk(bytes, "rt.vtk");
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(r->mesh, m);
}

TEST(VtkRead, Version51AsciiMixedCells) {
  const std::string text =
      "# vtk DataFile Version 5.1\nmixed\nASCII\nDATASET UNSTRUCTURED_GRID\n"
      "POINTS 6 float\n0 0 0 1 0 0 0 1 0\n0 0 1 1 1 1 9 9 9\n"
      "CELLS 4 11\nOFFSETS vtktypeint64\n0 4 7 11\nCONNECTIVITY vtktypeint64\n0 1 2 3 0 1 5 1 4 2 3\n"
      "CELL_TYPES 3\n10\n5\n10\n"
      "CELL_DATA 3\nFIELD FieldData 2\ntet_id 1 3 vtktypeint64\n7 8 9\nother 2 3 double\n1 2 3 4 5 6\n"
      "POINT_DATA 6\nSCALARS node_id int 1\nLOOKUP_TABLE default\n10 11 12 13 14 15\n"
      "METADATA\nINFORMATION 0\n\n";
  const Result<MeshReadResult> r = parse_vtk(text, "mixed.vtk");
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(r->format, "vtk 5.1 ascii");
  EXPECT_EQ(r->mesh.num_tets(), 2);
  EXPECT_EQ(r->mesh.tet_ids, (std::vector<FileId>{7, 9}));
  // Point 5 was used only by the triangle.
  EXPECT_EQ(r->mesh.node_ids, (std::vector<FileId>{10, 11, 12, 13, 14}));
  EXPECT_EQ(r->mesh.tets[1], (TetIndices{1, 4, 2, 3}));
  EXPECT_EQ(r->skipped, (std::vector<std::string>{"1 triangle (vtk type 5)", "1 node used by no tetrahedron"}));
}

TEST(VtkRead, DataCountsMustMatchPointsAndCells) {
  // A POINT_DATA / CELL_DATA count that disagrees with POINTS / CELLS: its arrays are consistent
  // among themselves, but cannot be ids or tags of the mesh.
  const std::string head =
      "# vtk DataFile Version 4.2\nd\nASCII\nDATASET UNSTRUCTURED_GRID\n"
      "POINTS 6 float\n0 0 0 1 0 0 0 1 0\n0 0 1 1 1 1 9 9 9\n"
      "CELLS 2 9\n4 0 1 2 3\n3 0 1 5\nCELL_TYPES 2\n10\n5\n";
  const Result<MeshReadResult> nodes =
      parse_vtk(head + "POINT_DATA 2\nSCALARS node_tag int 1\nLOOKUP_TABLE default\n1 2\n", "d.vtk");
  ASSERT_FALSE(nodes.ok());
  EXPECT_NE(nodes.error().message.find("node_tag has 2 values for 6 points"), std::string::npos)
      << nodes.error().message;
  const Result<MeshReadResult> cells =
      parse_vtk(head + "CELL_DATA 1\nSCALARS tet_id int 1\nLOOKUP_TABLE default\n4\n", "d.vtk");
  ASSERT_FALSE(cells.ok());
  EXPECT_NE(cells.error().message.find("tet_id has 1 value for 2 cells"), std::string::npos) << cells.error().message;
  const Result<MeshReadResult> good =
      parse_vtk(head + "POINT_DATA 6\nSCALARS node_tag int 1\nLOOKUP_TABLE default\n1 2 3 4 5 6\n", "d.vtk");
  ASSERT_TRUE(good.ok()) << good.error().to_string();
  EXPECT_EQ(good->mesh.node_tags, (std::vector<std::int32_t>{1, 2, 3, 4}));  // points 4 and 5 are in no tet
}

/// Big-endian binary 4.2 written byte by byte; `bad_index` corrupts one connectivity entry.
std::string binary42(std::int32_t bad_index = 3, double x0 = 0.0) {
  std::string s = "# vtk DataFile Version 4.2\nb\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n";
  auto put = [&](auto v) {
    char b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    for (std::size_t i = 0; i < sizeof v; ++i) s += b[sizeof v - 1 - i];
  };
  for (float c : {static_cast<float>(x0), 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f}) put(c);
  s += "\nCELLS 1 5\n";
  for (std::int32_t v : {4, 0, 1, 2, bad_index}) put(v);
  s += "\nCELL_TYPES 1\n";
  put(std::int32_t(10));
  s += "\nCELL_DATA 1\nSCALARS tag int\nLOOKUP_TABLE default\n";
  put(std::int32_t(42));
  s += "\n";
  return s;
}

TEST(VtkRead, BigEndianBinary) {
  const Result<MeshReadResult> r = parse_vtk(binary42(), "b.vtk");
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(r->format, "vtk 4.2 binary");
  EXPECT_EQ(r->mesh.positions[3], Vec3(0, 0, 1));
  EXPECT_EQ(r->mesh.tet_tags, std::vector<std::int32_t>{42});
  const Result<MeshReadResult> bad = parse_vtk(binary42(7), "b.vtk");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("references point 7"), std::string::npos);
  const Result<MeshReadResult> nan = parse_vtk(binary42(3, std::numeric_limits<double>::quiet_NaN()), "b.vtk");
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().message.find("not finite"), std::string::npos);
  const std::string full = binary42();
  for (std::size_t n = 0; n + 1 < full.size(); ++n) {
    const Result<MeshReadResult> t = parse_vtk(full.substr(0, n), "t.vtk");
    // Cut anywhere before the optional cell data: an error.
    if (n < full.find("\nCELL_DATA")) {
      EXPECT_FALSE(t.ok()) << n;
    }
  }
}

TEST(VtkRead, CrlfAndBom) {
  std::string text = vtk_string(vtk_sample_mesh(), false);
  std::string crlf = "\xEF\xBB\xBF";
  for (char c : text) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  const Result<MeshReadResult> r = parse_vtk(crlf, "crlf.vtk");
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  expect_bit_equal(vtk_sample_mesh(), r->mesh);
}

TEST(VtkRead, MalformedInputs) {
  const std::string head = "# vtk DataFile Version 4.2\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n";
  const std::string pts = "POINTS 4 double\n0 0 0 1 0 0 0 1 0 0 0 1\n";
  const std::string head51 = "# vtk DataFile Version 5.1\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n";
  struct Case {
    const char* label;
    std::string text;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {"empty", "", "empty file"},
      {"not vtk", "hello\n", "not a legacy VTK file"},
      {"version", "# vtk DataFile Version 9.9\nt\nASCII\n", "unsupported legacy VTK version"},
      {"no title", "# vtk DataFile Version 4.2\n", "title"},
      {"format", "# vtk DataFile Version 4.2\nt\nTEXT\n", "'ASCII' or 'BINARY'"},
      {"polydata", "# vtk DataFile Version 4.2\nt\nASCII\nDATASET POLYDATA\n", "UNSTRUCTURED_GRID"},
      {"no points", head, "without a POINTS"},
      {"no cells", head + pts, "without a CELLS"},
      {"no types", head + pts + "CELLS 1 5\n4 0 1 2 3\n", "without a CELL_TYPES"},
      {"huge points", head + "POINTS 1000000000000000000 double\n0 0 0\n", "out of range"},
      {"points over data", head + "POINTS 100 double\n0 0 0\n", "bytes that remain"},
      {"bad type", head + "POINTS 1 quaternion\n0 0 0\n", "unknown POINTS data type"},
      {"nan", head + "POINTS 1 double\nnan 0 0\n", "finite number"},
      {"truncated points", head + "POINTS 4 double\n0 0 0 1 0 0 0 1 0 0 0", "point coordinates"},
      {"cells huge", head + pts + "CELLS 1 999999999999999999\n4 0 1 2 3\n", "bytes that remain"},
      {"cells negative size", head + pts + "CELLS 1 -5\n", "negative"},
      {"cell too long", head + pts + "CELLS 1 5\n9 0 1 2 3\nCELL_TYPES 1\n10\n", "beyond the CELLS list"},
      {"index out of range", head + pts + "CELLS 1 5\n4 0 1 2 4\nCELL_TYPES 1\n10\n", "references point 4"},
      {"negative index", head + pts + "CELLS 1 5\n4 0 1 2 -1\nCELL_TYPES 1\n10\n", "references point -1"},
      {"tet with 3 points", head + pts + "CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n10\n", "with 3 points"},
      {"type count", head + pts + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 2\n10 10\n", "CELL_TYPES lists 2"},
      {"no tets", head + pts + "CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n5\n", "no tetrahedra"},
      {"data count",
       head + pts + "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nCELL_DATA 1\nFIELD f 1\ntet_id 1 2 int\n1 2\n",
       "expected 1"},
      {"unknown keyword", head + pts + "BANANAS 3\n", "unexpected keyword"},
      {"51 offsets",
       head51 + pts + "CELLS 2 4\nOFFSETS vtktypeint64\n1 4\nCONNECTIVITY vtktypeint64\n0 1 2 3\nCELL_TYPES 1\n10\n",
       "first cell offset"},
      {"51 offsets decrease",
       head51 + pts + "CELLS 3 4\nOFFSETS vtktypeint64\n0 5 4\nCONNECTIVITY vtktypeint64\n0 1 2 3\n", "decrease"},
      {"51 last offset", head51 + pts + "CELLS 2 4\nOFFSETS vtktypeint64\n0 3\nCONNECTIVITY vtktypeint64\n0 1 2 3\n",
       "last cell offset"},
      {"51 float offsets", head51 + pts + "CELLS 2 4\nOFFSETS double\n0 4\n", "integer type"},
      {"tag too wide",
       head + pts +
           "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nCELL_DATA 1\nSCALARS tag long\nLOOKUP_TABLE default\n99999999999\n",
       "32 bits"},
      {"field huge", head + pts + "FIELD f 100000000000\n", "bad field array count"},
      {"binary no newline",
       "# vtk DataFile Version 4.2\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 float x0123456789abcdef",
       "end of the line"},
  };
  for (const Case& c : cases) {
    const Result<MeshReadResult> r = parse_vtk(c.text, "bad.vtk");
    ASSERT_FALSE(r.ok()) << c.label;
    EXPECT_NE(r.error().to_string().find(c.expected), std::string::npos) << c.label << ": " << r.error().to_string();
    EXPECT_EQ(r.error().file, "bad.vtk");
    EXPECT_TRUE(r.error().line > 0 || r.error().offset >= 0) << c.label;
  }
}

TEST(VtkWrite, RejectsWrongFieldSize) {
  const TetMesh m = make_box_mesh({.cells = {1, 1, 1}});
  MeshWriteOptions o;
  o.fields.node_fields.push_back({"bad", 3, {1.0, 2.0}});
  std::ostringstream s;
  const Result<void> r = write_vtk(s, m, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("node field bad"), std::string::npos);
}

}  // namespace
}  // namespace shatter
