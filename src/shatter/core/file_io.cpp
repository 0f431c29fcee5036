#include "shatter/core/file_io.h"

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <system_error>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace shatter {

namespace fs = std::filesystem;

namespace {

thread_local OutputBatch* t_batch = nullptr;  // outermost open batch of this thread

// A short name beside `target` for a temporary or a backup: short so that a target name near the
// file-system limit (255 bytes) still has room, unique per process and call.
fs::path sibling_name(const fs::path& target, const char* kind) {
  static std::atomic<std::uint64_t> counter{0};
  return target.parent_path() /
         (".shatter-" + std::string(kind) + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
}

// Closes a POSIX file descriptor when it leaves scope.
struct FileDescriptor {
  int fd;
  explicit FileDescriptor(int descriptor) : fd(descriptor) {}
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  ~FileDescriptor() { ::close(fd); }
};

// Files of at least this size are checked for holes; a file storing under 1/kSparseRatio of its
// bytes is refused (a 10 GiB file made by `truncate` would otherwise be read as 10 GiB of zeros).
constexpr std::uint64_t kSparseCheckBytes = 1ULL << 20;
constexpr std::uint64_t kSparseRatio = 16;

std::uint64_t physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return 0;  // unknown: no memory bound
  return static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page);
}

// Bytes of the file's data extents, from lseek's SEEK_DATA / SEEK_HOLE; `size` where the file
// system cannot say (every byte then counts as stored) or the file has very many extents.
std::uint64_t stored_bytes(int fd, std::uint64_t size) {
  constexpr int kMaxExtents = 1 << 16;
  std::uint64_t stored = 0;
  ::off_t pos = 0;
  for (int extent = 0; extent < kMaxExtents; ++extent) {
    const ::off_t data = ::lseek(fd, pos, SEEK_DATA);
    if (data < 0) return errno == ENXIO ? stored : size;  // ENXIO: no data after pos
    const ::off_t hole = ::lseek(fd, data, SEEK_HOLE);
    if (hole < data) return size;
    stored += static_cast<std::uint64_t>(hole - data);
    if (static_cast<std::uint64_t>(hole) >= size) return stored;
    pos = hole;
  }
  return size;
}

}  // namespace

OutputBatch::OutputBatch() {
  if (t_batch)
    outer_ = t_batch;
  else
    t_batch = this;
}

OutputBatch::~OutputBatch() {
  if (outer_) return;
  discard();
  t_batch = nullptr;
}

OutputBatch* OutputBatch::current() { return t_batch; }

void OutputBatch::stage(const std::string& target, const std::string& temp) {
  // A run that rewrites its series at every frame stages the same target thousands of times.
  if (const auto it = index_.find(target); it != index_.end()) {
    std::error_code ec;
    fs::remove(staged_[it->second].temp, ec);
    staged_[it->second].temp = temp;
    return;
  }
  index_.emplace(target, staged_.size());
  staged_.push_back({target, temp});
}

void OutputBatch::remove_on_commit(const std::string& path) {
  if (outer_)
    outer_->remove_on_commit(path);
  else
    remove_.push_back(path);
}

void OutputBatch::discard() {
  std::error_code ec;
  for (const Staged& s : staged_) fs::remove(s.temp, ec);
  staged_.clear();
  index_.clear();
  remove_.clear();
}

Result<void> OutputBatch::commit() {
  if (outer_) return {};
  std::error_code ec;
  // Keep each earlier file under a second name (a hard link: nothing copied) so that a failed
  // rename half-way can put back the ones already replaced.
  std::vector<std::string> backup(staged_.size());
  for (std::size_t k = 0; k < staged_.size(); ++k) {
    if (!fs::is_regular_file(staged_[k].target, ec)) continue;
    const fs::path b = sibling_name(staged_[k].target, "old");
    fs::create_hard_link(staged_[k].target, b, ec);
    if (ec) fs::copy_file(staged_[k].target, b, ec);  // a file system without hard links
    if (ec) {
      const std::string target = staged_[k].target;
      for (const std::string& p : backup)
        if (!p.empty()) fs::remove(p, ec);
      discard();
      return file_error(target, "cannot keep the earlier file while replacing it: " + ec.message() +
                                    "; none of this run's outputs were written");
    }
    backup[k] = b.string();
  }
  for (std::size_t k = 0; k < staged_.size(); ++k) {
    fs::rename(staged_[k].temp, staged_[k].target, ec);
    if (!ec) continue;
    const std::string why = ec.message();
    std::error_code ec2;
    for (std::size_t j = 0; j < k; ++j) {
      if (!backup[j].empty())
        fs::rename(backup[j], staged_[j].target, ec2);
      else
        fs::remove(staged_[j].target, ec2);
    }
    for (std::size_t j = k; j < staged_.size(); ++j)
      if (!backup[j].empty()) fs::remove(backup[j], ec2);
    const std::string target = staged_[k].target;
    discard();
    return file_error(target,
                      "cannot rename the temporary into place: " + why + "; none of this run's outputs were replaced");
  }
  for (const std::string& p : backup)
    if (!p.empty()) fs::remove(p, ec);
  for (const std::string& p : remove_) fs::remove(p, ec);
  staged_.clear();
  index_.clear();
  remove_.clear();
  return {};
}

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
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return file_error(path, std::string("cannot open for reading: ") + std::strerror(errno));
  const FileDescriptor guard{fd};
  struct stat info{};
  if (::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode))
    return file_error(path, "is not a regular file, expected a file");
  const auto size = static_cast<std::uint64_t>(info.st_size);
  if (size > max_bytes)
    return file_error(
        path, "file is " + std::to_string(size) + " bytes, larger than the limit of " + std::to_string(max_bytes));
  // The file is read whole and parsed into structures of a similar size: refuse one that cannot fit
  // rather than let the system kill the process half-way.
  if (const std::uint64_t memory = physical_memory_bytes(); memory > 0 && size > memory / 2)
    return file_error(path, "file is " + std::to_string(size) + " bytes, more than half of this machine's memory (" +
                                std::to_string(memory) + " bytes): it is read whole");
  if (size >= kSparseCheckBytes) {
    const std::uint64_t stored = stored_bytes(fd, size);
    if (stored < size / kSparseRatio)
      return file_error(path, "is a sparse file: only " + std::to_string(stored) + " of its " + std::to_string(size) +
                                  " bytes are stored, the rest are holes (zeros); no mesh, surface or JSON file "
                                  "is mostly zeros");
  }
  std::string data(static_cast<std::size_t>(size), '\0');
  std::size_t done = 0;  // pread: the hole check above moved the file offset
  while (done < data.size()) {
    const ::ssize_t got = ::pread(fd, data.data() + done, data.size() - done, static_cast<::off_t>(done));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return file_error(path, std::string("read failed: ") + std::strerror(errno));
    if (got == 0) return file_error(path, "read failed: the file became shorter while it was read");
    done += static_cast<std::size_t>(got);
  }
  return data;
}

Result<void> write_file_atomic(const std::string& path, const std::function<Result<void>(std::ostream&)>& write) {
  const fs::path target(path);
  if (target.filename().empty()) return file_error(path, "output path names no file");
  std::error_code ec;
  if (fs::is_directory(target, ec)) return file_error(path, "is a directory, expected a file path");
  const fs::path tmp = sibling_name(target, "tmp");
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
  if (OutputBatch* batch = OutputBatch::current()) {
    batch->stage(path, tmp.string());
    return {};
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
