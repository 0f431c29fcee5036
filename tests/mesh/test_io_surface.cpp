// Surface readers and writers (OBJ, PLY, STL): variants, exact round trips, malformed input.
#include <gtest/gtest.h>

#include <cstring>
#include <sstream>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

void expect_surface_error(const Result<SurfaceReadResult>& r, const std::string& substring, std::int64_t line,
                          std::int64_t offset = -1) {
  test::expect_read_error(r, substring, line, "", offset);
}

TriSurface box_surface() {
  return boundary_surface(
      make_box_mesh({.min = Vec3(-1, 0.1, 0), .max = Vec3(0.3, 1, 2), .cells = {2, 2, 2}, .jitter = 0.2}));
}

/// Same positions (bit-exact) and triangles; the per-vertex node / per-triangle tet maps are not stored.
void expect_same(const TriSurface& a, const TriSurface& b) {
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.triangles, b.triangles);
}

/// Same triangles in the same order with bit-exact corner positions (STL renumbers vertices).
void expect_same_geometry(const TriSurface& a, const TriSurface& b) {
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  EXPECT_EQ(a.positions.size(), b.positions.size());
  for (std::size_t t = 0; t < a.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_TRUE(a.positions[a.triangles[t][k]] == b.positions[b.triangles[t][k]])
          << "triangle " << t << ": " << a.positions[a.triangles[t][k]].transpose() << " vs "
          << b.positions[b.triangles[t][k]].transpose();
}

TEST(ObjRead, FormsNegativeIndicesAndPolygons) {
  auto r = parse_obj(
      "# comment\nmtllib a.mtl\no thing\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0\nv 0 1 0 0.5 0.5 0.5\nvt 0 0\nvn 0 0 1\n"
      "f 1/1/1 2/1/1 3/1/1\nf -4//1 -2//1 -1//1\nf 1 2 3 4\nl 1 2\n",
      "t.obj");
  ASSERT_OK(r);
  EXPECT_EQ(r->surface.positions.size(), 4u);
  EXPECT_EQ(r->surface.triangles, (std::vector<TriIndices>{{0, 1, 2}, {0, 2, 3}, {0, 1, 2}, {0, 2, 3}}));
  EXPECT_EQ(r->skipped, (std::vector<std::string>{"polygons triangulated: 1", "1 lines"}));
}

TEST(ObjRead, Malformed) {
  expect_surface_error(parse_obj("v 0 0\n", "t.obj"), "v x y z", 1);
  expect_surface_error(parse_obj("v 0 0 nan\n", "t.obj"), "finite number", 1);
  expect_surface_error(parse_obj("\xEF\xBB\xBFv 0 0 0\r\nf 1 2 3\r\n", "t.obj"), "there are 1 vertices", 2);
  expect_surface_error(parse_obj("v 0 0 0\nf 1 0 1\n", "t.obj"), "non-zero integer", 2);
  expect_surface_error(parse_obj("v 0 0 0\nf 1 -2 1\n", "t.obj"), "before the first vertex", 2);
  expect_surface_error(parse_obj("v 0 0 0\nf 1 1000000000000000000 1\n", "t.obj"), "there are 1 vertices", 2);
  expect_surface_error(parse_obj("v 0 0 0\nf 1 x 1\n", "t.obj"), "vertex index", 2);
  auto empty = parse_obj("", "t.obj");
  ASSERT_OK(empty);
  EXPECT_TRUE(empty->surface.positions.empty());
}

TEST(PlyRead, AsciiAndBinaryVariants) {
  auto a = parse_ply(
      "ply\r\nformat ascii 1.0\r\ncomment hi\r\nelement vertex 4\r\nproperty float x\r\nproperty float y\r\n"
      "property float z\r\nproperty uchar red\r\nproperty int id\r\nelement face 1\r\nproperty list uchar uint "
      "vertex_indices\r\n"
      "element edge 1\r\nproperty int a\r\nproperty int b\r\nend_header\r\n0 0 0 255 10\r\n1 0 0 0 11\r\n1 1 0 0 "
      "12\r\n0 1 0 0 13\r\n"
      "4 0 1 2 3\r\n0 1\r\n",
      "t.ply");
  ASSERT_OK(a);
  EXPECT_EQ(a->surface.triangles, (std::vector<TriIndices>{{0, 1, 2}, {0, 2, 3}}));
  EXPECT_EQ(a->vertex_ids, (std::vector<FileId>{10, 11, 12, 13}));
  EXPECT_EQ(a->surface.positions[2], Vec3(1, 1, 0));
  // Big endian, float coordinates, short list lengths.
  std::string be =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list ushort short vertex_indices\nend_header\n";
  auto put_be = [&](const void* p, int n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (int i = n - 1; i >= 0; --i) be += static_cast<char>(b[i]);
  };
  const float xs[9] = {0, 0, 0, 2, 0, 0, 0, 3, 0.5f};
  for (float x : xs) put_be(&x, 4);
  const std::uint16_t three = 3;
  put_be(&three, 2);
  for (std::int16_t v : {std::int16_t(0), std::int16_t(1), std::int16_t(2)}) put_be(&v, 2);
  auto b = parse_ply(be, "t.ply");
  ASSERT_OK(b);
  EXPECT_EQ(b->format, "ply binary_big_endian");
  EXPECT_EQ(b->surface.positions[2], Vec3(0, 3, 0.5));
  EXPECT_EQ(b->surface.triangles, (std::vector<TriIndices>{{0, 1, 2}}));
}

TEST(PlyRead, Malformed) {
  const std::string h =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";  // 9 lines
  expect_surface_error(parse_ply("", "t.ply"), "empty file", 1);
  expect_surface_error(parse_ply("plx\n", "t.ply"), "expected 'ply'", 1);
  expect_surface_error(parse_ply("ply\nformat ascii 1.0\n", "t.ply"), "before 'end_header'", 3);
  expect_surface_error(parse_ply("ply\nformat foo 1.0\nend_header\n", "t.ply"), "unknown PLY format", 2);
  expect_surface_error(parse_ply("ply\nend_header\n", "t.ply"), "no 'format'", 3);
  expect_surface_error(parse_ply("ply\nformat ascii 1.0\nelement vertex -1\nend_header\n", "t.ply"), "element count",
                       3);
  expect_surface_error(
      parse_ply("ply\nformat ascii 1.0\nelement vertex 1000000000000000000\nproperty float x\nproperty float y\n"
                "property float z\nend_header\n0 0 0\n",
                "t.ply"),
      "larger than the", 3);
  expect_surface_error(parse_ply("ply\nformat ascii 1.0\nelement vertex 5\nend_header\n", "t.ply"), "no properties", 3);
  expect_surface_error(parse_ply("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n", "t.ply"),
                       "x, y and z", 3);
  expect_surface_error(parse_ply("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\n", "t.ply"),
                       "unknown PLY type", 4);
  expect_surface_error(parse_ply(h + "0 0 0\n1 0 0\n0 1 nan\n3 0 1 2\n", "t.ply"), "finite number", 12);
  expect_surface_error(parse_ply(h + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "t.ply"), "there are 3 vertices", 13);
  expect_surface_error(parse_ply(h + "0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n", "t.ply"), "there are 3 vertices", 13);
  expect_surface_error(parse_ply(h + "0 0 0\n1 0 0\n0 1 0\n200 0 1 2\n", "t.ply"), "list length 200", 13);
  // Binary: a list length larger than the bytes left, reported by byte offset.
  std::string bin =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty list int double x\nproperty float y\n"
      "property float z\nend_header\n";
  const std::size_t start = bin.size();
  const std::int32_t huge = 1000000000;
  bin.append(reinterpret_cast<const char*>(&huge), 4);
  bin.append(8, '\0');
  expect_surface_error(parse_ply(bin, "t.ply"), "must not be a list", 3);
  std::string bin2 =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
      "property double z\nend_header\n";
  const std::size_t start2 = bin2.size();
  bin2.append(24, '\0');
  const double nan = std::numeric_limits<double>::quiet_NaN();
  bin2.append(reinterpret_cast<const char*>(&nan), 8);
  bin2.append(16, '\0');
  expect_surface_error(parse_ply(bin2, "t.ply"), "finite number", -1, static_cast<std::int64_t>(start2 + 32));
  (void)start;
}

TEST(StlRead, AsciiPolygonsWeldingAndBinaryStartingWithSolid) {
  auto a = parse_stl(
      "solid cube\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 1 1 0\n "
      "endloop\nendfacet\n"
      "FACET NORMAL nan nan nan\nOUTER LOOP\nVERTEX 0 0 0\nVERTEX 1 1 0\nVERTEX -0 1 0\nVERTEX -0.5 0.5 "
      "0\nENDLOOP\nENDFACET\n"
      "endsolid cube\nsolid two\nendsolid\n",
      "t.stl");
  ASSERT_OK(a);
  EXPECT_EQ(a->format, "stl ascii");
  EXPECT_EQ(a->surface.positions.size(), 5u);
  EXPECT_EQ(a->surface.triangles, (std::vector<TriIndices>{{0, 1, 2}, {0, 2, 3}, {0, 3, 4}}));
  // A binary file whose header starts with "solid".
  std::string bin = "solid but binary";
  bin.resize(80, ' ');
  const std::uint32_t n = 1;
  bin.append(reinterpret_cast<const char*>(&n), 4);
  const float f[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
  bin.append(reinterpret_cast<const char*>(f), 48);
  bin.append(2, '\0');
  auto b = parse_stl(bin, "t.stl");
  ASSERT_OK(b);
  EXPECT_EQ(b->format, "stl binary");
  EXPECT_EQ(b->surface.triangles.size(), 1u);
  EXPECT_EQ(b->surface.positions[2], Vec3(0, 1, 0));
}

TEST(StlRead, Malformed) {
  expect_surface_error(parse_stl("", "t.stl"), "neither ASCII STL", -1, 0);
  expect_surface_error(parse_stl("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\n", "t.stl"),
                       "vertex coordinate", 6);
  expect_surface_error(parse_stl("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 inf\n", "t.stl"), "finite number",
                       4);
  expect_surface_error(
      parse_stl("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n",
                "t.stl"),
      "at least 3 vertices", 7);
  expect_surface_error(parse_stl("solid x\nfacet normal 0 0 1\nouter hoop\n", "t.stl"), "expected 'loop'", 3);
  expect_surface_error(parse_stl("solid x\n", "t.stl"), "file ends inside a solid", 2);
  std::string bin(80, 'x');
  const std::uint32_t n = 4000000000u;
  bin.append(reinterpret_cast<const char*>(&n), 4);
  bin.append(50, '\0');
  expect_surface_error(parse_stl(bin, "t.stl"), "only 50 remain", -1, 84);
  std::string nan_bin(80, 'x');
  const std::uint32_t one = 1;
  nan_bin.append(reinterpret_cast<const char*>(&one), 4);
  float f[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
  f[7] = std::numeric_limits<float>::quiet_NaN();
  nan_bin.append(reinterpret_cast<const char*>(f), 48);
  nan_bin.append(2, '\0');
  expect_surface_error(parse_stl(nan_bin, "t.stl"), "finite number", -1, 84 + 28);
}

TEST(SurfaceWrite, RoundTripsAreExact) {
  const TriSurface s = box_surface();
  SurfaceWriteOptions with_ids;
  for (std::size_t i = 0; i < s.positions.size(); ++i) with_ids.vertex_ids.push_back(static_cast<FileId>(100 + 3 * i));
  for (bool binary : {false, true}) {
    SurfaceWriteOptions o = with_ids;
    o.binary = binary;
    std::ostringstream ply;
    ASSERT_OK(write_ply(ply, s, o));
    auto r = parse_ply(ply.str(), "t.ply");
    ASSERT_OK(r);
    expect_same(r->surface, s);
    EXPECT_EQ(r->vertex_ids, with_ids.vertex_ids);
    std::ostringstream again;
    SurfaceWriteOptions o2{.binary = binary, .vertex_ids = r->vertex_ids};
    ASSERT_OK(write_ply(again, r->surface, o2));
    EXPECT_EQ(ply.str(), again.str());
  }
  std::ostringstream obj;
  ASSERT_OK(write_obj(obj, s, with_ids));
  auto o = parse_obj(obj.str(), "t.obj");
  ASSERT_OK(o);
  expect_same(o->surface, s);
  std::ostringstream stl;
  ASSERT_OK(write_stl(stl, s));
  auto a = parse_stl(stl.str(), "t.stl");
  ASSERT_OK(a);
  expect_same_geometry(a->surface, s);
}

TEST(SurfaceWrite, BinaryStlKeepsFloatPrecision) {
  TriSurface s = box_surface();
  // Round to float. (volatile: GCC 12's SLP vectorizer at -O2 drops a double->float->double
  // round trip in loops over Eigen vectors.)
  for (Vec3& p : s.positions)
    for (int k = 0; k < 3; ++k) {
      const volatile float f = static_cast<float>(p[k]);
      p[k] = f;
    }
  std::ostringstream stl;
  ASSERT_OK(write_stl(stl, s, {.binary = true}));
  EXPECT_EQ(stl.str().size(), 84 + 50 * s.triangles.size());
  EXPECT_NE(stl.str().substr(0, 5), "solid");
  auto r = parse_stl(stl.str(), "t.stl");
  ASSERT_OK(r);
  EXPECT_EQ(r->surface.triangles.size(), s.triangles.size());
  expect_same_geometry(r->surface, s);
}

TEST(PlyWrite, FaceValuesAsFaceProperties) {
  const TriSurface s = box_surface();
  std::vector<std::int32_t> body(s.triangles.size()), crack(s.triangles.size());
  for (std::size_t t = 0; t < body.size(); ++t) {
    body[t] = static_cast<std::int32_t>(t / 4);
    crack[t] = static_cast<std::int32_t>(t % 2);
  }
  for (const bool binary : {false, true}) {
    std::ostringstream out;
    ASSERT_OK(write_ply(out, s, {.binary = binary, .face_values = {{"body", body}, {"crack", crack}}}));
    const std::string text = out.str();
    EXPECT_NE(text.find("property list uchar int vertex_indices\nproperty int body\nproperty int crack\nend_header"),
              std::string::npos);
    if (!binary) {
      EXPECT_NE(text.find("\n3 0 "), std::string::npos);
    }
    auto r = parse_ply(text, "t.ply");  // the reader skips the extra properties
    ASSERT_OK(r);
    expect_same_geometry(r->surface, s);
  }
  std::ostringstream out;
  EXPECT_FALSE(write_ply(out, s, {.face_values = {{"body", {1, 2}}}}).ok());  // one value per triangle
  EXPECT_FALSE(write_ply(out, s, {.face_values = {{"a b", body}}}).ok());     // a name without spaces
}

TEST(SurfaceWrite, FilesByExtensionAndBadInput) {
  test::TempDir dir;
  const TriSurface s = box_surface();
  for (const char* name : {"a.obj", "a.PLY", "a.stl"}) {
    ASSERT_OK(write_surface(dir.file(name), s));
    auto r = read_surface(dir.file(name));
    ASSERT_OK(r);
    expect_same_geometry(r->surface, s);
  }
  EXPECT_EQ(surface_format_from_path("x.Stl"), SurfaceFormat::stl);
  EXPECT_EQ(surface_format_from_path("x.off"), SurfaceFormat::unknown);
  EXPECT_FALSE(write_surface(dir.file("a.off"), s).ok());
  EXPECT_FALSE(read_surface(dir.file("missing.obj")).ok());
  TriSurface bad = s;
  bad.triangles[0][1] = 100000;
  EXPECT_FALSE(write_surface(dir.file("bad.stl"), bad).ok());
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad.stl")));
  SurfaceWriteOptions wrong_ids;
  wrong_ids.vertex_ids = {1, 2};
  std::ostringstream out;
  EXPECT_FALSE(write_ply(out, s, wrong_ids).ok());
}

}  // namespace
}  // namespace shatter
