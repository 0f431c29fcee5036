// Helpers shared by the test programs.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "shatter/core/error.h"

namespace shatter::test {

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

/// Fail the test with the error's text if r is not ok.
#define ASSERT_OK(expr)                                                        \
  do {                                                                         \
    const auto& shatter_r_ = (expr);                                           \
    ASSERT_TRUE(shatter_r_.ok()) << shatter_r_.error().to_string();            \
  } while (0)
#define EXPECT_OK(expr)                                                        \
  do {                                                                         \
    const auto& shatter_r_ = (expr);                                           \
    EXPECT_TRUE(shatter_r_.ok()) << (shatter_r_.ok() ? std::string() : shatter_r_.error().to_string()); \
  } while (0)

}  // namespace shatter::test
