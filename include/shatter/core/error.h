// Errors for bad input (files, parameters) and a Result<T> that carries either a value or an Error.
// Library functions never abort or throw on bad input; they return an Error that names the file,
// the line / byte offset / field, and what was expected. (Debian 12 packages no tl::expected and
// GCC 12 has no std::expected, so this is a small one of our own with the same spirit.)
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <variant>

#include "shatter/core/assert.h"

namespace shatter {

/// A user-facing error: where it happened and what was expected.
struct Error {
  std::string message;       ///< what is wrong / what was expected
  std::string file;          ///< file the error is in ("" if none)
  std::int64_t line = -1;    ///< 1-based line number (text formats), -1 if not known
  std::int64_t offset = -1;  ///< 0-based byte offset (binary formats), -1 if not known
  std::string field;         ///< JSON path or parameter name ("loads[2].force"), "" if none

  /// "file:line: field: message" with the parts that are known.
  [[nodiscard]] std::string to_string() const;
};

/// Builders for the common cases.
Error make_error(std::string message);                                           ///< message only
Error file_error(std::string file, std::string message);                         ///< with the file
Error line_error(std::string file, std::int64_t line, std::string message);      ///< with file and 1-based line
Error offset_error(std::string file, std::int64_t offset, std::string message);  ///< with file and byte offset
Error field_error(std::string field, std::string message);                       ///< with the field (JSON path)

/// A number for a message in printf's %g with `digits` significant digits, so 0.02 reads "0.02",
/// not the "0.020000" of std::to_string.
[[nodiscard]] std::string format_number(double v, int digits = 6);

/// Either a T or an Error. Check with ok() / operator bool before value().
template <class T>
class [[nodiscard]] Result {
 public:
  /// A success holding `value` (implicit, so a function can return a T).
  Result(T value) : v_(std::in_place_index<0>, std::move(value)) {}  // NOLINT(implicit)
  /// A failure holding `error` (implicit, so a function can return an Error).
  Result(Error error) : v_(std::in_place_index<1>, std::move(error)) {}  // NOLINT(implicit)

  /// True when it holds a value.
  [[nodiscard]] bool ok() const { return v_.index() == 0; }
  /// Same as ok().
  explicit operator bool() const { return ok(); }

  /// The value; only when ok().
  T& value() & {
    SHATTER_ASSERT(ok());
    return std::get<0>(v_);
  }
  const T& value() const& {
    SHATTER_ASSERT(ok());
    return std::get<0>(v_);
  }
  T&& value() && {
    SHATTER_ASSERT(ok());
    return std::get<0>(std::move(v_));
  }
  /// Member access to the value; only when ok().
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  /// The value; only when ok().
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  /// The error; only when !ok().
  [[nodiscard]] const Error& error() const {
    SHATTER_ASSERT(!ok());
    return std::get<1>(v_);
  }
  Error& error() {
    SHATTER_ASSERT(!ok());
    return std::get<1>(v_);
  }

 private:
  std::variant<T, Error> v_;
};

/// Result of an operation with no value.
template <>
class [[nodiscard]] Result<void> {
 public:
  /// Success.
  Result() = default;
  /// A failure holding `error` (implicit, so a function can return an Error).
  Result(Error error) : error_(std::move(error)) {}  // NOLINT(implicit)
  /// True on success.
  [[nodiscard]] bool ok() const { return !error_.has_value(); }
  /// Same as ok().
  explicit operator bool() const { return ok(); }
  /// The error; only when !ok().
  [[nodiscard]] const Error& error() const {
    SHATTER_ASSERT(!ok());
    return *error_;
  }
  Error& error() {
    SHATTER_ASSERT(!ok());
    return *error_;
  }

 private:
  std::optional<Error> error_;
};

/// Propagate an error: `SHATTER_TRY(r, expr);` declares r, returns its error if it failed.
/// (var names a new variable, so it cannot be parenthesised.)
// NOLINTBEGIN(bugprone-macro-parentheses)
#define SHATTER_TRY(var, expr) \
  auto var = (expr);           \
  if (!var.ok()) return std::move(var.error())
// NOLINTEND(bugprone-macro-parentheses)

}  // namespace shatter
