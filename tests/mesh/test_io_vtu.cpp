// VTK XML (.vtu) reader and writer, the XML tokenizer, base64, and the .pvd series writer.
#include <gtest/gtest.h>

#include <bit>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
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

std::string vtu_string(const TetMesh& m, bool binary, const MeshFields& fields = {}, bool compress = false) {
  std::ostringstream s;
  MeshWriteOptions o;
  o.binary = binary;
  o.compress = compress;
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
  // RFC 4648's vectors, each appended to what the string already holds.
  std::string appended = "<";
  for (const char* s : {"", "f", "fo", "foo", "foob", "fooba", "foobar"}) io::base64_encode(s, appended);
  EXPECT_EQ(appended, "<Zg==Zm8=Zm9vZm9vYg==Zm9vYmE=Zm9vYmFy");
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
      {"lz4", replaced("header_type=\"UInt64\"", "header_type=\"UInt64\" compressor=\"vtkLZ4DataCompressor\""),
       "only vtkZLibDataCompressor"},
      {"appended after the root", ascii + "<AppendedData encoding=\"raw\">_\x01\x02</AppendedData>", "</VTKFile>"},
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

/// The mesh of tests/data/mesh/vtu/expected.json (points as shortest round-trip text).
struct ExpectedMesh {
  std::vector<Vec3> points;
  std::vector<TetIndices> tets;
};

ExpectedMesh fixture_mesh() {
  ExpectedMesh m;
  const Result<std::string> text = read_file(test::data_path("mesh/vtu/expected.json"));
  EXPECT_TRUE(text.ok());
  if (!text.ok()) return m;
  const nlohmann::json j = nlohmann::json::parse(*text);
  for (const auto& p : j.at("points")) {
    Vec3 v;
    for (int k = 0; k < 3; ++k) v[k] = std::strtod(p.at(k).get<std::string>().c_str(), nullptr);
    m.points.push_back(v);
  }
  for (const auto& t : j.at("tets"))
    m.tets.push_back({t[0].get<Index>(), t[1].get<Index>(), t[2].get<Index>(), t[3].get<Index>()});
  return m;
}

void expect_bitwise(const TetMesh& got, const std::vector<Vec3>& points, const std::vector<TetIndices>& tets) {
  ASSERT_EQ(got.positions.size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(std::bit_cast<std::uint64_t>(got.positions[i][k]), std::bit_cast<std::uint64_t>(points[i][k]))
          << "point " << i << " component " << k;
  EXPECT_EQ(got.tets, tets);
}

struct Fixture {
  const char* file;
  const char* format;
};
// Written by tests/data/mesh/vtu/make_fixtures.py with meshio 7 and VTK 9.1 (Debian 12).
const Fixture kFixtures[] = {
    {"meshio_default.vtu", "vtu binary zlib"},         {"meshio_uint64.vtu", "vtu binary zlib"},
    {"meshio_uncompressed.vtu", "vtu binary"},         {"vtk_default.vtu", "vtu appended base64 zlib"},
    {"vtk_appended_raw.vtu", "vtu appended raw zlib"}, {"vtk_inline_binary.vtu", "vtu binary zlib"},
    {"vtk_appended_plain.vtu", "vtu appended raw"},    {"vtk_small_blocks.vtu", "vtu appended raw zlib"},
};

std::string fixture_bytes(const char* file) {
  const Result<std::string> bytes = read_file(test::data_path(std::string("mesh/vtu/") + file));
  EXPECT_TRUE(bytes.ok()) << file;
  return bytes.ok() ? *bytes : std::string();
}

TEST(VtuRead, MeshioAndVtkFilesReadBackExactly) {
  const ExpectedMesh expected = fixture_mesh();
  ASSERT_EQ(expected.points.size(), 36u);
  ASSERT_EQ(expected.tets.size(), 72u);
  for (const Fixture& f : kFixtures) {
    SCOPED_TRACE(f.file);
    const Result<MeshReadResult> r = parse_vtu(fixture_bytes(f.file), f.file);
    ASSERT_TRUE(r.ok()) << r.error().to_string();
    EXPECT_EQ(r->format, f.format);
    expect_bitwise(r->mesh, expected.points, expected.tets);
    EXPECT_TRUE(r->skipped.empty());
  }
  // Through read_mesh too (validated: every tet is positively oriented, nothing repaired).
  const Result<MeshReadResult> r = read_mesh(test::data_path("mesh/vtu/vtk_appended_raw.vtu"));
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  expect_bitwise(r->mesh, expected.points, expected.tets);
}

TEST(VtuRoundTrip, CompressedWithFieldsAndManyBlocks) {
  // 21^3 nodes: the points (222 KB) span several 32 KiB zlib blocks.
  TetMesh big =
      make_box_mesh({.min = Vec3(0, 0, 0), .max = Vec3(1, 2, 3), .cells = {20, 20, 20}, .jitter = 0.3, .seed = 9});
  for (const TetMesh& m : {vtu_sample_mesh(), big}) {
    MeshFields fields;
    MeshField s{"s", 1, {}};
    for (Index e = 0; e < m.num_tets(); ++e) s.values.push_back(0.1 * e);
    fields.tet_fields = {s};
    const std::string bytes = vtu_string(m, false, fields, true);
    EXPECT_NE(bytes.find("compressor=\"vtkZLibDataCompressor\""), std::string::npos);
    const Result<MeshReadResult> r = parse_vtu(bytes, "z.vtu");
    ASSERT_TRUE(r.ok()) << r.error().to_string();
    EXPECT_EQ(r->format, "vtu binary zlib");
    expect_bitwise(r->mesh, m.positions, m.tets);
    EXPECT_EQ(r->mesh.node_ids, m.node_ids);
    EXPECT_EQ(r->mesh.tet_ids, m.tet_ids);
    EXPECT_EQ(r->mesh.tet_tags, m.tet_tags);
    EXPECT_EQ(vtu_string(r->mesh, false, fields, true), bytes);  // deterministic
    if (m.num_nodes() > 5000) {
      EXPECT_LT(bytes.size(), vtu_string(m, true, fields).size());
    }
  }
}

/// Every error names the file; none crashes. Returns the message.
std::string expect_fails(const std::string& bytes, const std::string& label) {
  const Result<MeshReadResult> r = parse_vtu(bytes, "bad.vtu");
  EXPECT_FALSE(r.ok()) << label;
  if (r.ok()) return {};
  EXPECT_NE(r.error().to_string().find("bad.vtu"), std::string::npos) << label << ": " << r.error().to_string();
  return r.error().to_string();
}

TEST(VtuRead, CorruptCompressedAndAppendedData) {
  // Truncated anywhere: an error (never a crash), for every layout.
  for (const Fixture& f : kFixtures) {
    const std::string bytes = fixture_bytes(f.file);
    for (std::size_t n = 0; n < bytes.size(); n += 7)
      expect_fails(bytes.substr(0, n), std::string(f.file) + " cut at " + std::to_string(n));
  }
  // Any byte of the appended data changed: an error or (when it only changes a value) a mesh, never a crash.
  for (const char* file : {"vtk_appended_raw.vtu", "vtk_default.vtu", "vtk_small_blocks.vtu", "meshio_default.vtu"}) {
    const std::string bytes = fixture_bytes(file);
    const std::size_t from = bytes.find("<Points>");
    for (std::size_t i = from; i < bytes.size(); i += 3) {
      std::string s = bytes;
      s[i] = static_cast<char>(s[i] ^ 0x5A);
      (void)parse_vtu(s, "bad.vtu");
    }
  }
  // Sizes in the zlib block header: each refused before anything is allocated.
  const std::string raw = fixture_bytes("vtk_appended_raw.vtu");  // UInt64 headers, the points at offset 0
  const std::size_t data = raw.find('_', raw.find("<AppendedData")) + 1;
  auto with_header = [&](int item, std::uint64_t value) {
    std::string s = raw;
    std::memcpy(s.data() + data + 8 * static_cast<std::size_t>(item), &value, 8);
    return s;
  };
  std::string m = expect_fails(with_header(0, ~std::uint64_t{0}), "nblocks");
  EXPECT_NE(m.find("DataArray 'Points'"), std::string::npos) << m;
  EXPECT_NE(m.find("block sizes"), std::string::npos) << m;
  m = expect_fails(with_header(0, 2), "two blocks");
  EXPECT_NE(m.find("expected 864"), std::string::npos) << m;  // 36 points x 3 x 8 bytes
  {
    std::string t = with_header(0, 3);
    const std::uint64_t huge = std::uint64_t{1} << 63;
    std::memcpy(t.data() + data + 8, &huge, 8);
    m = expect_fails(t, "block size overflow");
    EXPECT_NE(m.find("overflow"), std::string::npos) << m;
  }
  m = expect_fails(with_header(2, 1u << 20), "last block");
  EXPECT_NE(m.find("larger than the block size"), std::string::npos) << m;
  m = expect_fails(with_header(3, std::uint64_t{1} << 40), "compressed size");
  EXPECT_NE(m.find("does not fit"), std::string::npos) << m;
  m = expect_fails(with_header(3, 8), "short compressed block");
  EXPECT_NE(m.find("compressed block 0"), std::string::npos) << m;
  // A block claiming far more than its compressed bytes can hold (a "zip bomb" of 1.5 GB).
  {
    const std::uint64_t n = std::uint64_t{1} << 26;
    std::string t = with_header(1, 24 * n);
    std::memcpy(t.data() + data + 16, "\0\0\0\0\0\0\0\0", 8);
    const std::string np = "NumberOfPoints=\"36\"";
    t.replace(t.find(np), np.size(), "NumberOfPoints=\"" + std::to_string(n) + "\"");
    m = expect_fails(t, "bomb");
    EXPECT_NE(m.find("more than zlib can produce"), std::string::npos) << m;
  }
  // Bad offsets and encodings.
  std::string s = raw;
  s.replace(s.find("offset=\"0\""), 10, "offset=\"999999\"");
  m = expect_fails(s, "offset");
  EXPECT_NE(m.find("outside the"), std::string::npos) << m;
  s = raw;
  s.replace(s.find("encoding=\"raw\""), 14, "encoding=\"hex\"");
  m = expect_fails(s, "encoding");
  EXPECT_NE(m.find("encoding"), std::string::npos) << m;
  s = raw;
  s.erase(s.find("</AppendedData>"), 15);
  m = expect_fails(s, "no end tag");
  EXPECT_NE(m.find("</AppendedData>"), std::string::npos) << m;
  s = raw;
  s.erase(data - 1, 1);
  m = expect_fails(s, "no underscore");
  EXPECT_NE(m.find("'_'"), std::string::npos) << m;
  // Appended arrays without <AppendedData>.
  s = raw.substr(0, raw.find("<AppendedData")) + "</VTKFile>\n";
  m = expect_fails(s, "no appended data");
  EXPECT_NE(m.find("no <AppendedData>"), std::string::npos) << m;
  // Invalid base64 in appended base64 data.
  s = fixture_bytes("vtk_default.vtu");
  s[s.find('_', s.find("<AppendedData")) + 5] = '*';
  m = expect_fails(s, "base64");
  EXPECT_NE(m.find("invalid base64"), std::string::npos) << m;
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
