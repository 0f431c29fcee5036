// Whole-file reads and atomic writes: every output is written to a temporary beside the target
// and renamed over it, so a failure never leaves half a file and never destroys the old one.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>

#include "shatter/core/error.h"

namespace shatter {

/// Read a whole file into memory. Errors name the file. Files larger than max_bytes are refused,
/// and so is anything but a regular file (a directory, named pipe or device), without opening it.
Result<std::string> read_file(const std::string& path, std::uint64_t max_bytes = (1ULL << 34));

/// Write `path` atomically: `write` fills a stream opened on a temporary in the same folder; if it
/// returns an Error, throws, or the stream fails, the temporary is removed and `path` is untouched.
Result<void> write_file_atomic(const std::string& path, const std::function<Result<void>(std::ostream&)>& write);
/// Convenience: write bytes atomically.
Result<void> write_file_atomic(const std::string& path, std::string_view content);

/// Lower-case extension with the dot (".msh"); for "a.vtu.gz" returns ".gz".
std::string file_extension(const std::string& path);

}  // namespace shatter
