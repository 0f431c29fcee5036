// `shatter mesh`: report on stdout, mesh written, non-zero exit and a message on bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "support/test_support.h"

namespace shatter {
namespace {

bool have_cli() { return !test::cli_path().empty() && std::filesystem::exists(test::cli_path()); }

TEST(CmdMesh, PrimitiveReportAndOutput) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  const std::string out = dir.file("sphere.vtu");
  const auto r = test::run_command(test::cli_path() + " mesh --primitive sphere --radius 0.1 -H 0.02 --json -o " + out);
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_GT(j["tets"].get<int>(), 1000);
  EXPECT_EQ(j["reference_kind"], "analytic");
  EXPECT_LT(std::abs(j["volume_error"].get<double>()), 0.02);
  EXPECT_GT(j["dihedral_deg"]["min"].get<double>(), 10.0);
  EXPECT_TRUE(std::filesystem::exists(out));
}

TEST(CmdMesh, ShapeFileAndErrors) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  const std::string shape = dir.file("s.json");
  std::ofstream(shape) << R"({"tets": 2000, "shape": {"type": "union", "children": [
      {"type": "box", "size": [0.1, 0.1, 0.1]}, {"type": "sphere", "radius": 0.06, "translate": [0.05, 0, 0]}]}})";
  auto ok = test::run_command(test::cli_path() + " mesh --shape " + shape + " --json");
  ASSERT_EQ(ok.status, 0) << ok.output;
  EXPECT_EQ(nlohmann::json::parse(ok.output)["reference_kind"], "extrapolated from h/2");

  std::ofstream(shape)
      << R"({"tets": 2000, "shape": {"type": "union", "children": [{"type": "sphere", "radius": -1}]}})";
  auto bad = test::run_command(test::cli_path() + " mesh --shape " + shape + " 2>&1");
  EXPECT_EQ(bad.status, 3);
  EXPECT_NE(bad.output.find("shape.children[0].radius"), std::string::npos) << bad.output;

  auto none = test::run_command(test::cli_path() + " mesh --primitive sphere --radius 0.1 2>&1");
  EXPECT_EQ(none.status, 2) << none.output;
  auto open = test::run_command(test::cli_path() + " mesh --surface /nonexistent.obj -H 0.1 2>&1");
  EXPECT_EQ(open.status, 3) << open.output;
}

// --grading coarsens the inside of a stuffed mesh: fewer tets, the same volume, in the bounds; a
// negative factor is a usage error.
TEST(CmdMesh, Grading) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  const std::string cli = test::cli_path();
  auto uniform = test::run_command(cli + " mesh --primitive sphere --radius 0.1 -H 0.01 --json");
  auto graded = test::run_command(cli + " mesh --primitive sphere --radius 0.1 -H 0.01 --grading 1 --json");
  ASSERT_EQ(uniform.status, 0) << uniform.output;
  ASSERT_EQ(graded.status, 0) << graded.output;
  const auto ju = nlohmann::json::parse(uniform.output), jg = nlohmann::json::parse(graded.output);
  EXPECT_EQ(jg["tets_before_grading"], ju["tets"]);
  EXPECT_LT(jg["tets"].get<int>(), ju["tets"].get<int>() * 3 / 4);
  EXPECT_NEAR(jg["volume"].get<double>(), ju["volume"].get<double>(), 1e-10 * ju["volume"].get<double>());
  EXPECT_GE(jg["dihedral_deg"]["min"].get<double>(), 9.3);
  auto bad = test::run_command(cli + " mesh --primitive sphere --radius 0.1 -H 0.01 --grading -2 2>&1");
  EXPECT_EQ(bad.status, 2) << bad.output;
}

TEST(CmdMesh, MethodChoice) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  const std::string cli = test::cli_path();
  // A box qualifies for the box-CSG mesher: exact volume.
  auto box = test::run_command(cli + " mesh --primitive box --size 0.3 0.2 0.1 --tets 500 --json");
  ASSERT_EQ(box.status, 0) << box.output;
  const auto jb = nlohmann::json::parse(box.output);
  EXPECT_EQ(jb["method"], "box-csg");
  EXPECT_LT(std::abs(jb["volume_error"].get<double>()), 1e-12);
  auto stuffed =
      test::run_command(cli + " mesh --primitive box --size 0.3 0.2 0.1 --tets 500 --method stuffing --json");
  ASSERT_EQ(stuffed.status, 0) << stuffed.output;
  EXPECT_EQ(nlohmann::json::parse(stuffed.output)["method"], "stuffing");
  // The vase asset goes to the revolve mesher.
  auto vase =
      test::run_command(cli + " mesh --shape " + std::string(SHATTER_SOURCE_DIR) + "/assets/shapes/vase.json --json");
  ASSERT_EQ(vase.status, 0) << vase.output;
  EXPECT_EQ(nlohmann::json::parse(vase.output)["method"], "revolve");
  // A sphere is neither; an unknown method is a usage error.
  auto sphere = test::run_command(cli + " mesh --primitive sphere --radius 0.1 -H 0.05 --method structured 2>&1");
  EXPECT_EQ(sphere.status, 3) << sphere.output;
  EXPECT_NE(sphere.output.find("not a box CSG or a single revolution"), std::string::npos) << sphere.output;
  auto bogus = test::run_command(cli + " mesh --primitive sphere --radius 0.1 -H 0.05 --method magic 2>&1");
  EXPECT_EQ(bogus.status, 2) << bogus.output;
}

// Counts, sizes and depths from the command line and shape files are bounded before they size an
// allocation, a recursion or a loop: each is refused at once with the option or file named.
TEST(CmdMesh, HostileSizesAreRefused) {
  SHATTER_REQUIRE_TOOL(have_cli(), "shatter executable not built");
  test::TempDir dir;
  // `timeout` turns a hang into a failed test rather than a stuck suite.
  const std::string cli = "timeout 60 " + test::cli_path();
  for (const char* threads : {"100000", "2147483647", "-1"}) {
    auto r = test::run_command(cli + " mesh --primitive sphere --radius 0.1 -H 0.02 --threads " + threads + " 2>&1");
    EXPECT_EQ(r.status, 2) << threads << ": " << r.output;
    EXPECT_NE(r.output.find("--threads: expected 1 to 1024"), std::string::npos) << r.output;
  }
  auto ok = test::run_command(cli + " mesh --primitive sphere --radius 0.1 -H 0.05 --threads 1024 2>&1");
  EXPECT_EQ(ok.status, 0) << ok.output;
  // A bad output extension is a usage error before any meshing.
  auto ext =
      test::run_command(cli + " mesh --primitive sphere --radius 0.1 -H 0.02 -o " + dir.file("out.txt") + " 2>&1");
  EXPECT_EQ(ext.status, 2) << ext.output;

  // 10,000 nested unions: a clear error naming the file, not a stack overflow.
  std::string deep;
  for (int i = 0; i < 10'000; ++i) deep += R"({"type": "union", "children": [)";
  deep += R"({"type": "sphere", "radius": 0.1})";
  for (int i = 0; i < 10'000; ++i) deep += "]}";
  std::ofstream(dir.file("deep.json")) << R"({"tets": 1000, "shape": )" << deep << "}";
  auto d = test::run_command(cli + " mesh --shape " + dir.file("deep.json") + " 2>&1");
  EXPECT_EQ(d.status, 3) << d.output.substr(0, 400);
  EXPECT_NE(d.output.find("deep.json: JSON nested deeper than 256"), std::string::npos) << d.output.substr(0, 400);

  // The revolve mesher: segments, edge length and tet count bounded like the other meshers'.
  const std::string ring = dir.file("ring.json");
  std::ofstream(ring) << R"({"tets": 2000, "shape": {"type": "revolution",
      "profile": [[0.05, 0], [0.06, 0], [0.06, 0.1], [0.05, 0.1]]}})";
  struct Case {
    const char* args;
    int status;
    const char* expected;
  };
  for (const Case& c :
       {Case{"--segments 2147483647", 2, "--segments: expected 3 to 100000"},
        Case{"--segments 100000 -H 0.001", 3, "tets (limit 20000000)"}, Case{"-H 1e-7", 3, "points (limit 20000)"},
        Case{"-n 2000000000", 2, "--tets: expected a count from 1 to 20000000"}}) {
    auto r = test::run_command(cli + " mesh --shape " + ring + " " + c.args + " 2>&1");
    EXPECT_EQ(r.status, c.status) << c.args << ": " << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.args << ": " << r.output;
    if (c.status == 3) {
      EXPECT_NE(r.output.find("ring.json"), std::string::npos) << c.args << ": " << r.output;  // the file is named
    }
  }
  // A profile of more points than the mesher takes is named as such (not "not simple", not slow).
  {
    std::ofstream circle(dir.file("circle.json"));
    circle << R"({"tets": 1000, "shape": {"type": "revolution", "profile": [)";
    for (int i = 0; i < 30'000; ++i) {
      const double t = 2 * 3.141592653589793 * i / 30'000.0;
      circle << (i ? ", " : "") << "[" << 0.07 + 0.01 * std::cos(t) << ", " << 0.01 * std::sin(t) << "]";
    }
    circle << "]}}";
  }
  auto circle = test::run_command(cli + " mesh --shape " + dir.file("circle.json") + " 2>&1");
  EXPECT_EQ(circle.status, 3) << circle.output;
  EXPECT_NE(circle.output.find("the profile has 30000 points (limit 20000)"), std::string::npos) << circle.output;

  auto fine = test::run_command(cli + " mesh --shape " + ring + " --segments 64 --json");
  ASSERT_EQ(fine.status, 0) << fine.output;
  EXPECT_EQ(nlohmann::json::parse(fine.output)["segments"], 64);
}

}  // namespace
}  // namespace shatter
