// Binary scalar types shared by the VTK, VTU and PLY code (see scalar_type.h).
#include "shatter/mesh/io/scalar_type.h"

#include <array>
#include <iterator>
#include <limits>
#include <span>

#include "shatter/mesh/io/io_util.h"

namespace shatter::io {
namespace {

// One row per type: bytes per value, floating or not, and every spelling each format accepts
// ("" pads a shorter list). Legacy VTK: the DATA type names of the file format document plus the
// fixed-width vtktype* names VTK 9 writes (5.1 files), compared ignoring case. VTU: the DataArray
// types, "Char" / "UChar" being older spellings of Int8 / UInt8. PLY: the original property type
// names and the sized ones (both in common use); int64 / uint64 are an extension some writers use.
struct TypeRow {
  ScalarType type;
  std::uint8_t size;  // bytes; 0 for bit
  bool floating;
  std::array<std::string_view, 3> vtk;
  std::array<std::string_view, 2> vtu;
  std::array<std::string_view, 2> ply;
};

constexpr TypeRow kTypes[] = {
    // type         size  float  legacy VTK                                   VTU                  PLY
    {ScalarType::bit, 0, false, {"bit"}, {}, {}},
    {ScalarType::i8, 1, false, {"char", "vtktypeint8"}, {"Int8", "Char"}, {"char", "int8"}},
    {ScalarType::u8, 1, false, {"unsigned_char", "vtktypeuint8"}, {"UInt8", "UChar"}, {"uchar", "uint8"}},
    {ScalarType::i16, 2, false, {"short", "vtktypeint16"}, {"Int16"}, {"short", "int16"}},
    {ScalarType::u16, 2, false, {"unsigned_short", "vtktypeuint16"}, {"UInt16"}, {"ushort", "uint16"}},
    {ScalarType::i32, 4, false, {"int", "vtktypeint32"}, {"Int32"}, {"int", "int32"}},
    {ScalarType::u32, 4, false, {"unsigned_int", "vtktypeuint32"}, {"UInt32"}, {"uint", "uint32"}},
    {ScalarType::i64, 8, false, {"long", "vtktypeint64", "vtkidtype"}, {"Int64"}, {"int64"}},
    {ScalarType::u64, 8, false, {"unsigned_long", "vtktypeuint64"}, {"UInt64"}, {"uint64"}},
    {ScalarType::f32, 4, true, {"float", "vtktypefloat32"}, {"Float32"}, {"float", "float32"}},
    {ScalarType::f64, 8, true, {"double", "vtktypefloat64"}, {"Float64"}, {"double", "float64"}},
};

// Rows are in enum order, so a type's row is kTypes[type].
constexpr bool rows_in_enum_order() {
  for (std::size_t i = 0; i < std::size(kTypes); ++i)
    if (static_cast<std::size_t>(kTypes[i].type) != i) return false;
  return true;
}
static_assert(rows_in_enum_order());

const TypeRow& row(ScalarType t) { return kTypes[static_cast<std::size_t>(t)]; }

std::span<const std::string_view> spellings(const TypeRow& r, ScalarNames format) {
  switch (format) {
    case ScalarNames::vtk: return r.vtk;
    case ScalarNames::vtu: return r.vtu;
    case ScalarNames::ply: return r.ply;
  }
  return {};
}

}  // namespace

std::optional<ScalarType> scalar_type_from_name(ScalarNames format, std::string_view name) {
  const bool any_case = format == ScalarNames::vtk;
  for (const TypeRow& r : kTypes)
    for (std::string_view n : spellings(r, format))
      if (!n.empty() && (any_case ? iequals(name, n) : name == n)) return r.type;
  return std::nullopt;
}

std::size_t scalar_size(ScalarType t) { return row(t).size; }

bool is_float(ScalarType t) { return row(t).floating; }

Result<Scalar> read_scalar(ByteCursor& b, ScalarType t, const char* what) {
  Scalar v;
  switch (t) {
    case ScalarType::i8: {
      SHATTER_TRY(x, b.u8(what));
      v.i = static_cast<std::int8_t>(*x);  // NOLINT(bugprone-signed-char-misuse): the byte is a signed int8
      break;
    }
    case ScalarType::u8: {
      SHATTER_TRY(x, b.u8(what));
      v.i = *x;
      break;
    }
    case ScalarType::i16: {
      SHATTER_TRY(x, b.u16(what));
      v.i = static_cast<std::int16_t>(*x);
      break;
    }
    case ScalarType::u16: {
      SHATTER_TRY(x, b.u16(what));
      v.i = *x;
      break;
    }
    case ScalarType::i32: {
      SHATTER_TRY(x, b.i32(what));
      v.i = *x;
      break;
    }
    case ScalarType::u32: {
      SHATTER_TRY(x, b.u32(what));
      v.i = *x;
      break;
    }
    case ScalarType::i64: {
      SHATTER_TRY(x, b.i64(what));
      v.i = *x;
      break;
    }
    case ScalarType::u64: {
      SHATTER_TRY(x, b.u64(what));
      if (*x > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
        return b.error(std::string(what) + " " + std::to_string(*x) + " is too large");
      v.i = static_cast<std::int64_t>(*x);
      break;
    }
    case ScalarType::f32: {
      SHATTER_TRY(x, b.f32(what));
      v.is_int = false;
      v.d = *x;
      break;
    }
    case ScalarType::f64: {
      SHATTER_TRY(x, b.f64(what));
      v.is_int = false;
      v.d = *x;
      break;
    }
    case ScalarType::bit: return b.error(std::string(what) + ": bit arrays are not read one value at a time");
  }
  return v;
}

Result<void> read_scalars(ByteCursor& b, ScalarType t, std::uint64_t count, const char* what, ScalarArray& out) {
  for (std::uint64_t k = 0; k < count; ++k) {
    SHATTER_TRY(v, read_scalar(b, t, what));
    if (v->is_int)
      out.ints.push_back(v->i);
    else
      out.reals.push_back(v->d);
  }
  return {};
}

}  // namespace shatter::io
