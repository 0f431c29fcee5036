// Base64 encoding and a whitespace- and padding-tolerant decoder.
#include "shatter/mesh/io/base64.h"

#include <array>
#include <cstdint>

namespace shatter::io {
namespace {

constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

constexpr std::array<std::int8_t, 256> make_table() {
  std::array<std::int8_t, 256> t{};
  for (auto& v : t) v = -1;
  for (int i = 0; i < 64; ++i) t[static_cast<unsigned char>(kAlphabet[i])] = static_cast<std::int8_t>(i);
  return t;
}
constexpr std::array<std::int8_t, 256> kTable = make_table();

}  // namespace

void base64_encode(std::string_view bytes, std::string& out) {
  // Sized once and written through a pointer: a character at a time through the string cost a
  // capacity check each, and was the largest part of writing a frame.
  const std::size_t start = out.size();
  out.resize(start + (bytes.size() + 2) / 3 * 4);
  char* o = out.data() + start;
  std::size_t i = 0;
  auto byte = [&](std::size_t k) { return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[k])); };
  for (; i + 3 <= bytes.size(); i += 3) {
    const std::uint32_t v = byte(i) << 16 | byte(i + 1) << 8 | byte(i + 2);
    o[0] = kAlphabet[v >> 18];
    o[1] = kAlphabet[(v >> 12) & 63];
    o[2] = kAlphabet[(v >> 6) & 63];
    o[3] = kAlphabet[v & 63];
    o += 4;
  }
  const std::size_t rest = bytes.size() - i;
  if (rest == 1) {
    const std::uint32_t v = byte(i) << 16;
    o[0] = kAlphabet[v >> 18];
    o[1] = kAlphabet[(v >> 12) & 63];
    o[2] = '=';
    o[3] = '=';
  } else if (rest == 2) {
    const std::uint32_t v = byte(i) << 16 | byte(i + 1) << 8;
    o[0] = kAlphabet[v >> 18];
    o[1] = kAlphabet[(v >> 12) & 63];
    o[2] = kAlphabet[(v >> 6) & 63];
    o[3] = '=';
  }
}

bool base64_decode(std::string_view text, std::string& out, std::size_t& bad_pos) {
  out.reserve(out.size() + text.size() / 4 * 3);
  std::uint32_t acc = 0;
  int n = 0;  // sextets in acc
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == ' ' || c == '\n' || c == '\r' || c == '\t') continue;
    if (c == '=') {
      // Close the current group: 2 sextets -> 1 byte, 3 -> 2 bytes.
      if (n == 2)
        out += static_cast<char>(acc >> 4);
      else if (n == 3) {
        out += static_cast<char>(acc >> 10);
        out += static_cast<char>((acc >> 2) & 0xFF);
      } else if (n != 0) {
        bad_pos = i;
        return false;
      }
      acc = 0;
      n = 0;
      continue;
    }
    const int v = kTable[static_cast<unsigned char>(c)];  // NOLINT(bugprone-signed-char-misuse): -1 or 0..63
    if (v < 0) {
      bad_pos = i;
      return false;
    }
    acc = acc << 6 | static_cast<std::uint32_t>(v);
    if (++n == 4) {
      out += static_cast<char>(acc >> 16);
      out += static_cast<char>((acc >> 8) & 0xFF);
      out += static_cast<char>(acc & 0xFF);
      acc = 0;
      n = 0;
    }
  }
  // Unpadded tail.
  if (n == 2)
    out += static_cast<char>(acc >> 4);
  else if (n == 3) {
    out += static_cast<char>(acc >> 10);
    out += static_cast<char>((acc >> 2) & 0xFF);
  } else if (n == 1) {
    bad_pos = text.size();
    return false;
  }
  return true;
}

}  // namespace shatter::io
