// Shape JSON: primitives and CSG parse into the expected distance functions; a corpus of bad
// files each gives its expected message and JSON path.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "shatter/meshing/shape_json.h"
#include "shatter/meshing/stuffing.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TEST(ShapeJson, PrimitivesAndTransforms) {
  auto r = parse_shape_json(R"({"name": "s", "edge_length": 0.01, "tets": 500,
    "shape": {"type": "sphere", "radius": 0.1, "translate": [1, 0, 0], "scale": 2}})",
                            "s.json");
  ASSERT_OK(r);
  EXPECT_EQ(r->name, "s");
  EXPECT_EQ(r->edge_length, 0.01);
  EXPECT_EQ(r->target_tets, 500);
  EXPECT_NEAR(r->sdf(Vec3(1, 0, 0)), -0.2, 1e-12);
  EXPECT_NEAR(r->sdf(Vec3(1.5, 0, 0)), 0.3, 1e-12);
  EXPECT_NEAR(*r->sdf.analytic_volume(), 4.0 / 3.0 * std::numbers::pi * 0.008, 1e-12);

  auto b = parse_shape_json(R"({"shape": {"type": "box", "size": [0.4, 0.2, 0.2], "rotate": [0, 90, 0]}})", "b.json");
  ASSERT_OK(b);
  EXPECT_NEAR(b->sdf(Vec3(0, 0, 0.19)), -0.01, 1e-12);  // rotated: the long side is along z
  EXPECT_NEAR(b->sdf(Vec3(0.15, 0, 0)), 0.05, 1e-12);
}

TEST(ShapeJson, CsgOperations) {
  auto r = parse_shape_json(R"({"shape": {"type": "difference", "children": [
      {"type": "box", "size": [1, 1, 1]},
      {"type": "cylinder", "radius": 0.2, "height": 2}]}})",
                            "d.json");
  ASSERT_OK(r);
  EXPECT_GT(r->sdf(Vec3(0, 0, 0)), 0.0);      // in the hole
  EXPECT_LT(r->sdf(Vec3(0.4, 0, 0.4)), 0.0);  // in the wall
  auto u = parse_shape_json(R"({"shape": {"type": "smooth_union", "blend": 0.1, "children": [
      {"type": "sphere", "radius": 0.5}, {"type": "sphere", "radius": 0.5, "translate": [0.9, 0, 0]}]}})",
                            "u.json");
  ASSERT_OK(u);
  // Smooth union fills the neck between the spheres: below the plain minimum there.
  const Vec3 neck(0.45, 0.2, 0);
  EXPECT_LT(u->sdf(neck), std::min(neck.norm() - 0.5, (neck - Vec3(0.9, 0, 0)).norm() - 0.5));
  auto v = parse_shape_json(R"({"shape": {"type": "revolution", "profile": [[0, 0], [0.1, 0], [0.1, 0.2], [0, 0.2]]}})",
                            "v.json");
  ASSERT_OK(v);
  EXPECT_NEAR(*v->sdf.analytic_volume(), std::numbers::pi * 0.01 * 0.2, 1e-12);
  EXPECT_NEAR(v->sdf(Vec3(0, 0.1, 0.05)), -0.05, 1e-12);
  auto e = parse_shape_json(R"({"shape": {"type": "extrusion", "depth": 0.5, "polygon": [[0, 0], [1, 0], [0, 1]]}})",
                            "e.json");
  ASSERT_OK(e);
  EXPECT_NEAR(*e->sdf.analytic_volume(), 0.25, 1e-12);
}

TEST(ShapeJson, MeshedRevolutionMatchesPappus) {
  // A thin-walled cup: revolution of a closed profile polygon.
  auto r = parse_shape_json(R"({"shape": {"type": "revolution", "profile":
      [[0, 0], [0.05, 0], [0.05, 0.08], [0.04, 0.08], [0.04, 0.01], [0, 0.01]]}})",
                            "cup.json");
  ASSERT_OK(r);
  auto m = stuff_tets(r->sdf, {.edge_length = 0.0025});
  ASSERT_OK(m);
  const double exact = *r->sdf.analytic_volume();
  EXPECT_NEAR(total_volume(*m), exact, 0.03 * exact);
}

struct BadCase {
  const char* json;
  const char* field;
  const char* message_part;
};

TEST(ShapeJson, BadFilesNameThePath) {
  const BadCase cases[] = {
      {R"({"shape": {"type": "sphere"}})", "shape.radius", "missing"},
      {R"({"shape": {"type": "sphere", "radius": -1}})", "shape.radius", "> 0"},
      {R"({"shape": {"type": "sphere", "radius": "big"}})", "shape.radius", "expected a number"},
      {R"({"shape": {"type": "sphere", "radius": 1, "radus": 2}})", "shape.radus", "unknown key"},
      {R"({"shape": {"type": "blob"}})", "shape.type", "unknown shape type"},
      {R"({"shape": {"radius": 1}})", "shape.type", "missing"},
      {R"({"shape": {"type": "union", "children": [{"type": "sphere", "radius": 1}, {"type": "sphere", "radius": 1},
         {"type": "cylinder", "radius": 0, "height": 1}]}})",
       "shape.children[2].radius", "> 0"},
      {R"({"shape": {"type": "union", "children": []}})", "shape.children", "empty"},
      {R"({"shape": {"type": "box", "size": [1, 2]}})", "shape.size", "3 numbers"},
      {R"({"shape": {"type": "box", "size": [1, 2, 0]}})", "shape.size[2]", "> 0"},
      {R"({"shape": {"type": "torus", "major_radius": 1, "minor_radius": 2}})", "shape.minor_radius",
       "minor_radius < major_radius"},
      {R"({"shape": {"type": "revolution", "profile": [[0, 0], [1, 0]]}})", "shape.profile", "at least 3"},
      {R"({"shape": {"type": "revolution", "profile": [[0, 0], [-1, 0], [0, 1]]}})", "shape.profile[1]", "r >= 0"},
      {R"({"shape": {"type": "extrusion", "depth": 1, "polygon": [[0, 0], [1, 1], [2, 2]]}})", "shape.polygon",
       "non-zero area"},
      {R"({"shape": {"type": "smooth_union", "children": [{"type": "sphere", "radius": 1}]}})", "shape.blend",
       "missing"},
      {R"({"shape": {"type": "sphere", "radius": 1, "translate": [0, "x", 0]}})", "shape.translate[1]", "number"},
      {R"({"shape": {"type": "surface", "file": "a.obj"}})", "shape.file", "no surface reader"},
      {R"({"shap": {}})", "shap", "unknown key"},
      {R"({"name": "x"})", "shape", "missing"},
      {R"({"shape": {"type": "sphere", "radius": 1}, "tets": -5})", "tets", "integer > 0"},
      {R"({"shape": {"type": "sphere", "radius": 1}, "grading": -0.5})", "grading", "number >= 0"},
      {R"({"shape": {"type": "sphere", "radius": 1}, "grading": "a"})", "grading", "number >= 0"},
      {R"([1, 2])", "", "JSON object"},
  };
  for (const BadCase& c : cases) {
    auto r = parse_shape_json(c.json, "bad.json");
    ASSERT_FALSE(r.ok()) << c.json;
    EXPECT_EQ(r.error().field, c.field) << c.json;
    EXPECT_EQ(r.error().file, "bad.json");
    EXPECT_NE(r.error().message.find(c.message_part), std::string::npos) << r.error().to_string();
  }
  auto syntax = parse_shape_json("{\"shape\": {", "broken.json");
  ASSERT_FALSE(syntax.ok());
  EXPECT_NE(syntax.error().to_string().find("broken.json: invalid JSON"), std::string::npos)
      << syntax.error().to_string();
  auto missing = read_shape_json("/nonexistent/shape.json");
  ASSERT_FALSE(missing.ok());
}

}  // namespace
}  // namespace shatter
