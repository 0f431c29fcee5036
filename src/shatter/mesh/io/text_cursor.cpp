#include "shatter/mesh/io/text_cursor.h"

#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

#include "shatter/mesh/io/scalar_type.h"

namespace shatter::io {

TextCursor::TextCursor(std::string_view bytes, std::string name) : data_(bytes), name_(std::move(name)) {
  if (data_.size() >= 3 && static_cast<unsigned char>(data_[0]) == 0xEF &&
      static_cast<unsigned char>(data_[1]) == 0xBB && static_cast<unsigned char>(data_[2]) == 0xBF)
    pos_ = 3;
}

void TextCursor::skip_blanks() {
  while (pos_ < data_.size() && (data_[pos_] == ' ' || data_[pos_] == '\t' || data_[pos_] == '\r')) ++pos_;
}

void TextCursor::skip_space(char comment_char) {
  while (pos_ < data_.size()) {
    const char c = data_[pos_];
    if (c == '\n') {
      ++line_;
      ++pos_;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++pos_;
    } else if (comment_char != 0 && c == comment_char) {
      while (pos_ < data_.size() && data_[pos_] != '\n') ++pos_;
    } else {
      break;
    }
  }
}

std::string_view TextCursor::next_token(char comment_char) {
  skip_space(comment_char);
  const std::size_t start = pos_;
  while (pos_ < data_.size()) {
    const char c = data_[pos_];
    if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v') break;
    if (comment_char != 0 && c == comment_char) break;
    ++pos_;
  }
  return data_.substr(start, pos_ - start);
}

std::string_view TextCursor::peek_token(char comment_char) {
  const std::size_t saved_pos = pos_;
  const std::int64_t saved_line = line_;
  const std::string_view t = next_token(comment_char);
  pos_ = saved_pos;
  line_ = saved_line;
  return t;
}

std::string_view TextCursor::next_line() {
  const std::size_t start = pos_;
  while (pos_ < data_.size() && data_[pos_] != '\n') ++pos_;
  std::size_t end = pos_;
  if (end > start && data_[end - 1] == '\r') --end;
  if (pos_ < data_.size()) {
    ++pos_;
    ++line_;
  }
  return data_.substr(start, end - start);
}

bool TextCursor::at_line_end() {
  skip_blanks();
  return pos_ >= data_.size() || data_[pos_] == '\n';
}

void TextCursor::skip_line() { (void)next_line(); }

Result<std::string_view> TextCursor::take_bytes(std::size_t n, const char* what) {
  if (n > remaining())
    return error(std::string("file ends inside ") + what + ": " + std::to_string(n) + " bytes expected, " +
                 std::to_string(remaining()) + " remain");
  const std::string_view s = data_.substr(pos_, n);
  for (char c : s)
    if (c == '\n') ++line_;
  pos_ += n;
  return s;
}

Result<std::int64_t> TextCursor::next_int(const char* what, char comment_char) {
  const std::string_view t = next_token(comment_char);
  if (t.empty()) return error(std::string("file ends where ") + what + " (an integer) was expected");
  std::int64_t v = 0;
  if (!parse_int(t, v)) return error(std::string("expected ") + what + " (an integer), found " + quote_token(t));
  return v;
}

Result<double> TextCursor::next_double(const char* what, char comment_char) {
  const std::string_view t = next_token(comment_char);
  if (t.empty()) return error(std::string("file ends where ") + what + " (a number) was expected");
  double v = 0;
  if (!parse_double(t, v))
    return error(std::string("expected ") + what + " (a finite number), found " + quote_token(t));
  return v;
}

Result<std::int64_t> TextCursor::next_int_in(const char* what, std::int64_t lo, std::int64_t hi, char comment_char) {
  SHATTER_TRY(v, next_int(what, comment_char));
  if (*v < lo || *v > hi)
    return error(std::string("expected ") + what + " in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                 "], found " + std::to_string(*v));
  return v;
}

Result<void> TextCursor::expect(std::string_view keyword, bool ignore_case, char comment_char) {
  const std::string_view t = next_token(comment_char);
  const bool same = ignore_case ? to_lower(t) == to_lower(keyword) : t == keyword;
  if (!same) {
    if (t.empty()) return error("file ends where '" + std::string(keyword) + "' was expected");
    return error("expected '" + std::string(keyword) + "', found " + quote_token(t));
  }
  return {};
}

Error TextCursor::error(const std::string& message) const { return line_error(name_, line_, message); }
Error TextCursor::error_at(std::int64_t line, const std::string& message) const {
  return line_error(name_, line, message);
}

bool parse_int(std::string_view t, std::int64_t& out) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), out);
  return ec == std::errc() && ptr == t.data() + t.size();
}

bool parse_double(std::string_view t, double& out) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  // Fortran-style exponents ("1.0D+03") appear in some Abaqus and MEDIT files.
  char buf[64];
  if (t.size() < sizeof buf && (t.find('d') != std::string_view::npos || t.find('D') != std::string_view::npos)) {
    std::memcpy(buf, t.data(), t.size());
    for (std::size_t i = 0; i < t.size(); ++i)
      if (buf[i] == 'd' || buf[i] == 'D') buf[i] = 'e';
    const auto [ptr, ec] = std::from_chars(buf, buf + t.size(), out);
    return ec == std::errc() && ptr == buf + t.size() && std::isfinite(out);
  }
  const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), out);
  return ec == std::errc() && ptr == t.data() + t.size() && std::isfinite(out);
}

std::string to_lower(std::string_view s) {
  std::string r(s);
  for (char& c : r)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return r;
}

std::string quote_token(std::string_view t) {
  std::string r = "'";
  const std::size_t n = std::min<std::size_t>(t.size(), 40);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(t[i]);
    if (c >= 32 && c < 127) {
      r += static_cast<char>(c);
    } else {
      static const char* hex = "0123456789abcdef";
      r += "\\x";
      r += hex[c >> 4];
      r += hex[c & 15];
    }
  }
  if (t.size() > n) r += "...";
  return r + "'";
}

Result<void> ByteCursor::require(std::uint64_t count, std::uint64_t size, const char* what) const {
  const std::uint64_t rem = remaining();
  if (size != 0 && count > rem / size)
    return error(std::string(what) + ": " + std::to_string(count) + " x " + std::to_string(size) +
                 " bytes expected, only " + std::to_string(rem) + " remain");
  return {};
}

Result<std::string_view> ByteCursor::take(std::size_t n, const char* what) {
  if (n > remaining())
    return error(std::string("file ends inside ") + what + ": " + std::to_string(n) + " bytes expected, " +
                 std::to_string(remaining()) + " remain");
  const std::string_view s = data_.substr(pos_, n);
  pos_ += n;
  return s;
}

template <class T>
Result<T> ByteCursor::read(const char* what) {
  if (sizeof(T) > remaining())
    return error(std::string("file ends where ") + what + " (" + std::to_string(sizeof(T)) + " bytes) was expected");
  unsigned char b[sizeof(T)];
  std::memcpy(b, data_.data() + pos_, sizeof(T));
  swap_to_native(b, sizeof(T), big_endian_);
  T v;
  std::memcpy(&v, b, sizeof(T));
  pos_ += sizeof(T);
  return v;
}

Result<double> ByteCursor::f64(const char* what) { return read<double>(what); }
Result<float> ByteCursor::f32(const char* what) { return read<float>(what); }
Result<std::int32_t> ByteCursor::i32(const char* what) { return read<std::int32_t>(what); }
Result<std::uint32_t> ByteCursor::u32(const char* what) { return read<std::uint32_t>(what); }
Result<std::int64_t> ByteCursor::i64(const char* what) { return read<std::int64_t>(what); }
Result<std::uint64_t> ByteCursor::u64(const char* what) { return read<std::uint64_t>(what); }
Result<std::uint8_t> ByteCursor::u8(const char* what) { return read<std::uint8_t>(what); }
Result<std::uint16_t> ByteCursor::u16(const char* what) { return read<std::uint16_t>(what); }

Error ByteCursor::error(const std::string& message) const {
  return offset_error(name_, static_cast<std::int64_t>(pos_), message);
}

}  // namespace shatter::io
