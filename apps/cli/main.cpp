// `shatter`: command-line entry point. Data goes to stdout, messages to stderr.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "command.h"
#include "shatter/core/log.h"
#include "shatter/core/memory.h"

namespace shatter::cli {
namespace {
struct Entry {
  std::string name, description;
  SetupFn setup;
};
std::vector<Entry>& registry() {
  static std::vector<Entry> r;
  return r;
}
}  // namespace

Registration::Registration(const char* name, const char* description, SetupFn setup) {
  registry().push_back({name, description, setup});
}

// The bundled vase drop: scenes/vase_drop.json in the current folder, or beside the source tree
// the program was built in, or in an installed share/shatter.
std::string default_scene_path() {
  std::vector<std::filesystem::path> candidates = {"scenes/vase_drop.json",
                                                   std::filesystem::path(SHATTER_SOURCE_DIR) / "scenes/vase_drop.json"};
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path() / "../share/shatter/scenes/vase_drop.json");
  for (const auto& c : candidates)
    if (std::filesystem::is_regular_file(c, ec)) return c.lexically_normal().string();
  return "scenes/vase_drop.json";
}

bool parse_size(const std::string& text, int lo, int hi, int& width, int& height) {
  char x = 0, rest = 0;
  return std::sscanf(text.c_str(), "%d%c%d%c", &width, &x, &height, &rest) == 3 && (x == 'x' || x == 'X') &&
         width >= lo && height >= lo && width <= hi && height <= hi;
}

// Every floating-point option of the parsed subcommand holds a finite number: CLI11 reads "nan",
// "inf" and "1e400" (infinity) as doubles, and no option means any of them. Empty when all are.
std::string non_finite_option(const CLI::App& sub) {
  for (const CLI::Option* opt : sub.get_options()) {
    if (opt->get_type_name().rfind("FLOAT", 0) != 0) continue;
    for (const std::string& text : opt->results()) {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (end != text.c_str() && !std::isfinite(v))
        return opt->get_name() + ": expected a finite number, got \"" + text + "\"";
    }
  }
  return {};
}

int report_error(const std::string& message, int code) {
  std::fprintf(stderr, "shatter: error: %s\n", message.c_str());
  return code;
}

}  // namespace shatter::cli

int main(int argc, char** argv) {
  using namespace shatter::cli;
  // Impact steps free and reallocate large arrays: keep that memory instead of faulting in fresh
  // pages every step (core/memory.h).
  shatter::keep_freed_memory();
  CLI::App app{"shatter: deformation and fracture of stiff solids on tetrahedral meshes"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("shatter 0.1.0"));
  // Static registration order depends on link order: sort for a stable --help.
  auto entries = registry();
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  std::vector<std::pair<CLI::App*, RunFn>> commands;
  for (const auto& e : entries) {
    CLI::App* sub = app.add_subcommand(e.name, e.description);
    commands.emplace_back(sub, e.setup(*sub));
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // CLI11's own messages ("Could not convert: --radius = abc") in the form of every other error.
    report_error(std::string(e.what()) + " (shatter COMMAND --help lists the options)", kExitUsage);
    return kExitUsage;
  }
  try {
    for (auto& [sub, run] : commands) {
      if (!sub->parsed()) continue;
      if (const std::string bad = non_finite_option(*sub); !bad.empty()) return report_error(bad, kExitUsage);
      return run();
    }
  } catch (const std::exception& e) {
    return report_error(std::string("internal error: ") + e.what(), kExitFailure);
  }
  return kExitUsage;
}
