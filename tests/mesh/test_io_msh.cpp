// Gmsh MSH reader and writer: round trips (ASCII and binary), hand-written 2.2 / 4.1 files,
// binary files built byte by byte, and a table of malformed inputs.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include "shatter/core/file_io.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

/// A jittered box with sparse, shuffled-looking ids and three regions.
TetMesh msh_sample(bool with_tags = true) {
  TetMesh m =
      make_box_mesh({.min = Vec3(-1, 0.25, 3), .max = Vec3(1.5, 1, 4), .cells = {3, 2, 2}, .jitter = 0.2, .seed = 11});
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(1000 + 7 * FileId((i * 5) % m.num_nodes()));
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_ids.push_back(5 + 3 * FileId(e));
  if (with_tags)
    for (Index e = 0; e < m.num_tets(); ++e) m.tet_tags.push_back(e < 20 ? 4 : 1 + (e / 7) % 3);
  return m;
}

std::string write_to_string(const TetMesh& m, bool binary) {
  std::ostringstream s;
  MeshWriteOptions o;
  o.binary = binary;
  const Result<void> r = write_msh(s, m, o);
  EXPECT_TRUE(r.ok()) << r.error().to_string();
  return s.str();
}

void expect_same_mesh(const TetMesh& a, const TetMesh& b) {
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (std::size_t i = 0; i < a.positions.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a.positions[i][k]), std::bit_cast<std::uint64_t>(b.positions[i][k])) << i;
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.node_ids, b.node_ids);
  EXPECT_EQ(a.tet_ids, b.tet_ids);
  EXPECT_EQ(a.tet_tags, b.tet_tags);
  EXPECT_EQ(a.tet_sets, b.tet_sets);
}

TEST(MshRoundTrip, AsciiAndBinaryKeepEverythingBitExact) {
  TetMesh m = msh_sample();
  std::vector<Index> region4;
  for (Index e = 0; e < 20; ++e) region4.push_back(e);
  m.tet_sets["base plate"] = region4;
  for (bool binary : {false, true}) {
    const std::string bytes = write_to_string(m, binary);
    const Result<MeshReadResult> r = parse_msh(bytes, "rt.msh");
    ASSERT_TRUE(r.ok()) << r.error().to_string();
    EXPECT_EQ(r->format, binary ? "msh 4.1 binary" : "msh 4.1 ascii");
    EXPECT_TRUE(r->skipped.empty());
    expect_same_mesh(m, r->mesh);
    // Writing again gives the same bytes.
    EXPECT_EQ(write_to_string(r->mesh, binary), bytes);
  }
}

TEST(MshRoundTrip, UntaggedMeshWithDefaultIdsComesBackUnchanged) {
  const TetMesh m = make_box_mesh({.cells = {2, 2, 2}, .jitter = 0.1});
  for (bool binary : {false, true}) {
    const Result<MeshReadResult> r = parse_msh(write_to_string(m, binary), "rt.msh");
    ASSERT_TRUE(r.ok()) << r.error().to_string();
    EXPECT_TRUE(r->mesh.tet_tags.empty());
    expect_same_mesh(m, r->mesh);
  }
}

// A binary 4.1 tag above the largest int64 (here 2^64 - 1) is refused with its value; it used to
// wrap to the id -1.
TEST(MshRead, BinaryTagAboveInt64IsRefused) {
  TetMesh m = make_box_mesh({.cells = {1, 1, 1}});
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(100 + 7 * FileId(i));
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_ids.push_back(500 + 3 * FileId(e));
  const std::string bytes = write_to_string(m, true);
  for (const FileId id : {FileId{107}, FileId{503}}) {  // neither the smallest nor the largest tag
    std::string s = bytes;
    char le[8];
    std::memcpy(le, &id, 8);
    const std::size_t at = s.find(std::string(le, 8));
    ASSERT_NE(at, std::string::npos);
    std::memset(s.data() + at, 0xFF, 8);
    const Result<MeshReadResult> r = parse_msh(s, "big.msh");
    ASSERT_FALSE(r.ok()) << id;
    EXPECT_NE(r.error().message.find("tag 18446744073709551615 is larger than the largest id"), std::string::npos)
        << r.error().to_string();
  }
}

TEST(MshRead, Version22PhysicalTagsMixedElements) {
  const Result<std::string> bytes = read_file(test::data_path("mesh/two_regions_v22.msh"));
  ASSERT_OK(bytes);
  const Result<MeshReadResult> r = parse_msh(*bytes, "two_regions_v22.msh");
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(r->format, "msh 2.2 ascii");
  const TetMesh& m = r->mesh;
  ASSERT_EQ(m.num_tets(), 2);
  // Nodes 60 and 70 serve only the line, triangle and point: dropped.
  EXPECT_EQ(m.node_ids, (std::vector<FileId>{10, 20, 30, 40, 50}));
  EXPECT_EQ(m.tet_ids, (std::vector<FileId>{7, 9}));
  EXPECT_EQ(m.tet_tags, (std::vector<std::int32_t>{1, 2}));
  EXPECT_EQ(m.tets[1], (TetIndices{1, 4, 2, 3}));
  EXPECT_EQ(m.positions[4], Vec3(1, 1, 1));
  EXPECT_EQ(m.tet_sets.at("core"), std::vector<Index>{0});
  EXPECT_EQ(m.tet_sets.at("shell"), std::vector<Index>{1});
  EXPECT_EQ(m.tet_sets.count("skin"), 0u);
  EXPECT_EQ(r->skipped, (std::vector<std::string>{"1 line (gmsh type 1)", "1 triangle (gmsh type 2)",
                                                  "1 quadratic tetrahedron (gmsh type 11)", "1 point (gmsh type 15)",
                                                  "2 nodes used by no tetrahedron"}));
}

TEST(MshRead, Version41SparseTagsNoEntitiesCrlf) {
  const Result<std::string> bytes = read_file(test::data_path("mesh/sparse_no_entities_v41_crlf.msh"));
  ASSERT_OK(bytes);
  const Result<MeshReadResult> r = parse_msh(*bytes, "sparse.msh");
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(r->format, "msh 4.1 ascii");
  const TetMesh& m = r->mesh;
  EXPECT_EQ(m.node_ids, (std::vector<FileId>{103, 7, 5, 9, 3}));
  EXPECT_EQ(m.tet_ids, (std::vector<FileId>{900, 400}));
  EXPECT_EQ(m.tets[0], (TetIndices{0, 1, 2, 3}));
  EXPECT_EQ(m.tets[1], (TetIndices{1, 4, 2, 3}));
  EXPECT_TRUE(m.tet_tags.empty());
  EXPECT_EQ(r->skipped, (std::vector<std::string>{"1 triangle (gmsh type 2)", "section $Comments"}));
}

TEST(MshRead, Utf8BomIsSkipped) {
  const std::string bytes = "\xEF\xBB\xBF" + write_to_string(msh_sample(), false);
  EXPECT_OK(parse_msh(bytes, "bom.msh"));
}

/// MSH 2.2 binary built byte by byte: two tets (one tagged block) and a triangle block.
std::string binary22(std::int32_t marker = 1, double x0 = 0.0) {
  std::string s = "$MeshFormat\n2.2 1 8\n";
  auto put = [&](auto v) {
    char b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    s.append(b, sizeof v);
  };
  put(marker);
  s += "\n$EndMeshFormat\n$Nodes\n5\n";
  const double xyz[5][3] = {{x0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  for (int i = 0; i < 5; ++i) {
    put(std::int32_t(100 + i));
    for (double c : xyz[i]) put(c);
  }
  s += "\n$EndNodes\n$Elements\n3\n";
  put(std::int32_t(4));  // tets
  put(std::int32_t(2));
  put(std::int32_t(2));
  const std::int32_t tets[2][7] = {{1, 8, 3, 100, 101, 102, 103}, {2, 9, 3, 101, 104, 102, 103}};
  for (const auto& t : tets)
    for (std::int32_t v : t) put(v);
  put(std::int32_t(2));  // one triangle
  put(std::int32_t(1));
  put(std::int32_t(0));
  for (std::int32_t v : {3, 100, 101, 102}) put(v);
  s += "\n$EndElements\n";
  return s;
}

TEST(MshRead, Version22Binary) {
  const Result<MeshReadResult> r = parse_msh(binary22(), "b22.msh");
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(r->format, "msh 2.2 binary");
  EXPECT_EQ(r->mesh.node_ids, (std::vector<FileId>{100, 101, 102, 103, 104}));
  EXPECT_TRUE(r->mesh.tet_ids.empty());  // 1, 2: the default numbering
  EXPECT_EQ(r->mesh.tet_tags, (std::vector<std::int32_t>{8, 9}));
  EXPECT_EQ(r->mesh.tets[1], (TetIndices{1, 4, 2, 3}));
  EXPECT_EQ(r->skipped, std::vector<std::string>{"1 triangle (gmsh type 2)"});
}

TEST(MshRead, BinaryMarkerAndNonFiniteCoordinates) {
  Result<MeshReadResult> r = parse_msh(binary22(0x01000000), "b.msh");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("big-endian"), std::string::npos) << r.error().to_string();
  EXPECT_GE(r.error().offset, 0);
  r = parse_msh(binary22(7), "b.msh");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("endianness marker"), std::string::npos);
  r = parse_msh(binary22(1, std::numeric_limits<double>::quiet_NaN()), "b.msh");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("not finite"), std::string::npos) << r.error().to_string();
  // Truncated at every byte: never ok, never a crash.
  const std::string full = binary22();
  for (std::size_t n = 0; n + 1 < full.size(); ++n) EXPECT_FALSE(parse_msh(full.substr(0, n), "t.msh").ok()) << n;
}

TEST(MshRead, TruncatedRoundTripFilesFailCleanly) {
  for (bool binary : {false, true}) {
    const std::string full = write_to_string(msh_sample(), binary);
    // Every prefix that cuts a section short fails (step keeps the test fast).
    for (std::size_t n = 0; n + 14 < full.size(); n += 7) {
      const Result<MeshReadResult> r = parse_msh(full.substr(0, n), "t.msh");
      EXPECT_FALSE(r.ok()) << n;
    }
  }
}

struct BadCase {
  const char* label;
  std::string text;
  const char* expected;
};

const std::string kHeader22 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
const std::string kNodes22 = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";
const std::string kHeader41 = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";

TEST(MshRead, MalformedInputs) {
  const std::vector<BadCase> cases = {
      {"empty", "", "empty file"},
      {"only spaces", "  \n\n ", "empty file"},
      {"not msh", "solid cube\n", "not a Gmsh MSH file"},
      {"version 4.0", "$MeshFormat\n4 0 8\n$EndMeshFormat\n", "unsupported MSH version"},
      {"data size", "$MeshFormat\n2.2 0 4\n$EndMeshFormat\n", "data size 8"},
      {"file type", "$MeshFormat\n2.2 3 8\n$EndMeshFormat\n", "file type"},
      {"truncated format", "$MeshFormat\n2.2 0", "data size"},
      {"no end format", "$MeshFormat\n2.2 0 8\n$Nodes\n", "$EndMeshFormat"},
      {"no nodes", kHeader22, "without a $Nodes"},
      {"no elements", kHeader22 + kNodes22, "without an $Elements"},
      {"elements first", kHeader22 + "$Elements\n0\n$EndElements\n", "before $Nodes"},
      {"huge node count", kHeader22 + "$Nodes\n1000000000000000000\n1 0 0 0\n$EndNodes\n", "exceeds the limit"},
      {"node count over data", kHeader22 + "$Nodes\n1000\n1 0 0 0\n$EndNodes\n", "bytes that remain"},
      {"negative node count", kHeader22 + "$Nodes\n-3\n$EndNodes\n", "negative node count"},
      {"truncated nodes", kHeader22 + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0", "z coordinate"},
      {"nan coordinate", kHeader22 + "$Nodes\n1\n1 nan 0 0\n$EndNodes\n", "finite number"},
      {"inf coordinate", kHeader22 + "$Nodes\n1\n1 0 inf 0\n$EndNodes\n", "finite number"},
      {"duplicate node tag", kHeader22 + "$Nodes\n2\n5 0 0 0\n5 1 0 0\n$EndNodes\n", "appears twice"},
      {"missing end nodes", kHeader22 + "$Nodes\n1\n1 0 0 0\n$Elements\n", "$EndNodes"},
      {"huge element count", kHeader22 + kNodes22 + "$Elements\n999999999999999999\n$EndElements\n",
       "bytes that remain"},
      {"unknown node", kHeader22 + kNodes22 + "$Elements\n1\n1 4 0 1 2 3 99\n$EndElements\n", "node 99"},
      {"negative node", kHeader22 + kNodes22 + "$Elements\n1\n1 4 0 1 2 3 -1\n$EndElements\n", "node -1"},
      {"truncated elements", kHeader22 + kNodes22 + "$Elements\n1\n1 4 0 1 2", "node tag"},
      {"bad tag count", kHeader22 + kNodes22 + "$Elements\n1\n1 4 99999999999 1 2 3 4\n$EndElements\n", "tag count"},
      {"no tets", kHeader22 + kNodes22 + "$Elements\n1\n1 2 0 1 2 3\n$EndElements\n", "no linear tetrahedra"},
      {"unterminated section", kHeader22 + "$Comments\nhello\n", "has no $EndComments"},
      {"garbage between sections", kHeader22 + "hello\n", "expected a section"},
      {"second nodes", kHeader22 + kNodes22 + kNodes22, "second $Nodes"},
      {"41 block overflow", kHeader41 + "$Nodes\n1 1 1 1\n0 1 0 5\n1\n0 0 0\n$EndNodes\n", "blocks hold more"},
      {"41 huge blocks", kHeader41 + "$Nodes\n1000000000000000000 1 1 1\n0 1 0 1\n1\n0 0 0\n$EndNodes\n",
       "node block count"},
      {"41 count mismatch", kHeader41 + "$Nodes\n1 3 1 3\n0 1 0 1\n1\n0 0 0\n$EndNodes\n", "3 declared"},
      {"41 entity huge", kHeader41 + "$Entities\n0 0 0 1000000000000\n$EndEntities\n", "bytes that remain"},
      {"41 element block huge",
       kHeader41 + "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n" +
           "$Elements\n1 1 1 1\n3 1 4 999999999999\n1 1 2 3 4\n$EndElements\n",
       "blocks hold more"},
      {"41 unknown type unterminated",
       kHeader41 + "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n" +
           "$Elements\n1 2 1 2\n3 1 777 2\n1 1 2\n",
       "ends inside an element block"},
  };
  for (const BadCase& c : cases) {
    const Result<MeshReadResult> r = parse_msh(c.text, "bad.msh");
    ASSERT_FALSE(r.ok()) << c.label;
    EXPECT_NE(r.error().to_string().find(c.expected), std::string::npos) << c.label << ": " << r.error().to_string();
    EXPECT_EQ(r.error().file, "bad.msh") << c.label;
    EXPECT_TRUE(r.error().line > 0 || r.error().offset >= 0) << c.label;
  }
}

TEST(MshRead, BinaryHugeCountsFailWithoutAllocating) {
  // 4.1 binary $Nodes header claiming 2^62 nodes.
  std::string s = "$MeshFormat\n4.1 1 8\n";
  auto put = [&](auto v) {
    char b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    s.append(b, sizeof v);
  };
  put(std::int32_t(1));
  s += "\n$EndMeshFormat\n$Nodes\n";
  put(std::uint64_t(1));
  put(std::uint64_t(1) << 30);
  put(std::uint64_t(1));
  put(std::uint64_t(1) << 30);
  s += "\n$EndNodes\n";
  const Result<MeshReadResult> r = parse_msh(s, "huge.msh");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("remain"), std::string::npos) << r.error().to_string();
}

}  // namespace
}  // namespace shatter
