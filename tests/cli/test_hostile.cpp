// The hostile-input suite: every command and every file type against the classes of fault that
// break a command-line tool's promises (docs/cli.md): a crash, a hang, unbounded memory, NaN in a
// report, a failed run that destroys earlier results, a false success, a message that names no
// file. Each run is checked against all of them, whatever it was given:
//   - it ends within its time limit and under an address-space limit (outside the sanitizers,
//     which reserve terabytes of address space), by exit, not by a signal;
//   - its status is one the command documents for what it was given; an error says
//     "shatter: error:" and, for a file, names it; no "internal error";
//   - a report has no NaN or infinity, and its JSON no null the report does not account for;
//   - the output folder holds exactly what it held before, byte for byte, when the run failed,
//     and no temporary is left behind either way.
// HostileInput.MutatedFiles mutates seed files of every format deterministically; SHATTER_SOAK=N
// runs N times as many mutations (scripts/soak.sh).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "shatter/core/random.h"
#include "support/test_support.h"

namespace shatter {
namespace {

namespace fs = std::filesystem;

using test::kSanitized;

bool have_cli() { return !test::cli_path().empty() && fs::exists(test::cli_path()); }

using test::quoted;

void write_all(const fs::path& p, const std::string& bytes) { std::ofstream(p, std::ios::binary) << bytes; }

// Every regular file under `dir` with its bytes (names relative to `dir`).
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> files;
  if (!fs::exists(dir)) return files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = test::read_text(e.path());
  return files;
}

// What a run printed: stdout (data, reports) and stderr (messages) apart.
struct RunResult {
  int status = -1;
  std::string out, err;
};

// A run of the CLI under limits: `timeout` kills a hang (status 137), `ulimit -v` turns unbounded
// memory into a failed allocation.
RunResult run_limited(const std::string& args, int seconds = 60) {
  static int counter = 0;
  const fs::path err = fs::temp_directory_path() /
                       ("shatter_hostile_stderr_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  std::string cmd;
  if (!kSanitized) cmd += "ulimit -v 6000000; ";  // 6 GB of address space
  cmd +=
      "timeout -s KILL " + std::to_string(seconds) + " " + test::cli_path() + " " + args + " 2>" + quoted(err.string());
  const test::CommandResult r = test::run_command(cmd);
  RunResult run{r.status, r.output, test::read_text(err)};
  fs::remove(err);
  return run;
}

bool is_word_char(char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0 || c == '_'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

// A word that is a NaN or an infinity as printf prints one ("nan", "-nan", "inf", "-inf").
// (No std::regex: GCC 12 warns inside it at -O1 with the sanitizers.)
bool has_non_finite_word(const std::string& text) {
  for (std::size_t i = 0; i < text.size();) {
    if (!is_word_char(text[i])) {
      ++i;
      continue;
    }
    std::size_t j = i;
    std::string word;
    while (j < text.size() && is_word_char(text[j])) word += static_cast<char>(std::tolower(text[j++]));
    if (word == "nan" || word == "inf" || word == "infinity") return true;
    i = j;
  }
  return false;
}

// Spans (begin, length) of the decimal numbers in `s` (sign, digits, point, exponent), at most `limit`.
std::vector<std::pair<std::size_t, std::size_t>> number_spans(const std::string& s, std::size_t limit) {
  std::vector<std::pair<std::size_t, std::size_t>> spans;
  std::size_t i = 0;
  while (i < s.size() && spans.size() < limit) {
    std::size_t j = i;
    if (s[j] == '-' || s[j] == '+') ++j;
    bool digits = false;
    for (; j < s.size() && is_digit(s[j]); ++j) digits = true;
    if (j < s.size() && s[j] == '.')
      for (++j; j < s.size() && is_digit(s[j]); ++j) digits = true;
    if (!digits) {
      ++i;
      continue;
    }
    if (j + 1 < s.size() && (s[j] == 'e' || s[j] == 'E')) {
      std::size_t k = j + 1;
      if (s[k] == '-' || s[k] == '+') ++k;
      if (k < s.size() && is_digit(s[k])) {
        while (k < s.size() && is_digit(s[k])) ++k;
        j = k;
      }
    }
    spans.emplace_back(i, j - i);
    i = j;
  }
  return spans;
}

// Nulls in a JSON report, as paths; inspect writes null for a value a double cannot hold and names
// it in `non_finite`, which accounts for it.
void collect_nulls(const nlohmann::json& j, const std::string& path, std::vector<std::string>& out) {
  if (j.is_null()) out.push_back(path);
  if (j.is_object())
    for (const auto& [k, v] : j.items()) collect_nulls(v, path + "." + k, out);
  if (j.is_array())
    for (std::size_t i = 0; i < j.size(); ++i) collect_nulls(j[i], path + "[" + std::to_string(i) + "]", out);
}

// What a run may end with.
struct Expect {
  std::set<int> statuses;         // documented statuses for this input
  std::string names;              // a failure's message must contain this (a file name), "" if none
  bool json = false;              // stdout is a JSON report when the status is 0
  std::vector<fs::path> outputs;  // folders whose contents a failure must leave as they were
};

// Run `args` and check every promise; `what` says in a failure message what the input was.
RunResult check_run(const std::string& args, const Expect& e, const std::string& what, int seconds = 60) {
  std::vector<std::map<std::string, std::string>> before;
  for (const fs::path& d : e.outputs) before.push_back(snapshot(d));
  const RunResult r = run_limited(args, seconds);
  const std::string head =
      what + "\n$ shatter " + args + "\nstderr: " + r.err.substr(0, 1000) + "\nstdout: " + r.out.substr(0, 500);
  EXPECT_NE(r.status, 137) << "did not finish in " << seconds << " s: " << head;
  EXPECT_TRUE(r.status >= 0 && r.status < 128) << "killed by a signal: " << head;
  EXPECT_TRUE(e.statuses.count(r.status)) << "status " << r.status << ": " << head;
  EXPECT_EQ(r.err.find("internal error"), std::string::npos) << head;
  EXPECT_EQ(r.err.find("bad_alloc"), std::string::npos) << head;
  std::optional<nlohmann::json> report;  // the JSON report on stdout
  if (e.json && !r.out.empty()) {
    try {
      report = nlohmann::json::parse(r.out);
    } catch (const std::exception& ex) {
      ADD_FAILURE() << "the JSON report does not parse (" << ex.what() << "): " << head;
    }
  }
  // inspect reports a mesh with errors and exits 3: its report says so instead of an error line.
  const bool reported_invalid = report && report->is_object() && report->value("valid", true) == false;
  if (r.status != 0 && r.status < 128 && !reported_invalid) {
    EXPECT_NE(r.err.find("shatter: error:"), std::string::npos) << head;
    if (!e.names.empty()) {
      EXPECT_NE(r.err.find(e.names), std::string::npos) << "the message does not name " << e.names << ": " << head;
    }
  }
  if (r.status == 0 && e.json) {
    EXPECT_TRUE(report.has_value()) << "no JSON report: " << head;
  }
  if (report) {
    std::vector<std::string> nulls;
    collect_nulls(*report, "", nulls);
    if (!nulls.empty()) {
      EXPECT_TRUE(report->contains("non_finite") && !(*report)["non_finite"].empty())
          << "null at " << nulls.front() << " not named in non_finite: " << head;
    }
  } else if (r.status == 0) {
    EXPECT_FALSE(has_non_finite_word(r.out)) << "a NaN or infinity in the report: " << head;
  }
  for (std::size_t k = 0; k < e.outputs.size(); ++k) {
    const auto after = snapshot(e.outputs[k]);
    for (const auto& [name, bytes] : after)
      EXPECT_EQ(name.find(".shatter-"), std::string::npos) << "a temporary was left: " << name << ": " << head;
    if (r.status != 0) {
      EXPECT_TRUE(after == before[k]) << "a failed run changed " << e.outputs[k] << ": " << head;
    }
  }
  return r;
}

// The seed files of every type, made from the bundled examples through the CLI itself.
class Seeds {
 public:
  explicit Seeds(const test::TempDir& dir) : dir_(dir.path()) {
    const std::string bar = std::string(SHATTER_SOURCE_DIR) + "/examples/glass_bar/bar.vtk";
    const std::string cli = test::cli_path();
    fs::copy_file(bar, dir_ / "bar.vtk");
    fs::copy_file(std::string(SHATTER_SOURCE_DIR) + "/examples/glass_bar/case.json", dir_ / "case.json");
    for (const char* out : {"bar.msh", "bar.vtu", "bar.mesh", "bar.inp", "bar.node", "bar.stl", "bar.obj", "bar.ply"})
      convert(bar, out, "");
    convert(bar, "bar_binary.msh", "--binary");
    convert(bar, "bar_binary.vtk", "--binary");
    convert(bar, "bar_binary.vtu", "--binary");
    convert(bar, "bar_compressed.vtu", "--compress");
    convert(bar, "bar_binary.stl", "--binary");
    convert(bar, "bar_binary.ply", "--binary");
    for (const char* vtu : {"meshio_default.vtu", "vtk_default.vtu", "vtk_appended_raw.vtu"})
      fs::copy_file(test::data_path(std::string("mesh/vtu/") + vtu), dir_ / vtu);
    write_all(dir_ / "shape.json", R"({"tets": 400, "shape": {"type": "difference", "children": [
      {"type": "box", "size": [0.1, 0.06, 0.08], "rotate": {"axis": [0, 0, 1], "degrees": 20}},
      {"type": "cylinder", "radius": 0.02, "height": 0.2, "translate": [0.01, 0, 0]}]}})");
    write_all(dir_ / "ring.json", R"({"tets": 400, "shape": {"type": "revolution",
      "profile": [[0.03, 0], [0.05, 0], [0.05, 0.04], [0.03, 0.04]]}})");
    write_all(dir_ / "scene.json", R"({
  "name": "hostile", "duration": 0.4, "threads": 1,
  "world": {"time_step": 0.02, "substeps": 4},
  "ground": {"height": 0, "friction": 0.5},
  "materials": {"china": {"preset": "porcelain", "tensile_strength": 2e6}},
  "bodies": [
    {"name": "a", "shape": {"tets": 150, "shape": {"type": "sphere", "radius": 0.04}}, "material": "china",
     "height": 0.05, "velocity": [0, -4, 0]},
    {"name": "b", "mesh": "bar.vtk", "material": "glass", "position": [0, 0, 0.2], "height": 0.0,
     "array": {"count": [1, 1, 2], "spacing": [0, 0, 0.05]}}
  ],
  "actions": [{"time": 0.1, "type": "strike", "body": "b.0", "impulse": [0, 0.01, 0], "speed": 6}],
  "output": {"frames_per_second": 10, "vtu": true, "surfaces": "ply", "events": true, "summary": true, "gltf": true}
})");
  }
  [[nodiscard]] fs::path path(const std::string& name) const { return dir_ / name; }

 private:
  void convert(const std::string& in, const std::string& out, const std::string& flags) {
    const auto r = test::run_command(test::cli_path() + " convert -q " + flags + " " + quoted(in) + " " +
                                     quoted((dir_ / out).string()) + " 2>&1");
    EXPECT_EQ(r.status, 0) << out << ": " << r.output;
  }
  fs::path dir_;
};

// A command reading `input` the way each command reads its kind of file.
struct Reader {
  std::string name;                                     // for messages
  std::function<std::string(const std::string&)> args;  // the command line for an input path
  std::set<int> ok_statuses;                            // statuses a valid-looking input may end with
  bool json = false;                                    // --json report on stdout
};

std::vector<Reader> readers_for(const std::string& kind, const fs::path& out, const fs::path& seeds) {
  const std::string o = quoted(out.string());
  const std::string bar = quoted((seeds / "bar.vtk").string());
  const std::string c = quoted((seeds / "case.json").string());
  if (kind == "surface")
    return {{"mesh --surface",
             [o](const std::string& in) { return "mesh --json -n 300 --surface " + in + " -o " + o + "/m.vtu"; },
             {0, 3},
             true}};
  if (kind == "shape")
    return {{"mesh --shape",
             [o](const std::string& in) { return "mesh --json --shape " + in + " -o " + o + "/m.msh"; },
             {0, 3},
             true}};
  if (kind == "case")
    return {{"static --case",
             [o, bar](const std::string& in) {
               return "static " + bar + " --json --fracture --case " + in + " --out " + o;
             },
             {0, 1, 3},
             true}};
  if (kind == "scene")
    return {
        {"run", [o](const std::string& in) { return "run --json --threads 2 " + in + " --out " + o; }, {0, 3}, true}};
  // Volume meshes: inspect, convert, and a static analysis on them.
  return {{"inspect", [](const std::string& in) { return "inspect --json " + in; }, {0, 3}, true},
          {"convert", [o](const std::string& in) { return "convert -q " + in + " " + o + "/c.msh"; }, {0, 3}, false},
          {"static",
           [o, c](const std::string& in) { return "static " + in + " --case " + c + " --json --out " + o; },
           {0, 1, 3},
           true}};
}

// Seed files and the kind of reader each takes.
const std::vector<std::pair<std::string, std::string>>& seed_files() {
  static const std::vector<std::pair<std::string, std::string>> files = {
      {"bar.vtk", "mesh"},
      {"bar_binary.vtk", "mesh"},
      {"bar.msh", "mesh"},
      {"bar_binary.msh", "mesh"},
      {"bar.vtu", "mesh"},
      {"bar_binary.vtu", "mesh"},
      {"bar_compressed.vtu", "mesh"},
      {"meshio_default.vtu", "mesh"},
      {"vtk_default.vtu", "mesh"},
      {"vtk_appended_raw.vtu", "mesh"},
      {"bar.mesh", "mesh"},
      {"bar.inp", "mesh"},
      {"bar.node", "mesh"},
      {"bar.stl", "surface"},
      {"bar_binary.stl", "surface"},
      {"bar.obj", "surface"},
      {"bar.ply", "surface"},
      {"bar_binary.ply", "surface"},
      {"shape.json", "shape"},
      {"ring.json", "shape"},
      {"case.json", "case"},
      {"scene.json", "scene"},
  };
  return files;
}

// Numbers a careless or hostile file holds where a sane one was.
const std::vector<std::string>& hostile_numbers() {
  static const std::vector<std::string> numbers = {"1e400",
                                                   "-1e400",
                                                   "1e308",
                                                   "-1e308",
                                                   "nan",
                                                   "inf",
                                                   "-inf",
                                                   "0",
                                                   "-0",
                                                   "1e-320",
                                                   "-1",
                                                   "18446744073709551615",
                                                   "9223372036854775808",
                                                   "2147483648",
                                                   "-2147483649",
                                                   "4294967295",
                                                   "1e30",
                                                   "1e9"};
  return numbers;
}

// One deterministic mutation of `bytes`.
std::string mutate(const std::string& bytes, Random& rng) {
  std::string s = bytes;
  if (s.empty()) return s;
  switch (rng.below(7)) {
    case 0: {  // flip a few bytes
      const int n = 1 + static_cast<int>(rng.below(8));
      for (int i = 0; i < n; ++i) s[rng.below(s.size())] = static_cast<char>(rng.below(256));
      break;
    }
    case 1:  // cut short
      s.resize(rng.below(s.size()));
      break;
    case 2:
    case 3: {  // a number replaced by a hostile one (binary files: a 4- or 8-byte field overwritten)
      const std::vector<std::pair<std::size_t, std::size_t>> spans = number_spans(s, 100000);
      const std::string& h = hostile_numbers()[rng.below(hostile_numbers().size())];
      if (!spans.empty()) {
        const auto [at, len] = spans[rng.below(spans.size())];
        s.replace(at, len, h);
      }
      if (rng.below(2) == 0 && s.size() > 8) {
        const std::size_t at = rng.below(s.size() - 8);
        const std::uint64_t v = rng.below(2) ? ~std::uint64_t{0} : (std::uint64_t{1} << (31 + rng.below(33)));
        for (int b = 0; b < (rng.below(2) ? 4 : 8); ++b) s[at + b] = static_cast<char>((v >> (8 * b)) & 0xFF);
      }
      break;
    }
    case 4: {  // a line repeated (a count's worth of items, or a section twice)
      const std::size_t at = rng.below(s.size());
      const std::size_t b = s.rfind('\n', at) == std::string::npos ? 0 : s.rfind('\n', at) + 1;
      const std::size_t e = std::min(s.size(), s.find('\n', at) == std::string::npos ? s.size() : s.find('\n', at) + 1);
      const std::string line = s.substr(b, e - b);
      std::string many;
      const std::size_t times = 1 + rng.below(50);
      for (std::size_t i = 0; i < times && many.size() < (1U << 20); ++i) many += line;
      s.insert(e, many);
      break;
    }
    case 5: {  // a line deleted
      const std::size_t at = rng.below(s.size());
      const std::size_t b = s.rfind('\n', at) == std::string::npos ? 0 : s.rfind('\n', at) + 1;
      const std::size_t e = s.find('\n', at) == std::string::npos ? s.size() : s.find('\n', at) + 1;
      s.erase(b, e - b);
      break;
    }
    default: {  // bytes inserted: NULs, quotes, brackets, line ends
      static const std::string junk = std::string("\0\"[]{}\r\n,:-.e", 14);
      const std::size_t at = rng.below(s.size());
      std::string ins;
      for (std::size_t i = 0, n = 1 + rng.below(6); i < n; ++i) ins += junk[rng.below(junk.size())];
      s.insert(at, ins);
      break;
    }
  }
  return s;
}

// Inputs that are not files a command can read: each is refused with exit 3, naming it, at once
// (a named pipe is never opened: it would block until someone writes to it).
TEST(HostileInput, InputsThatAreNotReadableFiles) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  const Seeds seeds(dir);
  const fs::path out = dir.path() / "out";
  fs::create_directories(out);
  write_all(out / "keep.txt", "earlier results");
  ASSERT_EQ(test::run_command("mkfifo " + quoted(dir.file("pipe.msh"))).status, 0);
  fs::create_directories(dir.path() / "folder.vtu");
  write_all(dir.path() / "empty.inp", "");
  {
    Random rng(7);
    std::string noise(1 << 16, '\0');
    for (char& ch : noise) ch = static_cast<char>(rng.below(256));
    for (const char* name : {"noise.msh", "noise.vtu", "noise.vtk", "noise.mesh", "noise.node", "noise.stl",
                             "noise.ply", "noise.obj", "noise.json"})
      write_all(dir.path() / name, noise);
  }
  std::vector<std::string> inputs = {"/nonexistent/x.msh", dir.file("pipe.msh"), "/dev/zero", dir.file("folder.vtu"),
                                     dir.file("empty.inp")};
  for (const char* name : {"noise.msh", "noise.vtu", "noise.vtk", "noise.mesh", "noise.node"})
    inputs.push_back(dir.file(name));
  const std::string o = quoted(out.string());
  for (const std::string& in : inputs) {
    // A TetGen pair is named by whichever of .node and .ele failed: the stem names both.
    const std::string named = in.ends_with(".node") ? in.substr(0, in.size() - 4) : in;
    const Expect e{{3}, named, false, {out}};
    check_run("inspect " + quoted(in), e, in, 20);
    check_run("convert " + quoted(in) + " " + o + "/c.vtu", e, in, 20);
    check_run("static " + quoted(in) + " --case " + quoted(seeds.path("case.json").string()) + " --out " + o, e, in,
              20);
  }
  const std::string bar = quoted(seeds.path("bar.vtk").string());
  for (const std::string& in : {std::string("/nonexistent/x.json"), dir.file("pipe.msh"), std::string("/dev/zero"),
                                dir.file("folder.vtu"), dir.file("noise.json")}) {
    const Expect e{{3}, in, false, {out}};
    check_run("mesh --shape " + quoted(in) + " -o " + o + "/m.vtu", e, in, 20);
    check_run("static " + bar + " --case " + quoted(in) + " --out " + o, e, in, 20);
    check_run("run " + quoted(in) + " --out " + o, e, in, 20);
  }
  for (const char* name : {"noise.stl", "noise.ply", "noise.obj"}) {
    const std::string in = dir.file(name);
    check_run("mesh -n 300 --surface " + quoted(in) + " -o " + o + "/m.vtu", {{3}, in, false, {out}}, in, 20);
  }
}

// A 10 GiB file made by `truncate` is refused at once, not read (it would take 10 GiB and a minute).
TEST(HostileInput, SparseHugeFile) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  const fs::path huge = dir.path() / "huge.msh";
  write_all(huge, "$MeshFormat\n");
  fs::resize_file(huge, 10ULL << 30);
  for (const std::string& args :
       {"inspect " + quoted(huge.string()), "convert " + quoted(huge.string()) + " " + quoted(dir.file("out.vtu"))}) {
    const RunResult r = check_run(args, {{3}, huge.string(), false, {}}, "a sparse 10 GiB file", 20);
    EXPECT_NE(r.err.find("is a sparse file"), std::string::npos) << r.err;
  }
}

// A binary STL with one vertex thrown far away (one corrupted coordinate): the shape is a long thin
// spike in a huge box. Meshing it finely is refused at once with the memory it would take; coarser,
// it is meshed without the reference volume, whose lattice would be eight times as wasteful.
TEST(HostileInput, SurfaceWithAStrayVertex) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  const std::string cli = test::cli_path();
  ASSERT_EQ(
      test::run_command(cli + " mesh --primitive sphere --radius 0.1 -n 2000 -o " + quoted(dir.file("s.vtu")) + " && " +
                        cli + " convert -q --binary " + quoted(dir.file("s.vtu")) + " " + quoted(dir.file("s.stl")))
          .status,
      0);
  const std::string stl = test::read_text(dir.path() / "s.stl");
  ASSERT_GT(stl.size(), 84U + 50 * 6);
  auto stray = [&](float x, const std::string& name) {
    std::string bytes = stl;
    std::memcpy(bytes.data() + 84 + 50 * 5 + 12, &x, sizeof x);  // triangle 5, vertex 0, x
    write_all(dir.path() / name, bytes);
    return quoted(dir.file(name));
  };
  const auto start = std::chrono::steady_clock::now();
  const RunResult fine =
      check_run("mesh --surface " + stray(300.0F, "far.stl") + " -H 0.01 -o " + quoted(dir.file("m.vtu")),
                {{3}, "far.stl", false, {}}, "a stray vertex 300 m away", 30);
  EXPECT_NE(fine.err.find("GiB"), std::string::npos) << fine.err;
  EXPECT_NE(fine.err.find("300.1 x 0.2"), std::string::npos) << fine.err;  // the bounds, so the user sees why
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  const RunResult coarse =
      check_run("mesh --json --surface " + stray(100.0F, "near.stl") + " -H 0.02 -o " + quoted(dir.file("m.vtu")),
                {{0}, "", true, {}}, "a stray vertex 100 m away", 60);
  const auto j = nlohmann::json::parse(coarse.out);
  EXPECT_FALSE(j.contains("reference_volume")) << coarse.out;
  EXPECT_GT(j["tets"].get<int>(), 1000);
}

// Numbers on the command line that are not numbers, not finite or far out of range: a usage error
// (exit 2) naming the option, before any work.
TEST(HostileInput, CommandLineNumbers) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  const Seeds seeds(dir);
  const std::string scene = quoted(seeds.path("scene.json").string());
  const std::string o = quoted(dir.file("out"));
  fs::create_directories(dir.path() / "out");
  const std::vector<std::pair<std::string, std::string>> options = {
      {"mesh --primitive sphere --radius 0.1 -o " + o + "/m.vtu -H", "--edge-length"},
      {"mesh --primitive sphere -H 0.02 -o " + o + "/m.vtu --radius", "--radius"},
      {"mesh --primitive sphere --radius 0.1 -o " + o + "/m.vtu -n", "--tets"},
      {"mesh --primitive sphere --radius 0.1 -H 0.02 -o " + o + "/m.vtu --threads", "--threads"},
      {"mesh --primitive sphere --radius 0.1 -H 0.02 -o " + o + "/m.vtu --grading", "--grading"},
      {"mesh --shape " + quoted(seeds.path("ring.json").string()) + " -o " + o + "/m.vtu --segments", "--segments"},
      {"run " + scene + " --out " + o + " --time", "--time"},
      {"run " + scene + " --out " + o + " --threads", "--threads"},
  };
  for (const auto& [command, option] : options) {
    // Not a number, not finite, or negative: a usage error before any work.
    for (const char* value : {"nan", "inf", "-inf", "1e400", "-1", "abc", "0x"})
      check_run(command + " '" + value + "'", {{2}, option, false, {}}, option + " " + value, 20);
    // Finite but far too large: refused, as a usage error or by what it would need of the input,
    // or (a grading, a time the scene's bodies come to rest in) simply done.
    for (const char* value : {"2147483648", "18446744073709551616", "1e300"})
      check_run(command + " " + value, {{0, 2, 3}, "", false, {}}, option + " " + value, 60);
  }
}

// A run whose last output cannot be written replaces none of the earlier ones (exit 4): the
// outputs of one run are written to temporaries and renamed together at the end.
TEST(HostileInput, FailedOutputsReplaceNothing) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  const Seeds seeds(dir);
  const std::string bar = quoted(seeds.path("bar.vtk").string());
  struct Case {
    std::string args;                  // with OUT for the output folder
    std::string blocker;               // a folder made where this output file goes, so it cannot be written
    std::vector<std::string> earlier;  // files of an earlier run that must survive
  };
  const std::vector<Case> cases = {
      {"static " + bar + " --case " + quoted(seeds.path("case.json").string()) + " --out OUT",
       "elements.csv",
       {"displacements.csv", "summary.json"}},
      {"static " + bar + " --case " + quoted(seeds.path("case.json").string()) + " --fracture --out OUT",
       "fragments.vtu",
       {"fragment_1.vtu", "displacements.csv"}},
      {"convert " + bar + " OUT/m.node", "m.ele", {"m.node"}},
      {"mesh --primitive sphere --radius 0.05 -H 0.02 -o OUT/m.node", "m.ele", {"m.node"}},
      {"run " + quoted(seeds.path("scene.json").string()) + " --time 0.1 --out OUT",
       "summary.json",
       {"events.jsonl", "scene.pvd"}},
  };
  for (const Case& c : cases) {
    const fs::path out = dir.path() / ("out_" + std::to_string(&c - cases.data()));
    fs::create_directories(out / c.blocker);
    write_all(out / c.blocker / "inside", "a folder where a file should go");
    for (const std::string& f : c.earlier) write_all(out / f, "an earlier run's " + f);
    std::string args = c.args;
    for (std::size_t at; (at = args.find("OUT")) != std::string::npos;) args.replace(at, 3, quoted(out.string()));
    check_run(args, {{4}, c.blocker, false, {out}}, c.args, 120);
  }
}

// Seed files of every format mutated (bytes flipped, cut short, numbers replaced by hostile ones,
// lines repeated or deleted, junk inserted) and read by every command that takes them.
TEST(HostileInput, MutatedFiles) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  const Seeds seeds(dir);
  const char* soak = std::getenv("SHATTER_SOAK");
  const int per_seed = (kSanitized ? 2 : 6) * (soak ? std::max(1, std::atoi(soak)) : 1);
  const fs::path out = dir.path() / "out";
  const fs::path kept = fs::current_path() / "hostile_failures";  // outlives the test's folder
  int runs = 0;
  for (const auto& [file, kind] : seed_files()) {
    const std::string bytes = test::read_text(seeds.path(file));
    ASSERT_FALSE(bytes.empty()) << file;
    Random rng(std::hash<std::string>{}(file) ^ 20261201);  // per-file stream: adding a seed changes no other
    for (int k = 0; k < per_seed; ++k) {
      const std::string mutated = mutate(bytes, rng);
      // The mutated file sits where the seed was, so a scene's or case's relative paths still work.
      const fs::path input = seeds.path("mutated_" + file);
      write_all(input, mutated);
      if (file == "bar.node")
        fs::copy_file(seeds.path("bar.ele"), seeds.path("mutated_bar.ele"), fs::copy_options::overwrite_existing);
      for (const Reader& reader : readers_for(kind, out, seeds.path(""))) {
        fs::remove_all(out);
        fs::create_directories(out);
        write_all(out / "keep.txt", "earlier results");
        const std::string what =
            file + " mutation " + std::to_string(k) + " read by " + reader.name + " (kept in " + kept.string() + ")";
        const auto before_failures =
            ::testing::UnitTest::GetInstance()->current_test_info()->result()->total_part_count();
        check_run(reader.args(quoted(input.string())), {reader.ok_statuses, "", reader.json, {out}}, what, 90);
        ++runs;
        if (::testing::UnitTest::GetInstance()->current_test_info()->result()->total_part_count() != before_failures) {
          fs::create_directories(kept);
          fs::copy_file(input, kept / (std::to_string(k) + "_" + file), fs::copy_options::overwrite_existing);
        }
      }
    }
  }
  RecordProperty("runs", runs);
}

}  // namespace
}  // namespace shatter
