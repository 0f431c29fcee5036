// Strict reading of JSON input files, shared by shape files (meshing) and case files (scene);
// internal, never installed (it exposes nlohmann_json, a private dependency). Every value is
// checked for its type and range, every unknown key is an error naming the nearest known key, and
// every error carries the file name and the JSON path of the field ("loads[2].force").
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"

namespace shatter::json_input {

using Json = nlohmann::json;

/// Where a value sits: the file and the JSON path to it.
struct Where {
  const std::string* file = nullptr;  ///< file name for messages (never null in practice)
  std::string path;                   ///< "loads[2].force"; "" for the document root

  [[nodiscard]] Where key(std::string_view k) const;
  [[nodiscard]] Where index(std::size_t i) const;
  /// An Error naming the file and this path ("(top level)" for the root).
  [[nodiscard]] Error error(std::string message) const;
};

/// Deepest nesting of objects and arrays parse_json accepts (a shape tree of 128 levels).
inline constexpr int kMaxJsonDepth = 256;
/// Parse JSON text. Syntax errors name the line (Error::line) and what was wrong; nesting deeper
/// than kMaxJsonDepth is refused before parsing (the readers recurse over the tree).
Result<Json> parse_json(std::string_view text, const std::string& file);

/// A short description of a JSON value's type for messages ("a string", "an array", ...).
std::string type_name(const Json& value);

/// Reads the keys of one JSON object. Each get() marks a key as known; finish() fails on any key
/// that was never asked for, suggesting the nearest known one.
class ObjectReader {
 public:
  /// Fails (via status()) when `value` is not an object.
  ObjectReader(const Json& value, Where where);
  [[nodiscard]] const Result<void>& status() const { return status_; }
  [[nodiscard]] const Where& where() const { return where_; }

  /// The value at `key`, or nullptr when absent. Marks `key` as known.
  const Json* get(std::string_view key);
  /// Mark keys as known without reading them (e.g. alternatives handled elsewhere).
  void allow(std::initializer_list<std::string_view> keys);
  [[nodiscard]] bool has(std::string_view key) const;
  /// Error for the first key not asked for ("did you mean ...?").
  Result<void> finish() const;

 private:
  const Json* object_;
  Where where_;
  std::vector<std::string> known_;
  Result<void> status_;
};

/// Edit distance between two short strings (for "did you mean").
std::size_t edit_distance(std::string_view a, std::string_view b);
/// The candidate nearest to `word` if it is close enough to be a likely typo, else "".
std::string nearest(std::string_view word, const std::vector<std::string>& candidates);

// Typed readers: each fails with "expected ..., got ..." at `where`.
/// A finite number.
Result<double> read_number(const Json& value, const Where& where);
/// A finite number > 0 (strictly).
Result<double> read_positive(const Json& value, const Where& where);
/// A finite number >= 0.
Result<double> read_non_negative(const Json& value, const Where& where);
Result<std::int64_t> read_integer(const Json& value, const Where& where);
Result<bool> read_bool(const Json& value, const Where& where);
/// A string without NUL characters (they would cut names short in messages and file names).
Result<std::string> read_string(const Json& value, const Where& where);
/// [x, y] of finite numbers.
Result<Vec2> read_vec2(const Json& value, const Where& where);
/// [x, y, z] of finite numbers.
Result<Vec3> read_vec3(const Json& value, const Where& where);
/// [x, y, z] of finite numbers, each > 0 (sizes, radii); a bad component is named by its index.
Result<Vec3> read_positive_vec3(const Json& value, const Where& where);
/// An array (possibly empty).
Result<const Json*> read_array(const Json& value, const Where& where);

}  // namespace shatter::json_input
