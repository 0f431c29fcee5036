// Subcommands of the `shatter` tool register themselves, one line each:
//   static const shatter::cli::Registration reg{"inspect", "Describe a mesh", &setup_inspect};
// `setup` adds options to the CLI11 subcommand and returns the function to run after parsing.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>

namespace shatter::cli {

/// Exit codes (docs/cli.md).
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,   ///< the command ran but its outcome is a failure (e.g. solver did not converge)
  kExitUsage = 2,     ///< bad command line
  kExitBadInput = 3,  ///< an input file or parameter is invalid
  kExitOutput = 4,    ///< an output could not be written
};

using RunFn = std::function<int()>;
using SetupFn = RunFn (*)(CLI::App& sub);

struct Registration {
  Registration(const char* name, const char* description, SetupFn setup);
};

/// Print an error message on stderr ("shatter: error: ..."). Returns `code` for convenience.
int report_error(const std::string& message, int code);

/// An image or window size "WIDTHxHEIGHT" (or "WxH" with a capital X), each in [lo, hi]. False
/// when the text is not one.
bool parse_size(const std::string& text, int lo, int hi, int& width, int& height);

/// The bundled vase drop: scenes/vase_drop.json in the current folder, beside the source tree the
/// program was built from, or in an installed share/shatter (`run`, `render` and `view` without a
/// scene).
std::string default_scene_path();

}  // namespace shatter::cli
