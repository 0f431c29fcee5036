// `shatter`: command-line entry point. Data goes to stdout, messages to stderr.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "command.h"
#include "shatter/core/log.h"

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

int report_error(const std::string& message, int code) {
  std::fprintf(stderr, "shatter: error: %s\n", message.c_str());
  return code;
}

}  // namespace shatter::cli

int main(int argc, char** argv) {
  using namespace shatter::cli;
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
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }
  try {
    for (auto& [sub, run] : commands)
      if (sub->parsed()) return run();
  } catch (const std::exception& e) {
    return report_error(std::string("internal error: ") + e.what(), kExitFailure);
  }
  return kExitUsage;
}
