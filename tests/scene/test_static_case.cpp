// Static load cases: CASE.json parsing (happy paths and a table of broken cases with the field
// each error must name), resolution against a mesh, and `shatter static` end to end.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "shatter/core/file_io.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/scene/static_case.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TetMesh unit_box(Index cells = 2) {
  return make_box_mesh(BoxMeshDef{.min = Vec3::Zero(), .max = Vec3(2, 1, 1), .cells = {2 * cells, cells, cells}});
}

const char* kGoodCase = R"({
  "name": "bar",
  "material": {"preset": "steel", "youngs_modulus": 2.0e11},
  "model": "linear",
  "anchors": [
    {"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}},
    {"box": {"min": [2, 0, 0], "max": [2, 1, 1]}, "components": "yz"}
  ],
  "loads": [
    {"nodes": [1, 2], "force": [0, -10, 0]},
    {"box": {"min": [2, 0, 0], "max": [2, 1, 1]}, "total_force": [1000, 0, 0]},
    {"box": {"min": [2, 0, 0], "max": [2, 1, 1]}, "total_force": [0, 0, 90], "distribution": "area"}
  ],
  "gravity": true,
  "solver": {"linear_solver": "pcg-jacobi", "tolerance": 1e-9, "max_iterations": 7, "load_steps": 2,
             "line_search": false, "linear_tolerance": 1e-11, "linear_max_iterations": 500,
             "tangent": "exact"}
})";

TEST(StaticCase, ParsesEveryField) {
  auto c = parse_static_case(kGoodCase, "good.json");
  ASSERT_OK(c);
  EXPECT_EQ(c->name, "bar");
  EXPECT_EQ(c->material.youngs_modulus, 2.0e11);
  EXPECT_EQ(c->material.name, "steel (modified)");
  auto steel = material_preset("steel");
  ASSERT_OK(steel);
  EXPECT_EQ(c->material.poisson_ratio, steel->poisson_ratio);
  EXPECT_EQ(c->model, ModelKind::linear);
  ASSERT_EQ(c->anchors.size(), 2u);
  EXPECT_EQ(c->anchors[0].where.kind, NodeSelector::Kind::plane);
  EXPECT_EQ(c->anchors[0].components, 7);
  EXPECT_EQ(c->anchors[1].components, 6);
  ASSERT_EQ(c->loads.size(), 3u);
  EXPECT_TRUE(c->loads[0].per_node);
  EXPECT_FALSE(c->loads[1].per_node);
  EXPECT_EQ(c->loads[2].distribution, LoadSpec::Distribution::area);
  EXPECT_EQ(c->gravity, Vec3(0, -9.81, 0));
  const StaticSolverOptions o = make_solver_options(c->solver);
  EXPECT_EQ(o.linear.kind, LinearSolverKind::pcg_block_jacobi);
  EXPECT_EQ(o.relative_residual_tolerance, 1e-9);
  EXPECT_EQ(o.max_newton_iterations, 7);
  EXPECT_EQ(o.load_increments, 2);
  EXPECT_FALSE(o.line_search);
  EXPECT_EQ(o.linear.relative_tolerance, 1e-11);
  EXPECT_EQ(o.linear.max_iterations, 500);
  EXPECT_EQ(o.tangent, TangentKind::exact);
  const auto bad = parse_static_case(R"({"material": "glass", "anchors": [{"nodes": [1]}],
                                          "solver": {"tangent": "clamped"}})",
                                     "t.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "solver.tangent") << bad.error().to_string();
  EXPECT_NE(bad.error().message.find("on-demand"), std::string::npos) << bad.error().message;
  EXPECT_NE(bad.error().message.find("by-model"), std::string::npos) << bad.error().message;
}

TEST(StaticCase, DefaultsAndShortForms) {
  auto c = parse_static_case(R"({"material": "glass", "anchors": [{"nodes": [1, 2, 3]}]})", "dir/short.json");
  ASSERT_OK(c);
  EXPECT_EQ(c->name, "short");
  EXPECT_EQ(c->material.name, "glass");
  EXPECT_EQ(c->model, ModelKind::stvk);
  EXPECT_TRUE(c->loads.empty());
  EXPECT_EQ(c->gravity, Vec3::Zero());
  const StaticSolverOptions o = make_solver_options(c->solver);
  const StaticSolverOptions d;
  EXPECT_EQ(o.max_newton_iterations, d.max_newton_iterations);
  EXPECT_EQ(o.relative_residual_tolerance, d.relative_residual_tolerance);

  auto custom = parse_static_case(
      R"({"material": {"youngs_modulus": 1e9, "poisson_ratio": 0.3, "density": 1000, "tensile_strength": "inf"},
          "anchors": [{"set": "base"}], "gravity": [0, 0, -10]})",
      "c.json");
  ASSERT_OK(custom);
  EXPECT_EQ(custom->material.name, "custom");
  EXPECT_TRUE(std::isinf(custom->material.tensile_strength));
  EXPECT_EQ(custom->gravity, Vec3(0, 0, -10));
}

struct BrokenCase {
  const char* json;
  const char* field;    // must appear in the error's field
  const char* message;  // must appear in the error's message
};

TEST(StaticCase, BrokenCasesNameTheField) {
  const BrokenCase cases[] = {
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "lods": []})", "lods", "did you mean \"loads\""},
      {R"({"anchors": [{"nodes": [1]}]})", "material", "missing"},
      {R"({"material": "unobtainium", "anchors": [{"nodes": [1]}]})", "material", "unobtainium"},
      {R"({"material": {"preset": "glass", "youngs_modulus": -1}, "anchors": [{"nodes": [1]}]})",
       "material.youngs_modulus", ""},
      {R"({"material": {"youngs_modulus": 1e9, "density": 1}, "anchors": [{"nodes": [1]}]})", "material.poisson_ratio",
       "missing"},
      {R"({"material": {"preset": "glass", "poison_ratio": 0.2}, "anchors": [{"nodes": [1]}]})",
       "material.poison_ratio", "did you mean \"poisson_ratio\""},
      {R"({"material": "glass", "model": "neo", "anchors": [{"nodes": [1]}]})", "model", "neo"},
      {R"({"material": "glass"})", "anchors", "rigid"},
      {R"({"material": "glass", "anchors": []})", "anchors", "at least one"},
      {R"({"material": "glass", "anchors": {"nodes": [1]}})", "anchors", "expected an array"},
      {R"({"material": "glass", "anchors": [{"components": "xy"}]})", "anchors[0]", "one of \"nodes\""},
      {R"({"material": "glass", "anchors": [{"nodes": [1], "box": {"min": [0,0,0], "max": [1,1,1]}}]})", "anchors[0]",
       "only one"},
      {R"({"material": "glass", "anchors": [{"nodes": [1], "components": "xw"}]})", "anchors[0].components", "x, y, z"},
      {R"({"material": "glass", "anchors": [{"nodes": [1], "components": "xx"}]})", "anchors[0].components", ""},
      {R"({"material": "glass", "anchors": [{"nodes": [1, "two"]}]})", "anchors[0].nodes[1]", "integer"},
      {R"({"material": "glass", "anchors": [{"nodes": []}]})", "anchors[0].nodes", "non-empty"},
      {R"({"material": "glass", "anchors": [{"box": {"min": [0,0], "max": [1,1,1]}}]})", "anchors[0].box.min",
       "3 numbers"},
      {R"({"material": "glass", "anchors": [{"box": {"min": [2,0,0], "max": [1,1,1]}}]})", "anchors[0].box",
       "min must not exceed max"},
      {R"({"material": "glass", "anchors": [{"box": {"min": [0,0,0]}}]})", "anchors[0].box.max", "missing"},
      {R"({"material": "glass", "anchors": [{"plane": {"point": [0,0,0], "normal": [0,0,0]}}]})",
       "anchors[0].plane.normal", "non-zero"},
      {R"({"material": "glass", "anchors": [{"plane": {"point": [0,0,0], "normal": [0,1,0], "tol": 1}}]})",
       "anchors[0].plane.tol", "did you mean \"tolerance\""},
      {R"({"material": "glass", "anchors": [{"nodes": [1], "tolerance": 0.1}]})", "anchors[0].tolerance", "box"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "loads": [{"nodes": [1]}]})", "loads[0]", "exactly one"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "loads": [{"nodes": [1], "force": [1, 2]}]})",
       "loads[0].force", "3 numbers"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "loads": [{"nodes": [1], "force": [1, 2, 3], "total_force": [1, 2, 3]}]})",
       "loads[0]", "exactly one"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "loads": [{"nodes": [1], "force": [1, 2, 3], "distribution": "area"}]})",
       "loads[0].distribution", "total_force"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "loads": [{"nodes": [1], "total_force": [1, 2, 3], "distribution": "mass"}]})",
       "loads[0].distribution", "\"equal\" or \"area\""},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "loads": [{"nodes": [1], "force": [1, "a", 3]}]})",
       "loads[0].force[1]", "number"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "gravity": "down"})", "gravity", "true, false"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "solver": {"linear_solver": "magic"}})",
       "solver.linear_solver", "magic"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "solver": {"tolerance": 0}})", "solver.tolerance", "> 0"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "solver": {"max_iterations": 0}})",
       "solver.max_iterations", "1..100000"},
      {R"({"material": "glass", "anchors": [{"nodes": [1]}], "solver": {"load_step": 3}})", "solver.load_step",
       "did you mean \"load_steps\""},
      {R"([1, 2])", "(top level)", "expected an object"},
  };
  for (const BrokenCase& b : cases) {
    auto c = parse_static_case(b.json, "broken.json");
    ASSERT_FALSE(c.ok()) << b.json;
    EXPECT_EQ(c.error().file, "broken.json") << b.json;
    EXPECT_EQ(c.error().field, b.field) << b.json << "\n" << c.error().to_string();
    EXPECT_NE(c.error().message.find(b.message), std::string::npos) << b.json << "\n" << c.error().to_string();
  }
}

TEST(StaticCase, SyntaxErrorNamesTheLine) {
  auto c = parse_static_case("{\n  \"material\": \"glass\",\n  \"anchors\": [,]\n}", "syntax.json");
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().file, "syntax.json");
  EXPECT_EQ(c.error().line, 3) << c.error().to_string();
}

TEST(StaticCase, ResolvesAnchorsAndLoads) {
  const TetMesh mesh = unit_box();  // 5 x 3 x 3 nodes over [0,2]x[0,1]x[0,1]
  auto c = parse_static_case(kGoodCase, "good.json");
  ASSERT_OK(c);
  auto r = resolve_static_case(*c, mesh);
  ASSERT_OK(r);
  int fixed = 0, rollers = 0;
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    const Vec3& p = mesh.positions[i];
    if (p.x() == 0) {
      EXPECT_EQ(r->held[i], 7);
      ++fixed;
    } else if (p.x() == 2) {
      EXPECT_EQ(r->held[i], 6);
      ++rollers;
    } else {
      EXPECT_EQ(r->held[i], 0);
    }
  }
  EXPECT_EQ(fixed, 9);
  EXPECT_EQ(rollers, 9);
  EXPECT_EQ(r->num_held_nodes, 18);
  // Loads: 2 x (0,-10,0) + total (1000,0,0) + total (0,0,90); applied (the total): node 1 is held
  // and z is held on the loaded end, so one -10 and the 90 fall on anchors.
  EXPECT_NEAR((r->total_load - Vec3(1000, -10, 0)).norm(), 0, 1e-9);
  // Equal spread: each of the 9 end nodes has 1000/9 in x.
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    if (mesh.positions[i].x() == 2) {
      EXPECT_NEAR(r->forces[i].x(), 1000.0 / 9.0, 1e-9);
    }
  // Area spread over a 1x1 face of 2x2 cells, each cut into 2 triangles: corner nodes get less than
  // edge nodes, the centre the most; the sum is the total.
  double z_sum = 0, z_max = 0, z_min = 1e9;
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    if (mesh.positions[i].x() == 2) {
      z_sum += r->forces[i].z();
      z_max = std::max(z_max, r->forces[i].z());
      z_min = std::min(z_min, r->forces[i].z());
    }
  EXPECT_NEAR(z_sum, 90, 1e-9);
  EXPECT_GT(z_max, z_min);
  const StaticProblem p = make_static_problem(*c, *r);
  EXPECT_TRUE(p.gravity);
  EXPECT_EQ(p.anchors.size(), static_cast<std::size_t>(mesh.num_nodes()));
  // Node 1 is held (node 2 is not) and z is held on the loaded end: half of the first load and all
  // of the third are not applied, and each is named (the x load on the rollers is applied).
  ASSERT_EQ(r->warnings.size(), 2u);
  EXPECT_EQ(r->warnings[0].rfind("good.json: loads[0]: 50 % of the load falls on held components", 0), 0u)
      << r->warnings[0];
  EXPECT_EQ(r->warnings[1].rfind("good.json: loads[2]: all of the load", 0), 0u) << r->warnings[1];
  // The total counts only what is applied.
  Vec3 applied = Vec3::Zero(), given = Vec3::Zero();
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    for (int k = 0; k < 3; ++k) {
      given[k] += r->forces[i][k];
      if (!(r->held[i] & (1u << k))) applied[k] += r->forces[i][k];
    }
  EXPECT_LT((r->total_load - applied).norm(), 1e-9);
  EXPECT_GT((given - applied).norm(), 1.0);
}

TEST(StaticCase, ResolveErrorsNameTheField) {
  const TetMesh mesh = unit_box();
  struct Bad {
    const char* json;
    const char* field;
    const char* message;
  };
  const Bad cases[] = {
      {R"({"material": "glass", "anchors": [{"nodes": [1, 999]}]})", "anchors[0]", "node id 999"},
      {R"({"material": "glass", "anchors": [{"box": {"min": [5,5,5], "max": [6,6,6]}}]})", "anchors[0]",
       "contains no node"},
      {R"({"material": "glass", "anchors": [{"plane": {"point": [0,0,0.25], "normal": [0,0,1]}}]})", "anchors[0]",
       "no node"},
      {R"({"material": "glass", "anchors": [{"set": "base"}]})", "anchors[0]", "no node set"},
      {R"({"material": "glass", "anchors": [{"plane": {"point": [0,0,0], "normal": [1,0,0]}}],
          "loads": [{"nodes": [0], "force": [1, 0, 0]}]})",
       "loads[0]", "node id 0"},
      // A single held node leaves rotations free; a plane held only in x leaves sliding free.
      {R"({"material": "glass", "anchors": [{"nodes": [1]}]})", "anchors", "rigid"},
      {R"({"material": "glass", "anchors": [{"plane": {"point": [0,0,0], "normal": [1,0,0]}, "components": "x"}]})",
       "anchors", "rigid"},
      // An edge (a line of nodes) held in full still lets the body rotate about it.
      {R"({"material": "glass", "anchors": [{"box": {"min": [0,0,0], "max": [0,0,1]}}]})", "anchors", "rigid"},
      // Area spread over nodes that span no boundary triangle (a single node).
      {R"({"material": "glass", "anchors": [{"plane": {"point": [0,0,0], "normal": [1,0,0]}}],
          "loads": [{"nodes": [5], "total_force": [1, 0, 0], "distribution": "area"}]})",
       "loads[0]", "boundary triangle"},
  };
  for (const Bad& b : cases) {
    auto c = parse_static_case(b.json, "r.json");
    ASSERT_OK(c);
    auto r = resolve_static_case(*c, mesh);
    ASSERT_FALSE(r.ok()) << b.json;
    EXPECT_EQ(r.error().file, "r.json");
    EXPECT_EQ(r.error().field, b.field) << r.error().to_string();
    EXPECT_NE(r.error().message.find(b.message), std::string::npos) << r.error().to_string();
  }
  // Three rollers on the three symmetry planes through one corner (the classic 3-2-1 support)
  // do hold every rigid motion.
  auto ok = parse_static_case(R"({"material": "glass", "anchors": [
      {"plane": {"point": [0,0,0], "normal": [1,0,0]}, "components": "x"},
      {"plane": {"point": [0,0,0], "normal": [0,1,0]}, "components": "y"},
      {"plane": {"point": [0,0,0], "normal": [0,0,1]}, "components": "z"}]})",
                              "ok.json");
  ASSERT_OK(ok);
  EXPECT_OK(resolve_static_case(*ok, mesh));
}

// --- `shatter static` end to end -------------------------------------------------------------

using test::lines_of;
using test::read_text;

struct CliFixture {
  test::TempDir dir;
  std::string mesh_path = dir.file("bar.vtu");
  TetMesh mesh = unit_box();
  CliFixture() {
    const Result<void> w = write_mesh(mesh_path, mesh);
    SHATTER_CHECK(w.ok());
  }
  std::string write_case(const std::string& name, const std::string& text) const {
    const std::string p = dir.file(name);
    const Result<void> w = write_file_atomic(p, text);
    SHATTER_CHECK(w.ok());
    return p;
  }
};

const char* kCliCase = R"({
  "material": "steel",
  "model": "linear",
  "anchors": [{"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}}],
  "loads": [{"box": {"min": [2, 0, 0], "max": [2, 1, 1]}, "total_force": [0, -1.0e6, 0]}]
})";

TEST(StaticCli, WritesResultsAndSummary) {
  CliFixture f;
  const std::string case_path = f.write_case("bend.json", kCliCase);
  const std::string out = f.dir.file("out");
  auto r = test::run_command(test::cli_path() + " static " + f.mesh_path + " --case " + case_path + " --out " + out);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("max |u|"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("converged"), std::string::npos) << r.output;

  // displacements.csv: header + one row per node; the loaded end moves down, the held end not.
  const auto disp = lines_of(read_text(std::filesystem::path(out) / "displacements.csv"));
  ASSERT_EQ(disp.size(), static_cast<std::size_t>(f.mesh.num_nodes()) + 1);
  EXPECT_EQ(disp[0], "node_id,ux,uy,uz");
  for (Index i = 0; i < f.mesh.num_nodes(); ++i) {
    FileId id = 0;
    double u[3] = {};
    ASSERT_EQ(std::sscanf(disp[static_cast<std::size_t>(i) + 1].c_str(), "%ld,%lf,%lf,%lf", &id, &u[0], &u[1], &u[2]),
              4);
    EXPECT_EQ(id, f.mesh.node_id(i));
    if (f.mesh.positions[i].x() == 0) {
      EXPECT_EQ(u[0] * u[0] + u[1] * u[1] + u[2] * u[2], 0.0);
    }
    if (f.mesh.positions[i].x() == 2) {
      EXPECT_LT(u[1], 0.0);
    }
  }
  const auto elems = lines_of(read_text(std::filesystem::path(out) / "elements.csv"));
  ASSERT_EQ(elems.size(), static_cast<std::size_t>(f.mesh.num_tets()) + 1);
  EXPECT_EQ(elems[0], "element_id,sxx,syy,szz,sxy,syz,szx,max_principal,dir_x,dir_y,dir_z,von_mises");
  for (std::size_t k = 1; k < elems.size(); ++k) EXPECT_EQ(std::count(elems[k].begin(), elems[k].end(), ','), 11);

  auto vtu = read_mesh((std::filesystem::path(out) / "result.vtu").string());
  ASSERT_OK(vtu);
  EXPECT_EQ(vtu->mesh.num_tets(), f.mesh.num_tets());
  const std::string vtu_text = read_text(std::filesystem::path(out) / "result.vtu");
  for (const char* name : {"displacement", "stress", "max_principal", "von_mises", "node_id", "tet_id"})
    EXPECT_NE(vtu_text.find(std::string("Name=\"") + name + "\""), std::string::npos) << name;

  // --json: parses, and agrees with the files.
  const std::string out2 = f.dir.file("out2");
  auto rj = test::run_command(test::cli_path() + " static " + f.mesh_path + " --case " + case_path + " --out " + out2 +
                              " --json");
  ASSERT_EQ(rj.status, 0) << rj.output;
  const auto j = nlohmann::json::parse(rj.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << rj.output;
  EXPECT_EQ(j["mesh"]["tets"].get<int>(), f.mesh.num_tets());
  EXPECT_TRUE(j["solver"]["converged"].get<bool>());
  EXPECT_GT(j["max_displacement"]["value"].get<double>(), 0.0);
  EXPECT_NEAR(j["total_load"][1].get<double>(), -1.0e6, 1e-6);
  // Deterministic bytes: both runs wrote the same files.
  for (const char* name : {"displacements.csv", "elements.csv", "result.vtu"})
    EXPECT_EQ(read_text(std::filesystem::path(out) / name), read_text(std::filesystem::path(out2) / name)) << name;
}

TEST(StaticCli, BadInputExits3AndWritesNothing) {
  CliFixture f;
  const std::string out = f.dir.file("out");
  const std::string bad_case = f.write_case("bad.json", R"({"material": "glass", "anchors": [{"nodes": [1, 999]}]})");
  auto r =
      test::run_command(test::cli_path() + " static " + f.mesh_path + " --case " + bad_case + " --out " + out, true);
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_NE(r.output.find("anchors[0]"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("999"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));

  const std::string typo = f.write_case("typo.json", R"({"material": "glass", "anchor": []})");
  r = test::run_command(test::cli_path() + " static " + f.mesh_path + " --case " + typo + " --out " + out, true);
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_NE(r.output.find("did you mean \"anchors\""), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));

  const std::string good = f.write_case("good.json", kCliCase);
  r = test::run_command(test::cli_path() + " static " + f.dir.file("missing.msh") + " --case " + good + " --out " + out,
                        true);
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(StaticCli, OutputFailureExits4) {
  CliFixture f;
  const std::string good = f.write_case("good.json", kCliCase);
  // The output folder's place is taken by a file.
  const std::string blocker = f.write_case("blocker", "x");
  auto r =
      test::run_command(test::cli_path() + " static " + f.mesh_path + " --case " + good + " --out " + blocker, true);
  EXPECT_EQ(r.status, 4) << r.output;
}

// A run whose later output cannot be written replaces none of the earlier results: every file of
// the previous run stays byte for byte, and no temporary is left behind.
// A NUL in a case or material name is refused with the field named; it used to cut the message
// short, and a case name with one made a stray output folder before failing with exit 4.
TEST(StaticCli, NulInANameIsABadInput) {
  CliFixture f;
  for (const auto& [text, field] : std::vector<std::pair<std::string, std::string>>{
           {R"({"name": "bar\u0000x", "material": "steel", "anchors": [{"nodes": [1]}]})", "name"},
           {R"({"material": "st\u0000eel", "anchors": [{"nodes": [1]}]})", "material"}}) {
    const std::string case_path = f.write_case("nul.json", text);
    auto r = test::run_command(
        "cd " + f.dir.file("") + " && " + test::cli_path() + " static " + f.mesh_path + " --case " + case_path, true);
    EXPECT_EQ(r.status, 3) << r.output;
    EXPECT_NE(r.output.find(field + ": expected a string without NUL"), std::string::npos) << r.output;
    for (const auto& e : std::filesystem::directory_iterator(f.dir.file("")))
      EXPECT_EQ(e.path().filename().string().find("_out"), std::string::npos) << e.path();
  }
}

// A load on held nodes is not applied; the run says so instead of listing it silently.
TEST(StaticCli, LoadOnHeldNodesIsNamed) {
  CliFixture f;
  const std::string case_path = f.write_case("held.json", R"({"material": "steel", "model": "linear",
    "anchors": [{"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}}],
    "loads": [{"box": {"min": [2, 0, 0], "max": [2, 1, 1]}, "total_force": [0, -1000, 0]},
              {"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}, "total_force": [0, -5, 0]}]})");
  auto r = test::run_command(
      test::cli_path() + " static " + f.mesh_path + " --case " + case_path + " --out " + f.dir.file("out"), true);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("shatter: warning: " + case_path + ": loads[1]: all of the load falls on held"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("loads[0]:"), std::string::npos) << r.output;
}

TEST(StaticCli, FailedRunKeepsEveryEarlierOutput) {
  CliFixture f;
  const std::string out = f.dir.file("out");
  const std::string first = f.write_case("first.json", kCliCase);
  ASSERT_EQ(
      test::run_command(test::cli_path() + " static " + f.mesh_path + " --case " + first + " --out " + out).status, 0);
  const std::filesystem::path dir(out);
  std::map<std::string, std::string> before;
  for (const char* name : {"displacements.csv", "elements.csv"}) before[name] = read_text(dir / name);
  // A different load (so every file would change), and result.vtu's place taken by a folder.
  std::string twice = kCliCase;
  twice.replace(twice.find("-1.0e6"), 6, "-2.0e6");
  const std::string second = f.write_case("second.json", twice);
  std::filesystem::remove(dir / "result.vtu");
  std::filesystem::create_directory(dir / "result.vtu");
  for (const char* blocked : {"result.vtu", "elements.csv"}) {
    SCOPED_TRACE(blocked);
    if (std::string(blocked) == "elements.csv") {
      // The same with the second output blocked (and the third free).
      std::filesystem::remove(dir / "result.vtu");
      std::filesystem::rename(dir / "elements.csv", dir / "kept.csv");
      std::filesystem::create_directory(dir / "elements.csv");
    }
    auto r =
        test::run_command(test::cli_path() + " static " + f.mesh_path + " --case " + second + " --out " + out, true);
    EXPECT_EQ(r.status, 4) << r.output;
    EXPECT_NE(r.output.find(blocked), std::string::npos) << r.output;
    EXPECT_EQ(read_text(dir / "displacements.csv"), before["displacements.csv"]);
    if (std::string(blocked) == "result.vtu") {
      EXPECT_EQ(read_text(dir / "elements.csv"), before["elements.csv"]);
    } else {
      EXPECT_FALSE(std::filesystem::exists(dir / "result.vtu"));
    }
    for (const auto& e : std::filesystem::directory_iterator(dir))
      EXPECT_NE(e.path().filename().string().rfind(".shatter-", 0), 0u) << e.path();
  }
}

}  // namespace
}  // namespace shatter
