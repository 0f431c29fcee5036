// Binary scalar types of the mesh and surface formats (legacy VTK, VTU, PLY): one table of the
// types with their sizes, how one value is read (integers exact, floating types as double) and
// byte order, and each format's own spellings of the type names mapped onto it.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/mesh/io/text_cursor.h"

namespace shatter::io {

/// A scalar type of binary data. `bit` is legacy VTK's packed bit array (8 values a byte, most
/// significant bit first): it has no per-value byte size and is read by the VTK reader itself.
enum class ScalarType : std::uint8_t { bit, i8, u8, i16, u16, i32, u32, i64, u64, f32, f64 };

/// Whose spellings a type name is looked up in.
enum class ScalarNames : std::uint8_t {
  vtk,  ///< legacy VTK: "float", "double", "int", "unsigned_char", "vtktypeint64", "vtkidtype", ... (any case)
  vtu,  ///< VTK XML: "Float32", "Float64", "Int8" ... "UInt64", "Char", "UChar" (exact case)
  ply,  ///< PLY: "char"/"int8", "uchar"/"uint8", ..., "float"/"float32", "double"/"float64" (exact case)
};

/// The type a format spells as `name`, or nullopt when the format has no such name.
std::optional<ScalarType> scalar_type_from_name(ScalarNames format, std::string_view name);

/// Bytes of one value: 1, 2, 4 or 8; 0 for bit.
std::size_t scalar_size(ScalarType t);
/// f32 or f64.
bool is_float(ScalarType t);

/// One value read from a file: integer types keep their exact value, floating types are doubles.
struct Scalar {
  bool is_int = true;
  std::int64_t i = 0;  ///< the value when is_int
  double d = 0;        ///< the value when !is_int
  [[nodiscard]] double as_double() const { return is_int ? static_cast<double>(i) : d; }
};

/// The values of one array: integers kept exact in `ints`, floating types in `reals`.
struct ScalarArray {
  bool integral = true;  ///< which of ints / reals holds the values
  std::vector<std::int64_t> ints;
  std::vector<double> reals;
  [[nodiscard]] std::size_t size() const { return integral ? ints.size() : reals.size(); }
  /// Room for n values in the vector that `integral` selects.
  void reserve(std::size_t n) {
    if (integral)
      ints.reserve(n);
    else
      reals.reserve(n);
  }
};

/// Read one value of type `t` (not bit) at the cursor, in its byte order. A u64 above the
/// largest int64 fails ("<what> N is too large"); `what` names the value in messages.
Result<Scalar> read_scalar(ByteCursor& b, ScalarType t, const char* what);
/// Append `count` values of type `t` (not bit) to `out`: to ints for an integer type, to reals
/// for a floating one (out.integral should say the same: !is_float(t)).
Result<void> read_scalars(ByteCursor& b, ScalarType t, std::uint64_t count, const char* what, ScalarArray& out);

/// Put `n` bytes read or written in little- (big_endian false) or big-endian order into the
/// machine's order, or back: the same swap both ways.
inline void swap_to_native(unsigned char* bytes, std::size_t n, bool big_endian) {
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(bytes, bytes + n);
}

/// Append the bytes of a trivially copyable value in the given byte order.
template <class T>
void append_binary(std::string& out, T v, bool big_endian) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  swap_to_native(b, sizeof(T), big_endian);
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

}  // namespace shatter::io
