// VTK XML (.vtu) reader and writer, the XML tokenizer, base64, and the .pvd series writer.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <sstream>

#include "shatter/core/file_io.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/base64.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/xml_lite.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TetMesh vtu_sample_mesh() {
  TetMesh m = make_box_mesh({.min = Vec3(0, -1, -1),
                             .max = Vec3(2, 1, 0),
                             .cells = {2, 3, 2},
                             .pattern = BoxMeshDef::Pattern::five,
                             .jitter = 0.2,
                             .seed = 3});
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(7 + 11 * FileId(i));
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_ids.push_back(FileId(m.num_tets()) - e + 1000);
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_tags.push_back(e % 3);
  return m;
}

std::string vtu_string(const TetMesh& m, bool binary, const MeshFields& fields = {}) {
  std::ostringstream s;
  MeshWriteOptions o;
  o.binary = binary;
  o.fields = fields;
  const Result<void> r = write_vtu(s, m, o);
  EXPECT_TRUE(r.ok()) << r.error().to_string();
  return s.str();
}

TEST(Base64, EncodeDecodeAllLengths) {
  std::string bytes;
  for (int n = 0; n < 40; ++n) {
    std::string text, back;
    io::base64_encode(bytes, text);
    std::size_t bad = 0;
    ASSERT_TRUE(io::base64_decode(text, back, bad));
    EXPECT_EQ(back, bytes);
    bytes += static_cast<char>(n * 37 + 200);
  }
  std::string text;
  io::base64_encode("Man", text);
  EXPECT_EQ(text, "TWFu");
  // Two separately padded blocks decode as one stream.
  std::string out;
  std::size_t bad = 0;
  ASSERT_TRUE(io::base64_decode("TQ==\n TWE=", out, bad));
  EXPECT_EQ(out, "MMa");
  EXPECT_FALSE(io::base64_decode("TW*u", out, bad));
  EXPECT_EQ(bad, 2u);
  EXPECT_FALSE(io::base64_decode("T", out, bad));
}

TEST(VtuRoundTrip, AsciiAndBinaryWithFields) {
  const TetMesh m = vtu_sample_mesh();
  MeshFields fields;
  MeshField disp{"displacement", 3, {}}, s{"von Mises <Pa>", 1, {}};
  for (Index i = 0; i < m.num_nodes(); ++i)
    for (int k = 0; k < 3; ++k) disp.values.push_back(1e-3 * i - k);
  for (Index e = 0; e < m.num_tets(); ++e) s.values.push_back(3.5e6 * e);
  fields.node_fields = {disp};
  fields.tet_fields = {s};
  for (bool binary : {false, true}) {
    const std::string bytes = vtu_string(m, binary, fields);
    const Result<MeshReadResult> r = parse_vtu(bytes, "rt.vtu");
    ASSERT_TRUE(r.ok()) << r.error().to_string();
    EXPECT_EQ(r->format, binary ? "vtu binary" : "vtu ascii");
    ASSERT_EQ(r->mesh.positions.size(), m.positions.size());
    for (std::size_t i = 0; i < m.positions.size(); ++i)
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(std::bit_cast<std::uint64_t>(m.positions[i][k]),
                  std::bit_cast<std::uint64_t>(r->mesh.positions[i][k]));
    EXPECT_EQ(r->mesh.tets, m.tets);
    EXPECT_EQ(r->mesh.node_ids, m.node_ids);
    EXPECT_EQ(r->mesh.tet_ids, m.tet_ids);
    EXPECT_EQ(r->mesh.tet_tags, m.tet_tags);
    EXPECT_NE(bytes.find("von Mises &lt;Pa&gt;"), std::string::npos);
    // Same mesh, same bytes.
    EXPECT_EQ(vtu_string(r->mesh, binary, fields), bytes);
  }
}

/// A file laid out as meshio writes it (UInt32 headers, combined base64), with a triangle too.
std::string meshio_like(bool separate_header_encoding) {
  auto block = [&](const std::string& data) {
    const std::uint32_t n = static_cast<std::uint32_t>(data.size());
    std::string header(4, '\0');
    std::memcpy(header.data(), &n, 4);
    std::string text;
    if (separate_header_encoding) {
      io::base64_encode(header, text);
      io::base64_encode(data, text);
    } else {
      io::base64_encode(header + data, text);
    }
    return text;
  };
  auto raw = [](const auto& values) {
    std::string s(sizeof(values[0]) * values.size(), '\0');
    std::memcpy(s.data(), values.data(), s.size());
    return s;
  };
  const std::vector<double> pts = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 5, 5, 5};
  const std::vector<std::int64_t> conn = {0, 1, 4, 0, 1, 2, 3};
  const std::vector<std::int64_t> offs = {3, 7};
  const std::vector<std::uint8_t> types = {5, 10};
  const std::vector<std::int32_t> phys = {1, 8};
  return "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "<!-- written by a tool -->\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"5\" NumberOfCells=\"2\">\n<Points>\n"
         "<DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"binary\">\n" +
         block(raw(pts)) +
         "\n</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"binary\">\n" +
         block(raw(conn)) + "\n</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"binary\">\n" +
         block(raw(offs)) + "\n</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"binary\">\n" +
         block(raw(types)) +
         "\n</DataArray>\n</Cells>\n<CellData>\n<DataArray type=\"Int32\" Name=\"gmsh:physical\" format=\"binary\">\n" +
         block(raw(phys)) + "\n</DataArray>\n</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
}

TEST(VtuRead, MeshioLayoutBothBase64Styles) {
  for (bool separate : {false, true}) {
    const Result<MeshReadResult> r = parse_vtu(meshio_like(separate), "meshio.vtu");
    ASSERT_TRUE(r.ok()) << r.error().to_string();
    EXPECT_EQ(r->mesh.num_nodes(), 4);
    ASSERT_EQ(r->mesh.num_tets(), 1);
    EXPECT_EQ(r->mesh.tets[0], (TetIndices{0, 1, 2, 3}));
    EXPECT_EQ(r->mesh.tet_tags, std::vector<std::int32_t>{8});
    EXPECT_EQ(r->skipped, (std::vector<std::string>{"1 cell of vtk type 5", "1 node used by no tetrahedron"}));
  }
}

TEST(VtuRead, MalformedInputs) {
  const std::string ascii = vtu_string(vtu_sample_mesh(), false);
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string s = ascii;
    const std::size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) s.replace(at, from.size(), to);
    return s;
  };
  std::string deep = "<VTKFile type=\"UnstructuredGrid\">";
  for (int i = 0; i < 100; ++i) deep += "<a>";
  struct Case {
    const char* label;
    std::string text;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {"empty", "", "empty file"},
      {"blank", " \n ", "empty file"},
      {"not xml", "hello", "text outside the root"},
      {"wrong root", "<Foo/>", "<VTKFile>"},
      {"wrong type", "<VTKFile type=\"PolyData\"/>", "UnstructuredGrid"},
      {"compressed", replaced("header_type=\"UInt64\"", "header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\""),
       "compressed VTU not supported"},
      {"appended", ascii + "<AppendedData encoding=\"raw\">_\x01\x02</AppendedData>", "AppendedData"},
      {"unterminated", ascii.substr(0, ascii.size() / 2), "file ends inside"},
      {"mismatched", replaced("</Points>", "</Cells>"), "does not match"},
      {"doctype", "<!DOCTYPE x [<!ENTITY a \"b\">]><VTKFile/>", "DOCTYPE"},
      {"deep", deep, "nested deeper"},
      {"bad attribute", "<VTKFile type=UnstructuredGrid/>", "quoted value"},
      {"bad entity", "<VTKFile type=\"&bogus;\"/>", "character reference"},
      {"duplicate attribute", "<VTKFile type=\"a\" type=\"b\"/>", "appears twice"},
      {"huge points", replaced("NumberOfPoints=\"", "NumberOfPoints=\"1000000000000000000"), "NumberOfPoints"},
      {"negative cells", replaced("NumberOfCells=\"", "NumberOfCells=\"-"), "out of range"},
      {"more points", replaced("NumberOfPoints=\"", "NumberOfPoints=\"9"), "fewer values"},
      {"nan point",
       replaced("Name=\"Points\" NumberOfComponents=\"3\" format=\"ascii\">\n          ",
                "Name=\"Points\" NumberOfComponents=\"3\" format=\"ascii\">\n          nan "),
       "finite number"},
      {"components", replaced("NumberOfComponents=\"3\"", "NumberOfComponents=\"2\""), "NumberOfComponents=\"3\""},
      {"bad type", replaced("type=\"Float64\" Name=\"Points\"", "type=\"Float65\" Name=\"Points\""),
       "unknown or missing type"},
      {"no connectivity", replaced("Name=\"connectivity\"", "Name=\"conn\""), "connectivity, offsets and types"},
      {"bad format", replaced("Name=\"offsets\" format=\"ascii\"", "Name=\"offsets\" format=\"hex\""),
       "unknown DataArray format"},
      {"offsets decrease",
       replaced("Name=\"offsets\" format=\"ascii\">\n          4 8",
                "Name=\"offsets\" format=\"ascii\">\n          8 4"),
       "decrease"},
      {"second root", ascii + "<VTKFile/>", "second root"},
  };
  for (const Case& c : cases) {
    const Result<MeshReadResult> r = parse_vtu(c.text, "bad.vtu");
    ASSERT_FALSE(r.ok()) << c.label;
    EXPECT_NE(r.error().to_string().find(c.expected), std::string::npos) << c.label << ": " << r.error().to_string();
    EXPECT_GT(r.error().line, 0) << c.label;
  }
}

TEST(VtuRead, BinaryCorruptions) {
  const std::string bin = vtu_string(vtu_sample_mesh(), true);
  // Invalid base64 character inside the points array.
  std::string s = bin;
  const std::size_t at = s.find("Name=\"Points\"");
  s[s.find('\n', at) + 12] = '*';
  Result<MeshReadResult> r = parse_vtu(s, "b.vtu");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("invalid base64"), std::string::npos) << r.error().to_string();
  // A byte-count header that disagrees with NumberOfPoints.
  s = bin;
  const std::size_t np = s.find("NumberOfPoints=\"") + 16;
  s.insert(np, "1");
  r = parse_vtu(s, "b.vtu");
  ASSERT_FALSE(r.ok());
  // Every truncation fails cleanly.
  for (std::size_t n = 0; n < bin.size(); n += 13) EXPECT_FALSE(parse_vtu(bin.substr(0, n), "t.vtu").ok()) << n;
}

TEST(Pvd, RewritesTheSeriesAfterEveryStep) {
  test::TempDir dir;
  PvdSeries series(dir.file("run.pvd"));
  ASSERT_OK(series.add(0.0, "frame_0000.vtu"));
  ASSERT_OK(series.add(0.1, "frames/a&b.vtu"));
  const Result<std::string> text = read_file(series.path());
  ASSERT_OK(text);
  const Result<io::XmlDocument> doc = io::parse_xml(*text, "run.pvd");
  ASSERT_TRUE(doc.ok()) << doc.error().to_string();
  std::vector<std::string> files, times;
  for (const io::XmlElement& e : doc->elements)
    if (e.name == "DataSet") {
      files.push_back(*e.attribute("file"));
      times.push_back(*e.attribute("timestep"));
    }
  EXPECT_EQ(files, (std::vector<std::string>{"frame_0000.vtu", "frames/a&b.vtu"}));
  EXPECT_EQ(times, (std::vector<std::string>{"0", "0.1"}));
  EXPECT_FALSE(series.add(std::nan(""), "x.vtu").ok());
  PvdSeries bad(dir.file("missing/dir/run.pvd"));
  EXPECT_FALSE(bad.add(0.0, "a.vtu").ok());
}

}  // namespace
}  // namespace shatter
