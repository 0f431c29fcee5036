// `shatter inspect` and `shatter convert` end to end: exit codes, reports, JSON, outputs.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

using test::quoted;

TEST(CmdInspect, ReportsCountsQualityAndJson) {
  test::TempDir dir;
  TetMesh m = make_box_mesh({.max = Vec3(2, 1, 1), .cells = {4, 2, 2}, .jitter = 0.1});
  ASSERT_OK(write_mesh(dir.file("box.msh"), m));
  const auto text = test::run_command(test::cli_path() + " inspect " + quoted(dir.file("box.msh")));
  EXPECT_EQ(text.status, 0);
  EXPECT_NE(text.output.find("tets        96"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("components  1"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("0 error(s), 0 warning(s)"), std::string::npos) << text.output;

  const auto js = test::run_command(test::cli_path() + " inspect --json " + quoted(dir.file("box.msh")));
  ASSERT_EQ(js.status, 0);
  const auto j = nlohmann::json::parse(js.output);
  EXPECT_EQ(j["nodes"], m.num_nodes());
  EXPECT_EQ(j["tets"], 96);
  EXPECT_NEAR(j["volume"].get<double>(), 2.0, 1e-12);
  EXPECT_EQ(j["components"], 1);
  EXPECT_TRUE(j["valid"].get<bool>());
  EXPECT_GT(j["dihedral_deg"]["min"].get<double>(), 0.0);
}

TEST(CmdInspect, ListsEveryProblemAndExits3) {
  test::TempDir dir;
  // Tet 2 inverted, tet 3 degenerate (flat), node 9 unused.
  std::ofstream(dir.file("bad.mesh")) << "MeshVersionFormatted 2\nDimension 3\nVertices\n9\n"
                                         "0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1 1 1 0\n"
                                         "0.5 0.5 0 0\n2 0 0 0\n0 2 0 0\n5 5 5 0\n"
                                         "Tetrahedra\n3\n1 2 3 4 1\n2 3 5 4 1\n1 2 3 6 1\nEnd\n";
  const auto r = test::run_command(test::cli_path() + " inspect --json " + quoted(dir.file("bad.mesh")));
  EXPECT_EQ(r.status, 3);
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_FALSE(j["valid"].get<bool>());
  EXPECT_EQ(j["problem_counts"]["degenerate_tet"], 1);
  EXPECT_EQ(j["problem_counts"]["unreferenced_node"], 3);
  bool names_tet = false;
  for (const auto& p : j["problems"]) names_tet |= p["message"].get<std::string>().find("tet 3") != std::string::npos;
  EXPECT_TRUE(names_tet) << r.output;
}

// Coordinates at the ends of the double range: the report names what a double cannot hold and
// never prints nan; a mesh scaled by 1e100 has the same angles and aspect ratios as at 1.
TEST(CmdInspect, HugeCoordinatesGiveNoNan) {
  test::TempDir dir;
  TetMesh m = make_box_mesh({.max = Vec3(4, 1, 1), .cells = {4, 1, 1}});
  ASSERT_OK(write_mesh(dir.file("unit.vtu"), m));
  TetMesh big = m, far = m;
  for (Vec3& p : big.positions) p *= 1e100;
  for (Vec3& p : far.positions) p = Vec3(p.x() / 2 - 1, p.y() - 0.5, p.z() - 0.5) * 1e308;  // x in [-1e308, 1e308]
  ASSERT_OK(write_mesh(dir.file("big.vtu"), big));
  ASSERT_OK(write_mesh(dir.file("far.vtu"), far));
  const auto ju = nlohmann::json::parse(
      test::run_command(test::cli_path() + " inspect --json " + quoted(dir.file("unit.vtu"))).output);
  const auto rb = test::run_command(test::cli_path() + " inspect --json " + quoted(dir.file("big.vtu")));
  EXPECT_EQ(rb.status, 0) << rb.output;
  const auto jb = nlohmann::json::parse(rb.output);
  EXPECT_FALSE(jb.contains("non_finite")) << rb.output;
  EXPECT_NEAR(jb["aspect_ratio"]["max"].get<double>(), ju["aspect_ratio"]["max"].get<double>(), 1e-9);
  EXPECT_NEAR(jb["dihedral_deg"]["min"].get<double>(), ju["dihedral_deg"]["min"].get<double>(), 1e-9);
  EXPECT_NEAR(jb["volume"].get<double>(), 4e300, 1e288);
  for (const char* flag : {"", " --json"}) {
    const auto r = test::run_command(test::cli_path() + " inspect" + flag + " " + quoted(dir.file("far.vtu")));
    EXPECT_EQ(r.output.find("nan"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("inf"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(*flag ? "\"non_finite\"" : "not finite"), std::string::npos) << r.output;
  }
}

TEST(CmdInspect, UnreadableFileExits3WithLocation) {
  test::TempDir dir;
  std::ofstream(dir.file("trunc.msh")) << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n";
  const auto r = test::run_command(test::cli_path() + " inspect " + quoted(dir.file("trunc.msh")), true);
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("trunc.msh:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("shatter: error:"), std::string::npos) << r.output;
}

// Only regular files are read: a named pipe would block forever, a device never ends.
TEST(CmdInspect, RefusesWhatIsNotARegularFile) {
  test::TempDir dir;
  ASSERT_EQ(test::run_command("mkfifo " + quoted(dir.file("pipe.msh"))).status, 0);
  std::filesystem::create_directory(dir.file("folder.vtu"));
  std::filesystem::create_symlink("/dev/zero", dir.file("zero.vtk"));
  for (const auto& [file, what] : std::vector<std::pair<std::string, std::string>>{
           {"pipe.msh", "a named pipe"}, {"folder.vtu", "is a directory"}, {"zero.vtk", "a character device"}}) {
    const auto r = test::run_command("timeout 20 " + test::cli_path() + " inspect " + quoted(dir.file(file)), true);
    EXPECT_EQ(r.status, 3) << file << ": " << r.output;
    EXPECT_NE(r.output.find(file), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(what), std::string::npos) << r.output;
  }
}

TEST(CmdConvert, EveryFormatKeepsTheMeshAndIds) {
  test::TempDir dir;
  TetMesh m = make_box_mesh({.cells = {3, 2, 2}, .jitter = 0.1});
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(100 + 3 * i);
  for (Index e = 0; e < m.num_tets(); ++e) m.tet_ids.push_back(1000 + e);
  ASSERT_OK(write_mesh(dir.file("in.msh"), m));
  for (const char* ext : {".vtu", ".vtk", ".mesh", ".inp", ".node", ".msh"}) {
    const std::string out = dir.file(std::string("out") + ext);
    for (const char* binary : {"", " --binary"}) {
      const auto r = test::run_command(
          test::cli_path() + " convert -q" + binary + " " + quoted(dir.file("in.msh")) + " " + quoted(out), true);
      ASSERT_EQ(r.status, 0) << ext << ": " << r.output;
      auto back = read_mesh(out);
      ASSERT_OK(back);
      EXPECT_EQ(back->mesh.positions, m.positions) << ext;
      EXPECT_EQ(back->mesh.tets, m.tets) << ext;
      if (std::string(ext) != ".mesh") {
        EXPECT_EQ(back->mesh.node_ids, m.node_ids) << ext;
      }
    }
  }
}

TEST(CmdConvert, CompressedVtuBothWays) {
  test::TempDir dir;
  TetMesh m = make_box_mesh({.cells = {3, 2, 2}, .jitter = 0.1});
  ASSERT_OK(write_mesh(dir.file("in.msh"), m));
  auto r = test::run_command(
      test::cli_path() + " convert -q --compress " + quoted(dir.file("in.msh")) + " " + quoted(dir.file("z.vtu")),
      true);
  ASSERT_EQ(r.status, 0) << r.output;
  auto back = read_mesh(dir.file("z.vtu"));
  ASSERT_OK(back);
  EXPECT_EQ(back->format, "vtu binary zlib");
  EXPECT_EQ(back->mesh.positions, m.positions);
  EXPECT_EQ(back->mesh.tets, m.tets);
  // A compressed VTU (here also the fixture VTK itself wrote: appended raw zlib) converts to any format.
  r = test::run_command(test::cli_path() + " convert -q " + quoted(test::data_path("mesh/vtu/vtk_appended_raw.vtu")) +
                            " " + quoted(dir.file("from_vtk.msh")),
                        true);
  ASSERT_EQ(r.status, 0) << r.output;
  // --compress is for .vtu only: a usage error, nothing written.
  r = test::run_command(
      test::cli_path() + " convert --compress " + quoted(dir.file("in.msh")) + " " + quoted(dir.file("z.vtk")), true);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--compress"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file("z.vtk")));
}

TEST(CmdConvert, SurfaceOutputCarriesNodeIds) {
  test::TempDir dir;
  TetMesh m = make_box_mesh({.cells = {2, 2, 2}});
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(7 + i);
  ASSERT_OK(write_mesh(dir.file("in.msh"), m));
  const auto r = test::run_command(
      test::cli_path() + " convert -q --binary " + quoted(dir.file("in.msh")) + " " + quoted(dir.file("skin.ply")),
      true);
  ASSERT_EQ(r.status, 0) << r.output;
  auto s = read_surface(dir.file("skin.ply"));
  ASSERT_OK(s);
  EXPECT_EQ(s->surface.triangles.size(), 2u * 6u * 4u);
  ASSERT_EQ(s->vertex_ids.size(), s->surface.positions.size());
  for (std::size_t v = 0; v < s->vertex_ids.size(); ++v) {
    const FileId id = s->vertex_ids[v];
    ASSERT_GE(id, 7);
    EXPECT_EQ(s->surface.positions[v], m.positions[static_cast<std::size_t>(id - 7)]);
  }
}

TEST(CmdConvert, BadInputsAndOutputs) {
  test::TempDir dir;
  ASSERT_OK(write_mesh(dir.file("in.vtu"), make_box_mesh({})));
  // Unknown extension: usage error, nothing written.
  auto r = test::run_command(
      test::cli_path() + " convert " + quoted(dir.file("in.vtu")) + " " + quoted(dir.file("x.xyz")), true);
  EXPECT_EQ(r.status, 2);
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.xyz")));
  // Missing input: bad input.
  r = test::run_command(test::cli_path() + " convert " + quoted(dir.file("none.msh")) + " " + quoted(dir.file("y.vtu")),
                        true);
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("none.msh"), std::string::npos);
  // Unwritable output folder: output error, and an existing file stays as it was.
  r = test::run_command(
      test::cli_path() + " convert " + quoted(dir.file("in.vtu")) + " " + quoted(dir.file("no/such/dir/out.msh")),
      true);
  EXPECT_EQ(r.status, 4) << r.output;
  std::ofstream(dir.file("keep.msh")) << "old";
  std::ofstream(dir.file("bad.vtu")) << "<VTKFile";
  r = test::run_command(
      test::cli_path() + " convert " + quoted(dir.file("bad.vtu")) + " " + quoted(dir.file("keep.msh")), true);
  EXPECT_EQ(r.status, 3);
  std::ifstream in(dir.file("keep.msh"));
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content, "old");
}

// TetGen's two files are replaced together: when the .ele cannot be written, the old .node stays
// (a new .node beside an old .ele would be another mesh). The same through `mesh -o`.
TEST(CmdConvert, TetgenPairReplacedTogether) {
  test::TempDir dir;
  ASSERT_OK(write_mesh(dir.file("in.msh"), make_box_mesh({.cells = {2, 2, 2}})));
  std::ofstream(dir.file("out.node")) << "old node";
  std::filesystem::create_directory(dir.file("out.ele"));
  auto r = test::run_command(
      test::cli_path() + " convert " + quoted(dir.file("in.msh")) + " " + quoted(dir.file("out.node")), true);
  EXPECT_EQ(r.status, 4) << r.output;
  EXPECT_NE(r.output.find("out.ele"), std::string::npos) << r.output;
  std::ifstream in(dir.file("out.node"));
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()), "old node");
  r = test::run_command(
      test::cli_path() + " mesh --primitive box --size 1 1 1 --tets 50 -o " + quoted(dir.file("out.node")), true);
  EXPECT_EQ(r.status, 4) << r.output;
  std::ifstream in2(dir.file("out.node"));
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(in2)), std::istreambuf_iterator<char>()), "old node");
  for (const auto& e : std::filesystem::directory_iterator(dir.file("")))
    EXPECT_NE(e.path().filename().string().rfind(".shatter-", 0), 0u) << e.path();
}

}  // namespace
}  // namespace shatter
