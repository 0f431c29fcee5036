#include "shatter/core/file_io.h"

#include <cctype>
#include <cerrno>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <system_error>

#include <unistd.h>

namespace shatter {

namespace fs = std::filesystem;

Result<std::string> read_file(const std::string& path, std::uint64_t max_bytes) {
  std::error_code ec;
  // Only regular files: opening a named pipe blocks until someone writes to it, and a device
  // (/dev/zero) never ends. Checked by status, which opens nothing.
  const fs::file_status st = fs::status(path, ec);
  if (fs::is_directory(st)) return file_error(path, "is a directory, expected a file");
  if (fs::exists(st) && !fs::is_regular_file(st))
    return file_error(path, std::string("is not a regular file (") +
                                (fs::is_fifo(st)             ? "a named pipe"
                                 : fs::is_character_file(st) ? "a character device"
                                 : fs::is_block_file(st)     ? "a block device"
                                 : fs::is_socket(st)         ? "a socket"
                                                             : "an unknown kind of file") +
                                "), expected a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return file_error(path, std::string("cannot open for reading: ") + std::strerror(errno));
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) return file_error(path, "cannot determine the file size");
  if (static_cast<std::uint64_t>(size) > max_bytes)
    return file_error(
        path, "file is " + std::to_string(size) + " bytes, larger than the limit of " + std::to_string(max_bytes));
  in.seekg(0, std::ios::beg);
  std::string data(static_cast<std::size_t>(size), '\0');
  if (size > 0 && !in.read(data.data(), size)) return file_error(path, "read failed");
  return data;
}

Result<void> write_file_atomic(const std::string& path, const std::function<Result<void>(std::ostream&)>& write) {
  const fs::path target(path);
  if (target.filename().empty()) return file_error(path, "output path names no file");
  std::error_code ec;
  if (fs::is_directory(target, ec)) return file_error(path, "is a directory, expected a file path");
  const fs::path tmp = target.parent_path() / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()));
  Result<void> status;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      return file_error(path, std::string("cannot open a temporary for writing beside it: ") + std::strerror(errno));
    }
    try {
      status = write(out);
    } catch (const std::exception& e) {
      status = file_error(path, std::string("writing failed: ") + e.what());
    }
    if (status.ok()) {
      out.flush();
      if (!out) status = file_error(path, "write failed (disk full?)");
    }
  }
  if (!status.ok()) {
    fs::remove(tmp, ec);
    if (status.error().file.empty()) status.error().file = path;
    return status;
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return file_error(path, "cannot rename the temporary into place: " + ec.message());
  }
  return {};
}

Result<void> write_file_atomic(const std::string& path, std::string_view content) {
  return write_file_atomic(path, [&](std::ostream& out) -> Result<void> {
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    return {};
  });
}

std::string file_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace shatter
