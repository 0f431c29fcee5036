// The binary scalar-type table shared by the VTK, VTU and PLY code: every spelling each format
// accepts maps to its type (VTK ignoring case, VTU and PLY exactly), sizes, and one value read in
// either byte order.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <utility>

#include "shatter/mesh/io/scalar_type.h"
#include "support/test_support.h"

namespace shatter::io {
namespace {

using enum ScalarType;

void expect_names(ScalarNames format, std::initializer_list<std::pair<const char*, ScalarType>> names) {
  for (const auto& [name, type] : names) {
    const auto t = scalar_type_from_name(format, name);
    ASSERT_TRUE(t.has_value()) << name;
    EXPECT_EQ(*t, type) << name;
  }
}

TEST(ScalarType, EveryFormatKeepsItsSpellings) {
  expect_names(ScalarNames::vtk, {{"bit", bit},
                                  {"unsigned_char", u8},
                                  {"char", i8},
                                  {"unsigned_short", u16},
                                  {"short", i16},
                                  {"unsigned_int", u32},
                                  {"int", i32},
                                  {"unsigned_long", u64},
                                  {"long", i64},
                                  {"float", f32},
                                  {"double", f64},
                                  {"vtktypeint8", i8},
                                  {"vtktypeuint8", u8},
                                  {"vtktypeint16", i16},
                                  {"vtktypeuint16", u16},
                                  {"vtktypeint32", i32},
                                  {"vtktypeuint32", u32},
                                  {"vtktypeint64", i64},
                                  {"vtktypeuint64", u64},
                                  {"vtkIdType", i64},
                                  {"vtktypefloat32", f32},
                                  {"vtktypefloat64", f64},
                                  {"FLOAT", f32}});
  expect_names(ScalarNames::vtu, {{"Int8", i8},
                                  {"UInt8", u8},
                                  {"Int16", i16},
                                  {"UInt16", u16},
                                  {"Int32", i32},
                                  {"UInt32", u32},
                                  {"Int64", i64},
                                  {"UInt64", u64},
                                  {"Float32", f32},
                                  {"Float64", f64},
                                  {"Char", i8},
                                  {"UChar", u8}});
  expect_names(ScalarNames::ply, {{"char", i8},
                                  {"int8", i8},
                                  {"uchar", u8},
                                  {"uint8", u8},
                                  {"short", i16},
                                  {"int16", i16},
                                  {"ushort", u16},
                                  {"uint16", u16},
                                  {"int", i32},
                                  {"int32", i32},
                                  {"uint", u32},
                                  {"uint32", u32},
                                  {"int64", i64},
                                  {"uint64", u64},
                                  {"float", f32},
                                  {"float32", f32},
                                  {"double", f64},
                                  {"float64", f64}});
  // Names of one format are not names of another; VTU and PLY compare case.
  EXPECT_FALSE(scalar_type_from_name(ScalarNames::vtu, "float"));
  EXPECT_FALSE(scalar_type_from_name(ScalarNames::vtu, "float64"));
  EXPECT_FALSE(scalar_type_from_name(ScalarNames::ply, "Float32"));
  EXPECT_FALSE(scalar_type_from_name(ScalarNames::ply, "bit"));
  EXPECT_FALSE(scalar_type_from_name(ScalarNames::vtk, "Float64"));
  EXPECT_FALSE(scalar_type_from_name(ScalarNames::vtk, ""));
  EXPECT_FALSE(scalar_type_from_name(ScalarNames::vtu, ""));
}

TEST(ScalarType, SizesAndKinds) {
  EXPECT_EQ(scalar_size(bit), 0u);
  EXPECT_EQ(scalar_size(u8), 1u);
  EXPECT_EQ(scalar_size(i16), 2u);
  EXPECT_EQ(scalar_size(f32), 4u);
  EXPECT_EQ(scalar_size(u64), 8u);
  EXPECT_TRUE(is_float(f64));
  EXPECT_FALSE(is_float(i64));
}

TEST(ScalarType, ReadsEitherByteOrder) {
  for (bool big : {false, true}) {
    std::string bytes;
    append_binary<std::int16_t>(bytes, -2, big);
    append_binary<float>(bytes, 1.5f, big);
    append_binary<std::uint64_t>(bytes, 1ull << 63, big);
    ByteCursor b(bytes, "t.bin", 0, big);
    auto a = read_scalar(b, i16, "value");
    ASSERT_OK(a);
    EXPECT_TRUE(a->is_int);
    EXPECT_EQ(a->i, -2);
    auto f = read_scalar(b, f32, "value");
    ASSERT_OK(f);
    EXPECT_FALSE(f->is_int);
    EXPECT_EQ(f->as_double(), 1.5);
    // An unsigned 64-bit value above the largest int64 cannot be kept exact.
    auto u = read_scalar(b, u64, "node id");
    ASSERT_FALSE(u.ok());
    EXPECT_NE(u.error().message.find("node id 9223372036854775808 is too large"), std::string::npos)
        << u.error().to_string();
  }
  std::string bytes;
  for (std::uint8_t v : {1, 200, 3}) append_binary(bytes, v, false);
  ByteCursor b(bytes, "t.bin");
  ScalarArray a;
  ASSERT_OK(read_scalars(b, u8, 3, "value", a));
  EXPECT_EQ(a.ints, (std::vector<std::int64_t>{1, 200, 3}));
}

}  // namespace
}  // namespace shatter::io
