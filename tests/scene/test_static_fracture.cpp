// `shatter static --fracture`: the case's "fracture" section (every field, and errors naming the
// field), and the fragment, crack and rest-shape outputs end to end on the bundled examples.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "shatter/core/file_io.h"
#include "shatter/fracture/fragments.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/scene/static_case.h"
#include "support/test_support.h"

namespace shatter {
namespace {

namespace fs = std::filesystem;

const std::string kExamples = std::string(SHATTER_SOURCE_DIR) + "/examples/";

using test::lines_of;
using test::read_text;

std::string write_case(const test::TempDir& dir, const std::string& name, const std::string& text) {
  const std::string p = dir.file(name);
  const Result<void> w = write_file_atomic(p, text);
  SHATTER_CHECK(w.ok());
  return p;
}

// The glass bar case with another total force (N).
std::string glass_case(double force, const std::string& extra = "") {
  return R"({"name": "glass_bar", "material": "glass", "model": "linear",
  "anchors": [
    {"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}, "components": "x"},
    {"plane": {"point": [0, 0, 0], "normal": [0, 1, 0]}, "components": "y"},
    {"plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}, "components": "z"}],
  "loads": [{"plane": {"point": [0.2, 0, 0], "normal": [1, 0, 0]}, "total_force": [)" +
         std::to_string(force) + R"(, 0, 0], "distribution": "area"}])" + extra + "}";
}

test::CommandResult run_static(const std::string& mesh, const std::string& case_path, const std::string& out,
                               const std::string& more = "", bool merge_stderr = false) {
  return test::run_command(test::cli_path() + " static " + mesh + " --case " + case_path + " --out " + out + " " + more,
                           merge_stderr);
}

double mesh_volume(const TetMesh& m) {
  double v = 0;
  for (Index e = 0; e < m.num_tets(); ++e) v += signed_volume(m, e);
  return v;
}

TEST(StaticFractureCase, ParsesEveryField) {
  auto c = parse_static_case(R"({"material": "glass", "anchors": [{"nodes": [1, 2, 3]}],
    "fracture": {"max_cracks": 2, "brittleness": 3.5, "radius_fraction": 0.25, "min_radius_edges": 2,
                 "separation": 1.5, "split_tets": false, "snap_fraction": 0.2, "min_piece_fraction": 0.01,
                 "plasticity": false, "creep": 0.75, "max_plastic_strain": "inf", "min_rest_volume_fraction": 0.3}})",
                             "f.json");
  ASSERT_OK(c);
  EXPECT_TRUE(c->fracture_given);
  const FractureOptions& o = c->fracture;
  EXPECT_EQ(o.crack.max_cracks, 2);
  EXPECT_EQ(o.crack.brittleness, 3.5);
  EXPECT_EQ(o.crack.radius_fraction, 0.25);
  EXPECT_EQ(o.crack.min_radius_edges, 2.0);
  EXPECT_EQ(o.crack.separation, 1.5);
  EXPECT_FALSE(o.cut.split_tets);
  EXPECT_EQ(o.cut.snap_fraction, 0.2);
  EXPECT_EQ(o.cut.min_volume_fraction, 0.01);
  EXPECT_FALSE(o.plasticity.enabled);
  EXPECT_EQ(o.plasticity.creep, 0.75);
  EXPECT_TRUE(std::isinf(o.plasticity.max_plastic_strain));
  EXPECT_EQ(o.plasticity.min_volume_fraction, 0.3);

  // Absent: the fracture module's defaults.
  auto d = parse_static_case(R"({"material": "glass", "anchors": [{"nodes": [1, 2, 3]}]})", "d.json");
  ASSERT_OK(d);
  EXPECT_FALSE(d->fracture_given);
  const FractureOptions defaults;
  EXPECT_EQ(d->fracture.crack.max_cracks, defaults.crack.max_cracks);
  EXPECT_EQ(d->fracture.cut.split_tets, defaults.cut.split_tets);
  EXPECT_EQ(d->fracture.plasticity.creep, defaults.plasticity.creep);
}

TEST(StaticFractureCase, BadFieldsNameTheField) {
  struct Bad {
    const char* section;
    const char* field;
    const char* message;
  };
  const Bad cases[] = {
      {R"("x")", "fracture", "object"},
      {R"({"max_cracks": -1})", "fracture.max_cracks", "0..10000"},
      {R"({"max_cracks": 1.5})", "fracture.max_cracks", "integer"},
      {R"({"max_crack": 2})", "fracture", "did you mean \"max_cracks\""},
      {R"({"brittleness": -1})", "fracture.brittleness", ">= 0"},
      {R"({"radius_fraction": 0})", "fracture.radius_fraction", "> 0"},
      {R"({"min_radius_edges": "big"})", "fracture.min_radius_edges", "number"},
      {R"({"separation": -0.5})", "fracture.separation", ">= 0"},
      {R"({"split_tets": 1})", "fracture.split_tets", "true or false"},
      {R"({"snap_fraction": 0.5})", "fracture.snap_fraction", "[0, 0.5)"},
      {R"({"min_piece_fraction": -0.1})", "fracture.min_piece_fraction", "[0, 0.5)"},
      {R"({"plasticity": "yes"})", "fracture.plasticity", "true or false"},
      {R"({"creep": 1.5})", "fracture.creep", "[0, 1]"},
      {R"({"max_plastic_strain": 0})", "fracture.max_plastic_strain", "> 0"},
      {R"({"min_rest_volume_fraction": 1})", "fracture.min_rest_volume_fraction", "(0, 1)"},
  };
  for (const Bad& b : cases) {
    const std::string json =
        std::string(R"({"material": "glass", "anchors": [{"nodes": [1, 2, 3]}], "fracture": )") + b.section + "}";
    auto c = parse_static_case(json, "bad.json");
    ASSERT_FALSE(c.ok()) << json;
    EXPECT_EQ(c.error().file, "bad.json");
    EXPECT_NE(c.error().to_string().find(b.field), std::string::npos) << c.error().to_string();
    EXPECT_NE(c.error().message.find(b.message), std::string::npos) << c.error().to_string();
  }
  // A misspelt section name is a typo, not silently ignored.
  auto typo = parse_static_case(R"({"material": "glass", "anchors": [{"nodes": [1]}], "fractur": {}})", "t.json");
  ASSERT_FALSE(typo.ok());
  EXPECT_NE(typo.error().message.find("did you mean \"fracture\""), std::string::npos) << typo.error().to_string();
}

TEST(StaticFractureCli, GlassBarBreaksInTwo) {
  test::TempDir dir;
  const std::string mesh_path = kExamples + "glass_bar/bar.vtk";
  const std::string case_path = kExamples + "glass_bar/case.json";
  const std::string out = dir.file("out");
  auto r = run_static(mesh_path, case_path, out, "--fracture --json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.output;
  const auto& jf = j["fracture"];
  ASSERT_EQ(jf["fragments"].size(), 2u) << r.output;
  EXPECT_TRUE(jf["broken"].get<bool>());
  ASSERT_GE(jf["cracks"].size(), 1u);
  EXPECT_FALSE(jf.contains("plasticity"));  // glass does not yield

  auto input = read_mesh(mesh_path);
  ASSERT_OK(input);
  const MassProperties whole = mass_properties(input->mesh, 2500);
  std::set<FileId> input_nodes, input_tets, seen_nodes, seen_tets;
  for (Index i = 0; i < input->mesh.num_nodes(); ++i) input_nodes.insert(input->mesh.node_id(i));
  for (Index e = 0; e < input->mesh.num_tets(); ++e) input_tets.insert(input->mesh.tet_id(e));
  double volume = 0, mass = 0, json_mass = 0;
  Vec3 moment = Vec3::Zero();
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string file = (fs::path(out) / ("fragment_" + std::to_string(k) + ".vtu")).string();
    EXPECT_EQ(jf["fragments"][k]["file"].get<std::string>(), file);
    auto frag = read_mesh(file);
    ASSERT_OK(frag);
    EXPECT_EQ(frag->mesh.num_tets(), jf["fragments"][k]["tets"].get<Index>());
    for (Index e = 0; e < frag->mesh.num_tets(); ++e) EXPECT_GT(signed_volume(frag->mesh, e), 0.0);
    const MassProperties m = mass_properties(frag->mesh, 2500);
    EXPECT_NEAR(m.volume, jf["fragments"][k]["volume"].get<double>(), 1e-15);
    volume += m.volume;
    mass += m.mass;
    json_mass += jf["fragments"][k]["mass"].get<double>();
    moment += m.mass * m.center;
    for (Index i = 0; i < frag->mesh.num_nodes(); ++i) seen_nodes.insert(frag->mesh.node_id(i));
    for (Index e = 0; e < frag->mesh.num_tets(); ++e) seen_tets.insert(frag->mesh.tet_id(e));
  }
  EXPECT_NEAR(volume, whole.volume, 1e-12 * whole.volume);
  EXPECT_NEAR(mass, whole.mass, 1e-12 * whole.mass);
  EXPECT_NEAR(json_mass, whole.mass, 1e-12 * whole.mass);
  EXPECT_NEAR((moment / mass - whole.center).norm(), 0, 1e-12);
  // Every input node and tet id is carried by some fragment (duplicates and split pieces get fresh
  // ids above the input's largest).
  for (FileId id : input_nodes) EXPECT_TRUE(seen_nodes.count(id)) << "node " << id;
  for (FileId id : input_tets) EXPECT_TRUE(seen_tets.count(id)) << "tet " << id;
  for (FileId id : seen_nodes)
    if (!input_nodes.count(id)) {
      EXPECT_GT(id, *input_nodes.rbegin());
    }
  for (FileId id : seen_tets)
    if (!input_tets.count(id)) {
      EXPECT_GT(id, *input_tets.rbegin());
    }

  // The whole cut mesh and the crack table.
  auto whole_cut = read_mesh((fs::path(out) / "fragments.vtu").string());
  ASSERT_OK(whole_cut);
  EXPECT_NEAR(mesh_volume(whole_cut->mesh), whole.volume, 1e-12 * whole.volume);
  const std::string vtu = read_text(fs::path(out) / "fragments.vtu");
  for (const char* name : {"fragment_id", "display_stress", "displacement", "node_id", "tet_id"})
    EXPECT_NE(vtu.find(std::string("Name=\"") + name + "\""), std::string::npos) << name;
  const auto cracks = lines_of(read_text(fs::path(out) / "cracks.csv"));
  ASSERT_EQ(cracks.size(), jf["cracks"].size() + 1);
  EXPECT_EQ(cracks[0].rfind("crack,origin_element_id,x,y,z,nx,ny,nz,radius", 0), 0u) << cracks[0];
  // The bar is pulled along x: the crack plane's normal is (close to) the x axis.
  EXPECT_GT(std::abs(jf["cracks"][0]["normal"][0].get<double>()), 0.99);
  EXPECT_FALSE(fs::exists(fs::path(out) / "rest_shape.vtu"));

  // The same bytes again.
  const std::string out2 = dir.file("out2");
  auto r2 = run_static(mesh_path, case_path, out2, "--fracture --json");
  ASSERT_EQ(r2.status, 0) << r2.output;
  for (const char* name : {"fragment_0.vtu", "fragment_1.vtu", "fragments.vtu", "cracks.csv", "result.vtu",
                           "elements.csv", "displacements.csv"})
    EXPECT_EQ(read_text(fs::path(out) / name), read_text(fs::path(out2) / name)) << name;

  // The text summary lists fragments and cracks.
  auto rt = run_static(mesh_path, case_path, dir.file("out3"), "--fracture");
  ASSERT_EQ(rt.status, 0) << rt.output;
  EXPECT_NE(rt.output.find("fragment 1"), std::string::npos) << rt.output;
  EXPECT_NE(rt.output.find("crack 0"), std::string::npos) << rt.output;
}

TEST(StaticFractureCli, OtherFragmentFormats) {
  test::TempDir dir;
  const std::string out = dir.file("out");
  auto r = run_static(kExamples + "glass_bar/bar.vtk", kExamples + "glass_bar/case.json", out,
                      "--fracture --fragment-format msh");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* name : {"fragment_0.msh", "fragment_1.msh"}) {
    auto m = read_mesh((fs::path(out) / name).string());
    ASSERT_OK(m);
    EXPECT_GT(m->mesh.num_tets(), 0);
  }
  EXPECT_FALSE(fs::exists(fs::path(out) / "fragment_0.vtu"));
  auto bad = run_static(kExamples + "glass_bar/bar.vtk", kExamples + "glass_bar/case.json", dir.file("o2"),
                        "--fracture --fragment-format obj", true);
  EXPECT_EQ(bad.status, 2) << bad.output;
}

// --fracture whose fragments.vtu cannot be written: the earlier fragment files all stay as they were
// (none deleted, none replaced), and so do the earlier displacements.
TEST(StaticFractureCli, FailedRunKeepsEveryEarlierFragment) {
  test::TempDir dir;
  const std::string out = dir.file("out");
  const std::string mesh = kExamples + "glass_bar/bar.vtk";
  ASSERT_EQ(run_static(mesh, kExamples + "glass_bar/case.json", out, "--fracture").status, 0);
  const fs::path d(out);
  std::map<std::string, std::string> before;
  for (const char* name : {"fragment_0.vtu", "fragment_1.vtu", "displacements.csv", "cracks.csv"})
    before[name] = read_text(d / name);
  fs::remove(d / "fragments.vtu");
  fs::create_directory(d / "fragments.vtu");
  // Below strength: one fragment, so fragment_1.vtu would be removed by a run that succeeds.
  const std::string whole = write_case(dir, "whole.json", glass_case(1000.0));
  auto r = run_static(mesh, whole, out, "--fracture", true);
  EXPECT_EQ(r.status, 4) << r.output;
  EXPECT_NE(r.output.find("fragments.vtu"), std::string::npos) << r.output;
  for (const auto& [name, text] : before) EXPECT_EQ(read_text(d / name), text) << name;
  // The same run with the folder free replaces them all, and removes the stale fragment_1.
  fs::remove(d / "fragments.vtu");
  auto ok = run_static(mesh, whole, out, "--fracture", true);
  ASSERT_EQ(ok.status, 0) << ok.output;
  EXPECT_FALSE(fs::exists(d / "fragment_1.vtu"));
  EXPECT_NE(read_text(d / "displacements.csv"), before["displacements.csv"]);
}

// The glass bar moved to x = 1e7 m (map coordinates) under 1 N: at those coordinates its
// displacements are below the spacing of the doubles, so the solve runs about the mesh's centre
// and the result is the one at the origin (it used to stall as "not converged", and before that to
// report a wrong answer as converged). The result mesh stays where the input was.
TEST(StaticFractureCli, FarFromTheOriginSolvesAsAtTheOrigin) {
  test::TempDir dir;
  auto bar = read_mesh(kExamples + "glass_bar/bar.vtk");
  ASSERT_OK(bar);
  auto case_at = [&](double x0) {
    const std::string p = std::to_string(x0), q = std::to_string(x0 + 0.2);
    return R"({"material": "glass", "model": "linear", "anchors": [
      {"plane": {"point": [)" +
           p + R"(, 0, 0], "normal": [1, 0, 0]}, "components": "x"},
      {"plane": {"point": [0, 0, 0], "normal": [0, 1, 0]}, "components": "y"},
      {"plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}, "components": "z"}],
      "loads": [{"plane": {"point": [)" +
           q + R"(, 0, 0], "normal": [1, 0, 0]}, "total_force": [1, 0, 0]}]})";
  };
  TetMesh far = bar->mesh;
  for (Vec3& v : far.positions) v.x() += 1e7;
  ASSERT_OK(write_mesh(dir.file("far.vtu"), far));
  auto r = run_static(dir.file("far.vtu"), write_case(dir, "far.json", case_at(1e7)), dir.file("far"), "", true);
  ASSERT_EQ(r.status, 0) << r.output;
  auto ok =
      run_static(kExamples + "glass_bar/bar.vtk", write_case(dir, "near.json", case_at(0)), dir.file("near"), "", true);
  ASSERT_EQ(ok.status, 0) << ok.output;
  // The same displacements (up to the digits the shifted coordinates keep: 1e7 m to 1e-9 m).
  auto read_u = [](const fs::path& csv) {
    std::vector<double> u;
    std::ifstream in(csv);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::stringstream ss(line);
      std::string cell;
      std::getline(ss, cell, ',');
      while (std::getline(ss, cell, ',')) u.push_back(std::stod(cell));
    }
    return u;
  };
  const std::vector<double> uf = read_u(fs::path(dir.file("far")) / "displacements.csv");
  const std::vector<double> un = read_u(fs::path(dir.file("near")) / "displacements.csv");
  ASSERT_EQ(uf.size(), un.size());
  double umax = 0, diff = 0;
  for (std::size_t i = 0; i < un.size(); ++i) {
    umax = std::max(umax, std::abs(un[i]));
    diff = std::max(diff, std::abs(uf[i] - un[i]));
  }
  EXPECT_GT(umax, 6e-9);  // 1 N on 4 cm^2 of glass over 0.2 m: 6.9 nm
  EXPECT_LT(diff, 1e-6 * umax);
  auto result = read_mesh(dir.file("far") + "/result.vtu");
  ASSERT_OK(result);
  EXPECT_NEAR(result->mesh.positions[0].x(), 1e7, 1.0);
}

// The glass bar scaled by 1e60 (its positions by 1e60, 1 N at the end): the displacements, about
// 1e-128 of the coordinates, cannot be held by a double, and the rest state's round-off forces
// (F = I to 1e-16, over areas of 1e118 m^2) dwarf the load. It used to "converge" to |u| = 6e42 m;
// it must end not converged, exit 1 and write nothing.
TEST(StaticFractureCli, HugeScaleIsNotAFalseSuccess) {
  test::TempDir dir;
  auto bar = read_mesh(kExamples + "glass_bar/bar.vtk");
  ASSERT_OK(bar);
  TetMesh huge = bar->mesh;
  for (Vec3& v : huge.positions) v *= 1e60;
  ASSERT_OK(write_mesh(dir.file("huge.vtu"), huge));
  const std::string c = R"({"material": "glass", "model": "linear", "anchors": [
      {"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}, "components": "x"},
      {"plane": {"point": [0, 0, 0], "normal": [0, 1, 0]}, "components": "y"},
      {"plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}, "components": "z"}],
      "loads": [{"plane": {"point": [2e59, 0, 0], "normal": [1, 0, 0]}, "total_force": [1, 0, 0]}]})";
  auto r = run_static(dir.file("huge.vtu"), write_case(dir, "huge.json", c), dir.file("out"), "", true);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("did not converge"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("double precision"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("nan"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(fs::path(dir.file("out")) / "displacements.csv"));
}

// A mesh of two separate pieces that nothing breaks: the summary says so with the fragment count
// it then lists (it used to say "1 fragment" and list 2).
TEST(StaticFractureCli, SeparatePiecesAreCountedNotCracked) {
  test::TempDir dir;
  TetMesh a = make_box_mesh({.max = Vec3(0.2, 0.02, 0.02), .cells = {5, 1, 1}});
  const TetMesh b = make_box_mesh({.min = Vec3(0, 0.05, 0), .max = Vec3(0.2, 0.07, 0.02), .cells = {5, 1, 1}});
  const Index offset = a.num_nodes();
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  for (TetIndices t : b.tets) {
    for (int k = 0; k < 4; ++k) t[k] += offset;
    a.tets.push_back(t);
  }
  ASSERT_OK(write_mesh(dir.file("two.vtu"), a));
  const std::string case_path = write_case(dir, "two.json", R"({"material": "glass", "model": "linear",
      "anchors": [{"plane": {"point": [0, 0, 0], "normal": [1, 0, 0]}}],
      "loads": [{"plane": {"point": [0.2, 0, 0], "normal": [1, 0, 0]}, "total_force": [10, 0, 0]}]})");
  auto r = run_static(dir.file("two.vtu"), case_path, dir.file("out"), "--fracture", true);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("nothing breaks: no crack, 2 fragment(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("fragment 1"), std::string::npos) << r.output;
}

TEST(StaticFractureCli, BelowStrengthStaysWhole) {
  test::TempDir dir;
  const std::string mesh_path = kExamples + "glass_bar/bar.vtk";
  const std::string out = dir.file("out");
  // First a breaking run into the folder, then a safe load (30 MPa < 50 MPa): the stale second
  // fragment must go.
  ASSERT_EQ(run_static(mesh_path, write_case(dir, "break.json", glass_case(24000)), out, "--fracture").status, 0);
  ASSERT_TRUE(fs::exists(fs::path(out) / "fragment_1.vtu"));
  auto r = run_static(mesh_path, write_case(dir, "safe.json", glass_case(12000)), out, "--fracture");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("nothing breaks"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(fs::path(out) / "fragment_0.vtu"));
  EXPECT_FALSE(fs::exists(fs::path(out) / "fragment_1.vtu"));
  const auto cracks = lines_of(read_text(fs::path(out) / "cracks.csv"));
  ASSERT_EQ(cracks.size(), 1u);  // header only
  auto input = read_mesh(mesh_path);
  ASSERT_OK(input);
  auto frag = read_mesh((fs::path(out) / "fragment_0.vtu").string());
  ASSERT_OK(frag);
  EXPECT_EQ(frag->mesh.num_tets(), input->mesh.num_tets());
  EXPECT_EQ(frag->mesh.num_nodes(), input->mesh.num_nodes());
  auto rj = run_static(mesh_path, dir.file("safe.json"), dir.file("out2"), "--fracture --json");
  ASSERT_EQ(rj.status, 0) << rj.output;
  const auto j = nlohmann::json::parse(rj.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << rj.output;
  EXPECT_EQ(j["fracture"]["fragments"].size(), 1u);
  EXPECT_EQ(j["fracture"]["cracks"].size(), 0u);
  EXPECT_FALSE(j["fracture"]["broken"].get<bool>());
}

TEST(StaticFractureCli, LeadBlockDentsWithoutBreaking) {
  test::TempDir dir;
  const std::string mesh_path = kExamples + "lead_block/block.vtk";
  const std::string out = dir.file("out");
  auto r = run_static(mesh_path, kExamples + "lead_block/case.json", out, "--fracture --json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.output;
  const auto& jf = j["fracture"];
  EXPECT_EQ(jf["fragments"].size(), 1u) << r.output;
  EXPECT_EQ(jf["cracks"].size(), 0u) << r.output;
  ASSERT_TRUE(jf.contains("plasticity")) << r.output;
  EXPECT_GT(jf["plasticity"]["yielded_tets"].get<int>(), 0);
  const double eps = jf["plasticity"]["max_plastic_strain"].get<double>();
  EXPECT_GT(eps, 0.0);
  EXPECT_LT(eps, 0.05);

  auto input = read_mesh(mesh_path);
  ASSERT_OK(input);
  // Read back with validation: an inverted tet would be reported as a warning (failing the test).
  auto rest = read_mesh((fs::path(out) / "rest_shape.vtu").string());
  ASSERT_OK(rest);
  ASSERT_EQ(rest->mesh.num_tets(), input->mesh.num_tets());
  ASSERT_EQ(rest->mesh.num_nodes(), input->mesh.num_nodes());
  for (Index e = 0; e < rest->mesh.num_tets(); ++e) EXPECT_GT(signed_volume(rest->mesh, e), 0.0) << e;
  // The rest shape moved (a permanent bend), and its volume changed by the absorbed volumetric
  // strain (docs/static_case.md).
  double moved = 0;
  for (Index i = 0; i < rest->mesh.num_nodes(); ++i)
    moved = std::max(moved, (rest->mesh.positions[i] - input->mesh.positions[i]).norm());
  EXPECT_GT(moved, 0.0);
  const double v0 = mesh_volume(input->mesh), v1 = mesh_volume(rest->mesh);
  EXPECT_GT(std::abs(v1 - v0), 1e-12 * v0);
  EXPECT_LT(std::abs(v1 - v0), 1e-3 * v0);
  // The text summary says how much yielded.
  auto rt = run_static(mesh_path, kExamples + "lead_block/case.json", dir.file("out2"), "--fracture");
  ASSERT_EQ(rt.status, 0) << rt.output;
  EXPECT_NE(rt.output.find("yielded"), std::string::npos) << rt.output;
  EXPECT_NE(rt.output.find("max plastic strain"), std::string::npos) << rt.output;
}

TEST(StaticFractureCli, BadFractureFieldExits3) {
  test::TempDir dir;
  const std::string out = dir.file("out");
  const std::string bad = write_case(dir, "bad.json", glass_case(24000, R"(, "fracture": {"max_cracks": -2})"));
  auto r = run_static(kExamples + "glass_bar/bar.vtk", bad, out, "--fracture", true);
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_NE(r.output.find("fracture.max_cracks"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("bad.json"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
  const std::string typo = write_case(dir, "typo.json", glass_case(24000, R"(, "fracture": {"split_tet": false})"));
  r = run_static(kExamples + "glass_bar/bar.vtk", typo, out, "--fracture", true);
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_NE(r.output.find("split_tets"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(StaticFractureCli, FractureSectionLimitsCracks) {
  test::TempDir dir;
  // max_cracks 0: the overloaded bar stays whole.
  const std::string c = write_case(dir, "none.json", glass_case(24000, R"(, "fracture": {"max_cracks": 0})"));
  auto r = run_static(kExamples + "glass_bar/bar.vtk", c, dir.file("out"), "--fracture --json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.output;
  EXPECT_EQ(j["fracture"]["fragments"].size(), 1u);
  EXPECT_EQ(j["fracture"]["cracks"].size(), 0u);
}

}  // namespace
}  // namespace shatter
