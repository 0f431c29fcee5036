// Base64 (RFC 4648) for the inline binary arrays of VTK XML files.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace shatter::io {

/// Append the base64 text of `bytes` to `out` (with '=' padding, no line breaks).
void base64_encode(std::string_view bytes, std::string& out);

/// Decode `text` into `out`, skipping whitespace. '=' padding may close a group anywhere, so
/// separately encoded blocks written back to back decode as one stream. Returns false at the first
/// character that is not base64 and sets `bad_pos` to its position in `text`.
bool base64_decode(std::string_view text, std::string& out, std::size_t& bad_pos);

}  // namespace shatter::io
