// Tokenizer for the text mesh formats: tracks the line number for error messages, skips a UTF-8
// BOM, treats CR LF like LF, and parses numbers with std::from_chars (locale-independent, no
// allocation). All checks return Errors naming the file and line; nothing here can read past the end.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "shatter/core/error.h"

namespace shatter::io {

class TextCursor {
 public:
  TextCursor(std::string_view bytes, std::string name);

  [[nodiscard]] bool at_end() const { return pos_ >= data_.size(); }
  [[nodiscard]] std::int64_t line() const { return line_; }
  [[nodiscard]] std::size_t position() const { return pos_; }
  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] std::string_view rest() const { return data_.substr(pos_); }
  [[nodiscard]] std::size_t remaining() const { return data_.size() - pos_; }

  /// Skip spaces, tabs and CRs on this line (not newlines).
  void skip_blanks();
  /// Skip all whitespace including newlines. If comment_char != 0, also skip from it to end of line.
  void skip_space(char comment_char = 0);
  /// The next whitespace-delimited token (may cross lines; comments skipped); empty at end.
  std::string_view next_token(char comment_char = 0);
  /// Peek at the next token without consuming it.
  std::string_view peek_token(char comment_char = 0);
  /// The rest of the current line (without CR/LF), and move past the newline.
  std::string_view next_line();
  /// True if only blanks remain on the current line.
  bool at_line_end();
  /// Move to the start of the next line.
  void skip_line();
  /// Advance the position by n bytes (binary payload inside a text file), counting newlines.
  Result<std::string_view> take_bytes(std::size_t n, const char* what);

  // Typed reads: consume one token and check it; `what` says what was expected ("node count").
  Result<std::int64_t> next_int(const char* what, char comment_char = 0);
  Result<double> next_double(const char* what, char comment_char = 0);
  /// Integer in [lo, hi].
  Result<std::int64_t> next_int_in(const char* what, std::int64_t lo, std::int64_t hi, char comment_char = 0);
  /// Consume the token and check it equals `keyword` (case-sensitive unless ignore_case).
  Result<void> expect(std::string_view keyword, bool ignore_case = false, char comment_char = 0);

  /// An Error at the current line.
  [[nodiscard]] Error error(const std::string& message) const;
  [[nodiscard]] Error error_at(std::int64_t line, const std::string& message) const;

 private:
  std::string_view data_;
  std::string name_;
  std::size_t pos_ = 0;
  std::int64_t line_ = 1;
};

/// Parse a whole token as a number (false if it is not exactly one). Doubles accept what
/// from_chars accepts plus a leading '+'; "nan"/"inf" are rejected.
bool parse_int(std::string_view token, std::int64_t& out);
bool parse_double(std::string_view token, double& out);
/// Lower-case ASCII copy.
std::string to_lower(std::string_view s);
/// Shorten a token for messages ("abc..." at 40 chars, non-printables escaped).
std::string quote_token(std::string_view token);

/// Bounds-checked little/big-endian reads from a byte buffer, errors by byte offset.
class ByteCursor {
 public:
  ByteCursor(std::string_view bytes, std::string name, std::size_t start = 0, bool big_endian = false)
      : data_(bytes), name_(std::move(name)), pos_(start), big_endian_(big_endian) {}
  [[nodiscard]] std::size_t position() const { return pos_; }
  [[nodiscard]] std::size_t remaining() const { return data_.size() - pos_; }
  void set_big_endian(bool big) { big_endian_ = big; }
  /// Error unless `count` items of `size` bytes remain (overflow-safe).
  Result<void> require(std::uint64_t count, std::uint64_t size, const char* what) const;
  Result<std::string_view> take(std::size_t n, const char* what);
  Result<double> f64(const char* what);
  Result<float> f32(const char* what);
  Result<std::int32_t> i32(const char* what);
  Result<std::uint32_t> u32(const char* what);
  Result<std::int64_t> i64(const char* what);
  Result<std::uint64_t> u64(const char* what);
  Result<std::uint8_t> u8(const char* what);
  Result<std::uint16_t> u16(const char* what);
  [[nodiscard]] Error error(const std::string& message) const;

 private:
  template <class T>
  Result<T> read(const char* what);
  std::string_view data_;
  std::string name_;
  std::size_t pos_;
  bool big_endian_;
};

}  // namespace shatter::io
