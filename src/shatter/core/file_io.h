// Whole-file reads and atomic writes: every output is written to a temporary beside the target
// and renamed over it, so a failure never leaves half a file and never destroys the old one.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "shatter/core/error.h"

namespace shatter {

/// Read a whole file into memory. Errors name the file. Files larger than max_bytes are refused,
/// and so is anything but a regular file (a directory, named pipe or device), without opening it.
Result<std::string> read_file(const std::string& path, std::uint64_t max_bytes = (1ULL << 34));

/// Write `path` atomically: `write` fills a stream opened on a temporary in the same folder; if it
/// returns an Error, throws, or the stream fails, the temporary is removed and `path` is untouched.
/// While an OutputBatch is open on this thread, the temporary is left for the batch's commit().
Result<void> write_file_atomic(const std::string& path, const std::function<Result<void>(std::ostream&)>& write);
/// Convenience: write bytes atomically.
Result<void> write_file_atomic(const std::string& path, std::string_view content);

/// The outputs of one run, replaced all together or not at all. While a batch is open on this
/// thread, write_file_atomic() leaves each finished temporary beside its target, and commit()
/// renames them all into place, putting the earlier files back if a rename fails. A batch
/// destroyed without commit() (an output failed, the caller returned early) removes its
/// temporaries: every earlier file stays as it was. Batches nest: an inner batch joins the
/// outermost one, whose commit() is the one that renames (so write_mesh's own batch for the two
/// TetGen files joins the batch of a whole analysis).
class OutputBatch {
 public:
  OutputBatch();
  ~OutputBatch();
  OutputBatch(const OutputBatch&) = delete;
  OutputBatch& operator=(const OutputBatch&) = delete;
  /// Remove `path` at commit, after the renames (an output of an earlier run that this run does
  /// not replace); nothing is removed without a commit.
  void remove_on_commit(const std::string& path);
  /// Put every staged file in place (or, for a batch nested in another, leave that to the outer
  /// one). On failure nothing has changed: earlier files restored, temporaries removed.
  Result<void> commit();

  /// The batch open on this thread, if any (used by write_file_atomic).
  static OutputBatch* current();
  /// Take over the finished temporary `temp` of `target` (a later one for the same target replaces it).
  void stage(const std::string& target, const std::string& temp);

 private:
  struct Staged {
    std::string target, temp;
  };
  void discard();
  OutputBatch* outer_ = nullptr;  ///< the batch this one joined, or nullptr for the outermost
  std::vector<Staged> staged_;
  std::map<std::string, std::size_t> index_;  ///< target -> its entry in staged_
  std::vector<std::string> remove_;
};

/// Lower-case extension with the dot (".msh"); for "a.vtu.gz" returns ".gz".
std::string file_extension(const std::string& path);

}  // namespace shatter
