// glTF animations of runs: the file decoded back gives the simulated world positions at every
// frame (node keys, scale keys for births and removals, morph targets for dents), and the Khronos
// validator finds no error in it.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "shatter/scene/gltf.h"
#include "shatter/scene/scene.h"
#include "support/test_support.h"

namespace shatter {
namespace {

using Json = nlohmann::json;
using test::TempDir;

// A .glb split into its JSON and binary chunks, with float accessors read back.
struct Glb {
  Json json;
  std::string bin;

  static Glb parse(const std::string& bytes) {
    auto u32 = [&](std::size_t at) {
      std::uint32_t v = 0;
      std::memcpy(&v, bytes.data() + at, 4);
      return v;
    };
    Glb g;
    EXPECT_EQ(u32(0), 0x46546C67U);
    EXPECT_EQ(u32(4), 2U);
    EXPECT_EQ(u32(8), bytes.size());
    const std::uint32_t json_len = u32(12);
    EXPECT_EQ(u32(16), 0x4E4F534AU);
    g.json = Json::parse(bytes.substr(20, json_len));
    if (20 + json_len < bytes.size()) {
      EXPECT_EQ(u32(24 + json_len), 0x004E4942U);
      g.bin = bytes.substr(28 + json_len, u32(20 + json_len));
    }
    return g;
  }
  [[nodiscard]] std::vector<float> floats(int accessor) const {
    const Json& a = json["accessors"][accessor];
    const Json& v = json["bufferViews"][a["bufferView"].get<int>()];
    const std::map<std::string, int> width{{"SCALAR", 1}, {"VEC3", 3}, {"VEC4", 4}};
    std::vector<float> out(a["count"].get<std::size_t>() * static_cast<std::size_t>(width.at(a["type"])));
    std::memcpy(out.data(), bin.data() + v["byteOffset"].get<std::size_t>(), out.size() * sizeof(float));
    return out;
  }
  // The channel of a node and path: its output values.
  [[nodiscard]] std::vector<float> channel(int node, const std::string& path) const {
    const Json& anim = json["animations"][0];
    for (const Json& c : anim["channels"])
      if (c["target"]["node"] == node && c["target"]["path"] == path)
        return floats(anim["samplers"][c["sampler"].get<int>()]["output"].get<int>());
    return {};
  }
};

// The world positions of a node's base vertices at frame f: morph, then scale, rotate, translate.
std::vector<Vec3> node_positions(const Glb& g, int node, std::size_t f) {
  const int mesh = g.json["nodes"][node]["mesh"].get<int>();
  const Json& prim = g.json["meshes"][mesh]["primitives"][0];
  const std::vector<float> base = g.floats(prim["attributes"]["POSITION"].get<int>());
  std::vector<Vec3> p(base.size() / 3);
  for (std::size_t i = 0; i < p.size(); ++i) p[i] = Vec3(base[3 * i], base[3 * i + 1], base[3 * i + 2]);
  if (prim.contains("targets")) {
    const std::vector<float> w = g.channel(node, "weights");
    const std::size_t n = prim["targets"].size();
    for (std::size_t k = 0; k < n; ++k) {
      const double wk = w[f * n + k];
      if (wk == 0) continue;
      const std::vector<float> d = g.floats(prim["targets"][k]["POSITION"].get<int>());
      for (std::size_t i = 0; i < p.size(); ++i) p[i] += wk * Vec3(d[3 * i], d[3 * i + 1], d[3 * i + 2]);
    }
  }
  const std::vector<float> t = g.channel(node, "translation"), r = g.channel(node, "rotation"),
                           s = g.channel(node, "scale");
  const Quat q(r[4 * f + 3], r[4 * f], r[4 * f + 1], r[4 * f + 2]);
  const Vec3 tr(t[3 * f], t[3 * f + 1], t[3 * f + 2]);
  for (Vec3& x : p) x = tr + q.normalized() * (s[3 * f] * x);
  return p;
}

// Record a scene step by step, keeping the world's surfaces at each frame.
struct Recorded {
  std::string glb;
  std::vector<std::map<Index, BodySurface>> surfaces;  // per frame, per body slot
};
Recorded record(const std::string& scene_file, double seconds, int every) {
  auto scene = read_scene(std::string(SHATTER_SOURCE_DIR) + "/scenes/" + scene_file);
  EXPECT_TRUE(scene.ok());
  auto built = build_scene(*scene);
  EXPECT_TRUE(built.ok());
  World& w = *built->world;
  GltfRecorder rec;
  Recorded out;
  std::size_t next_action = 0;
  int step = 0;
  auto frame = [&] {
    rec.add_frame(w);
    std::map<Index, BodySurface> s;
    for (Index slot = 0; slot < w.body_count(); ++slot)
      if (w.model(w.body_id(slot)) && !w.removed(w.body_id(slot))) s[slot] = w.surface(w.body_id(slot));
    out.surfaces.push_back(std::move(s));
  };
  frame();
  while (w.time() + 1e-9 < seconds) {
    EXPECT_TRUE(apply_due_actions(*scene, *built, next_action).ok());
    w.step();
    if (++step % every == 0) frame();
  }
  EXPECT_EQ(rec.frames(), out.surfaces.size());
  out.glb = rec.glb();
  return out;
}

// Every node, at every frame it is shown, puts its vertices where the world had them.
void expect_matches_world(const Recorded& r, bool expect_morphs, bool expect_births) {
  const Glb g = Glb::parse(r.glb);
  int morph_nodes = 0, born = 0, checked = 0;
  for (std::size_t n = 0; n < g.json["nodes"].size(); ++n) {
    const Json& node = g.json["nodes"][n];
    if (!node.contains("extras")) continue;  // the ground
    const Index slot = node["extras"]["body"].get<Index>();
    const std::vector<float> scale = g.channel(static_cast<int>(n), "scale");
    if (g.json["meshes"][node["mesh"].get<int>()]["primitives"][0].contains("targets")) ++morph_nodes;
    if (scale[0] == 0) ++born;
    for (std::size_t f = 0; f < r.surfaces.size(); ++f) {
      if (scale[3 * f] == 0) continue;
      const auto it = r.surfaces[f].find(slot);
      ASSERT_NE(it, r.surfaces[f].end()) << "node " << n << " shown at frame " << f << " when its body is not";
      const std::vector<Vec3> p = node_positions(g, static_cast<int>(n), f);
      ASSERT_EQ(p.size(), it->second.positions.size());
      double worst = 0;
      for (std::size_t i = 0; i < p.size(); ++i) worst = std::max(worst, (p[i] - it->second.positions[i]).norm());
      EXPECT_LT(worst, 2e-5) << "node " << n << " frame " << f;  // float precision, m
      ++checked;
    }
  }
  std::printf("%zu nodes, %d with morph targets, %d born later, %d node frames checked, %zu bytes\n",
              g.json["nodes"].size(), morph_nodes, born, checked, r.glb.size());
  if (expect_morphs) {
    EXPECT_GT(morph_nodes, 0);
  }
  if (expect_births) {
    EXPECT_GT(born, 0);
  }
  EXPECT_GT(checked, 10);
}

TEST(Gltf, TheVaseDropDecodesToTheWorldsPositions) {
  expect_matches_world(record("vase_drop.json", 1.0, 4), false, true);
}

TEST(Gltf, TheTeddysDentsAreMorphTargets) { expect_matches_world(record("teddy_drops.json", 2.5, 6), true, false); }

// Deformable bodies change shape every frame: a morph target per frame they moved in.
TEST(Gltf, DeformableBodiesAreMorphTargets) { expect_matches_world(record("soft_landing.json", 0.6, 4), true, true); }

TEST(Gltf, AnEmptyRecordingIsAValidFile) {
  GltfRecorder rec;
  const Glb g = Glb::parse(rec.glb());
  EXPECT_EQ(g.json["asset"]["version"], "2.0");
}

bool have_validator() {
  return test::run_command("node -e 'require(\"" + std::string(SHATTER_SOURCE_DIR) +
                           "/tests/tools/gltf/node_modules/gltf-validator\")' >/dev/null 2>&1")
             .status == 0;
}

TEST(Gltf, TheKhronosValidatorFindsNoErrors) {
  SHATTER_REQUIRE_TOOL(have_validator(), "the glTF validator (scripts/setup.sh --test)");
  TempDir dir;
  for (const auto& [scene, seconds] : {std::pair{"vase_drop.json", 1.0}, std::pair{"teddy_drops.json", 2.5},
                                       std::pair{"block_on_block.json", 1.0}, std::pair{"soft_landing.json", 1.0}}) {
    const std::string path = dir.file(std::string(scene) + ".glb");
    {
      std::ofstream out(path, std::ios::binary);
      out << record(scene, seconds, 4).glb;
    }
    auto r = test::run_command("node " + std::string(SHATTER_SOURCE_DIR) + "/tests/tools/gltf/validate.js " + path);
    EXPECT_EQ(r.status, 0) << scene << ":\n" << r.output;
    const Json report = Json::parse(r.output);
    std::printf("%s: %d errors, %d warnings, %d infos\n", scene, report["issues"]["numErrors"].get<int>(),
                report["issues"]["numWarnings"].get<int>(), report["issues"]["numInfos"].get<int>());
    EXPECT_EQ(report["issues"]["numErrors"], 0) << r.output;
    EXPECT_EQ(report["issues"]["numWarnings"], 0) << r.output;
  }
}

TEST(Gltf, SceneRunsWriteItWhenAsked) {
  auto scene = read_scene(std::string(SHATTER_SOURCE_DIR) + "/scenes/vase_drop.json");
  ASSERT_OK(scene);
  scene->output.gltf = true;
  scene->output.vtu = false;
  scene->output.surfaces.clear();
  TempDir dir;
  RunOptions options;
  options.out_dir = dir.path().string();
  options.duration = 0.5;  // the vase lands at 0.42 s and breaks
  auto run = run_scene(*scene, options);
  ASSERT_OK(run);
  std::ifstream in(dir.file("scene.glb"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const Glb g = Glb::parse(bytes);
  EXPECT_FALSE(std::filesystem::exists(dir.file("scene.pvd")));  // the series was turned off
  // The file agrees with the summary: a body per scene body and fragment born, and an animation
  // as long as the run.
  std::ifstream sin(dir.file("summary.json"));
  const Json summary = Json::parse(sin);
  std::set<int> bodies;
  for (const Json& node : g.json["nodes"])
    if (node.contains("extras")) bodies.insert(node["extras"]["body"].get<int>());
  EXPECT_EQ(bodies.size(), scene->bodies.size() + summary["fragments_born"].get<std::size_t>());
  EXPECT_GT(summary["fragments_born"].get<int>(), 0);
  const Json& times = g.json["accessors"][g.json["animations"][0]["samplers"][0]["input"].get<int>()];
  EXPECT_NEAR(times["max"][0].get<double>(), summary["simulated_time"].get<double>(), 1e-6);
  EXPECT_EQ(times["count"].get<std::size_t>(), 16U);  // 30 frames a second over 0.5 s, and t = 0
  // Parsing the key.
  auto bad = parse_scene(R"({"bodies": [{"mesh": "v.msh", "material": "glass"}], "output": {"gltf": 1}})", "s.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().to_string().find("output.gltf"), std::string::npos) << bad.error().to_string();
}

}  // namespace
}  // namespace shatter
