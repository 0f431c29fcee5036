#include "support/test_support.h"

#include <sys/wait.h>
#include <unistd.h>
#include <array>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include "shatter/core/log.h"

namespace shatter::test {
namespace {
std::mutex g_mutex;
int g_expect_depth = 0;
std::vector<std::string> g_messages;
}  // namespace

void install_warning_guard() {
  set_log_sink([](LogLevel level, std::string_view message) {
    if (level < LogLevel::warning) return;
    std::lock_guard lock(g_mutex);
    if (g_expect_depth > 0) {
      g_messages.emplace_back(message);
      return;
    }
    ADD_FAILURE() << "unexpected library warning: " << message;
  });
}

ExpectWarnings::ExpectWarnings() {
  std::lock_guard lock(g_mutex);
  if (g_expect_depth++ == 0) g_messages.clear();
}
ExpectWarnings::~ExpectWarnings() {
  std::lock_guard lock(g_mutex);
  --g_expect_depth;
}
const std::vector<std::string>& ExpectWarnings::messages() const { return g_messages; }

TempDir::TempDir() {
  const auto* info = testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "shatter";
  for (char& c : name)
    if (c == '/') c = '_';
  path_ = std::filesystem::temp_directory_path() / ("shatter_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}
TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string data_path(const std::string& relative) { return std::string(SHATTER_TEST_DATA_DIR) + "/" + relative; }

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream s(text);
  for (std::string line; std::getline(s, line);) out.push_back(line);
  return out;
}

CommandResult run_command(const std::string& command, bool merge_stderr) {
  CommandResult r;
  const std::string full = command + (merge_stderr ? " 2>&1" : "");
  FILE* pipe = ::popen(full.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) r.output.append(buf.data(), n);
  const int status = ::pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string cli_path() { return SHATTER_CLI_PATH; }

int closed_manifold_euler(const TriSurface& s) {
  std::map<std::pair<Index, Index>, int> edges;
  for (const TriIndices& t : s.triangles)
    for (int k = 0; k < 3; ++k) ++edges[{t[k], t[(k + 1) % 3]}];
  for (const auto& [e, n] : edges) {
    EXPECT_EQ(n, 1) << "edge " << e.first << "-" << e.second;
    EXPECT_EQ(edges.count({e.second, e.first}), 1u) << "open edge " << e.first << "-" << e.second;
  }
  // Vertex fans: walk around each vertex through its triangles' next edges.
  std::map<Index, std::map<Index, Index>> fan;  // vertex -> (next vertex -> previous vertex)
  for (const TriIndices& t : s.triangles)
    for (int k = 0; k < 3; ++k) fan[t[k]][t[(k + 1) % 3]] = t[(k + 2) % 3];
  for (const auto& [v, ring] : fan) {
    const Index start = ring.begin()->first;
    Index cur = start;
    std::size_t steps = 0;
    do {
      cur = ring.at(cur);
      ++steps;
    } while (cur != start && steps <= ring.size());
    EXPECT_EQ(steps, ring.size()) << "pinched vertex " << v;
  }
  return static_cast<int>(s.positions.size()) - static_cast<int>(edges.size() / 2) +
         static_cast<int>(s.triangles.size());
}

}  // namespace shatter::test
