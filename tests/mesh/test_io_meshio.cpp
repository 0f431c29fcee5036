// Cross-checks with meshio (an independent implementation) run as an external program:
// (a) meshio writes each format and we read it; (b) we write each format and meshio reads it.
// Skipped when /usr/bin/python3 cannot import meshio.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "shatter/core/file_io.h"
#include "shatter/mesh/generate.h"
#include "shatter/mesh/io/mesh_io.h"
#include "support/test_support.h"

namespace shatter {
namespace {

const std::string kPython = "/usr/bin/python3";

std::string script() { return std::string(SHATTER_SOURCE_DIR) + "/tests/tools/meshio_check.py"; }

bool have_meshio() {
  static const bool ok = test::run_command(kPython + " -c 'import meshio' 2>/dev/null").status == 0;
  return ok;
}

TetMesh meshio_sample() {
  return make_box_mesh(
      {.min = Vec3(-0.5, 0.1, 2), .max = Vec3(0.7, 1.3, 2.5), .cells = {2, 2, 1}, .jitter = 0.2, .seed = 5});
}

void expect_matches(const TetMesh& m, const nlohmann::json& j, double tolerance) {
  ASSERT_EQ(j.at("points").size(), m.positions.size());
  ASSERT_EQ(j.at("tets").size(), m.tets.size());
  for (std::size_t i = 0; i < m.positions.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(j["points"][i][k].get<double>(), m.positions[i][k], tolerance) << "point " << i;
  for (std::size_t e = 0; e < m.tets.size(); ++e)
    for (int k = 0; k < 4; ++k) EXPECT_EQ(j["tets"][e][k].get<Index>(), m.tets[e][k]) << "tet " << e;
}

struct Case {
  const char* meshio_format;
  const char* file;
  bool binary;
  double tolerance;  // meshio writes ASCII VTU with 12 digits, MEDIT/INP/TetGen with 16-17
};
const Case kCases[] = {
    {"gmsh22", "a22.msh", false, 0},   {"gmsh22", "b22.msh", true, 0},    {"gmsh", "a41.msh", false, 0},
    {"gmsh", "b41.msh", true, 0},      {"vtk", "a.vtk", false, 0},        {"vtk", "b.vtk", true, 0},
    {"vtu", "a.vtu", false, 1e-11},    {"vtu", "b.vtu", true, 0},         {"vtu_default", "c.vtu", true, 0},
    {"medit", "a.mesh", false, 1e-15}, {"abaqus", "a.inp", false, 1e-15}, {"tetgen", "a.node", false, 1e-15},
};

TEST(Meshio, WeReadWhatMeshioWrites) {
  SHATTER_REQUIRE_TOOL(have_meshio(), "/usr/bin/python3 cannot import meshio");
  test::TempDir dir;
  const TetMesh m = meshio_sample();
  nlohmann::json in;
  for (const Vec3& p : m.positions) in["points"].push_back({p.x(), p.y(), p.z()});
  for (const TetIndices& t : m.tets) in["tets"].push_back({t[0], t[1], t[2], t[3]});
  ASSERT_OK(write_file_atomic(dir.file("in.json"), in.dump()));
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.file);
    const std::string path = dir.file(c.file);
    const auto run = test::run_command(kPython + " " + script() + " write " + dir.file("in.json") + " " + path + " " +
                                           c.meshio_format + (c.binary ? " binary" : ""),
                                       true);
    ASSERT_EQ(run.status, 0) << run.output;
    auto r = read_mesh(path);
    ASSERT_OK(r);
    ASSERT_EQ(r->mesh.num_nodes(), m.num_nodes());
    ASSERT_EQ(r->mesh.tets, m.tets);
    for (Index i = 0; i < m.num_nodes(); ++i)
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(r->mesh.positions[i][k], m.positions[i][k], c.tolerance) << i;
  }
}

TEST(Meshio, MeshioReadsWhatWeWrite) {
  SHATTER_REQUIRE_TOOL(have_meshio(), "/usr/bin/python3 cannot import meshio");
  test::TempDir dir;
  const TetMesh m = meshio_sample();
  struct Written {
    std::string file;
    bool binary = false;
    bool compress = false;
  };
  for (const auto& [file, binary, compress] : std::vector<Written>{{"a.msh", false},
                                                                   {"b.msh", true},
                                                                   {"a.vtk", false},
                                                                   {"b.vtk", true},
                                                                   {"a.vtu", false},
                                                                   {"b.vtu", true},
                                                                   {"c.vtu", true, true},
                                                                   {"a.mesh", false},
                                                                   {"a.inp", false},
                                                                   {"a.node", false}}) {
    SCOPED_TRACE(file);
    const std::string path = dir.file(file);
    ASSERT_OK(write_mesh(path, m, {.binary = binary, .compress = compress}));
    const auto run = test::run_command(kPython + " " + script() + " read " + path);
    ASSERT_EQ(run.status, 0) << run.output;
    const auto j = nlohmann::json::parse(run.output, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << run.output.substr(0, 400);
    expect_matches(m, j, 0.0);
  }
}

}  // namespace
}  // namespace shatter
