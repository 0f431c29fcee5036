// Helpers shared by the test programs.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/mesh/topology.h"

// Built with AddressSanitizer or ThreadSanitizer: GCC defines __SANITIZE_*__, clang answers
// __has_feature. Tests use it to skip what a sanitizer's runtime forbids (address-space limits,
// glibc's allocator settings) and to shorten runs that are ten times slower there.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SHATTER_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define SHATTER_TEST_SANITIZED 1
#endif
#endif

namespace shatter::test {

#if defined(SHATTER_TEST_SANITIZED)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

/// Route library warnings to the current test: an unexpected warning fails it.
void install_warning_guard();

/// While alive, warnings are collected instead of failing the test.
class ExpectWarnings {
 public:
  ExpectWarnings();
  ~ExpectWarnings();
  ExpectWarnings(const ExpectWarnings&) = delete;
  ExpectWarnings& operator=(const ExpectWarnings&) = delete;
  [[nodiscard]] const std::vector<std::string>& messages() const;
};

/// A fresh empty folder under the build tree for this test, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

/// Checks (with EXPECTs) that s is a closed, consistently oriented 2-manifold: every directed edge
/// once and its reverse once, every vertex's triangles one fan (no pinched vertex). Returns its
/// Euler characteristic V - E + F (2 for a sphere, 0 for a torus).
int closed_manifold_euler(const TriSurface& s);

/// Path of a file under tests/data.
std::string data_path(const std::string& relative);

/// Run a shell command; returns its exit status and captures stdout (+stderr if merge_stderr).
struct CommandResult {
  int status = -1;
  std::string output;
};
CommandResult run_command(const std::string& command, bool merge_stderr = false);

/// Path to the built `shatter` executable.
std::string cli_path();

/// A path or argument in single quotes for a shell command line (paths here have no quotes).
inline std::string quoted(const std::string& s) { return "'" + s + "'"; }

/// The whole file as bytes ("" when it cannot be read).
std::string read_text(const std::filesystem::path& p);

/// The lines of a text, without their line ends.
std::vector<std::string> lines_of(const std::string& text);

/// Check that a reader failed with a message containing `substring` at `line` (-1: no line);
/// when given, also the byte `offset` and the `file` the error names.
template <class T>
void expect_read_error(const Result<T>& r, const std::string& substring, std::int64_t line,
                       const std::string& file = "", std::int64_t offset = -1) {
  ASSERT_FALSE(r.ok()) << "expected an error containing '" << substring << "'";
  EXPECT_NE(r.error().message.find(substring), std::string::npos) << r.error().to_string();
  EXPECT_EQ(r.error().line, line) << r.error().to_string();
  if (!file.empty()) {
    EXPECT_EQ(r.error().file, file);
  }
  if (offset >= 0) {
    EXPECT_EQ(r.error().offset, offset) << r.error().to_string();
  }
}

/// An external tool a test compares against (meshio, CalculiX, the built CLI): skip when it is
/// missing on a developer machine, but fail under CI (environment variable CI set), where
/// scripts/setup.sh installs it, so a missing install step cannot hide behind a skip.
#define SHATTER_REQUIRE_TOOL(available, what)                                     \
  do {                                                                            \
    if (!(available)) {                                                           \
      if (std::getenv("CI") != nullptr) FAIL() << what << " (required under CI)"; \
      GTEST_SKIP() << what;                                                       \
    }                                                                             \
  } while (0)

/// Fail the test with the error's text if r is not ok.
#define ASSERT_OK(expr)                                             \
  do {                                                              \
    const auto& shatter_r_ = (expr);                                \
    ASSERT_TRUE(shatter_r_.ok()) << shatter_r_.error().to_string(); \
  } while (0)
#define EXPECT_OK(expr)                                                                                 \
  do {                                                                                                  \
    const auto& shatter_r_ = (expr);                                                                    \
    EXPECT_TRUE(shatter_r_.ok()) << (shatter_r_.ok() ? std::string() : shatter_r_.error().to_string()); \
  } while (0)

}  // namespace shatter::test
