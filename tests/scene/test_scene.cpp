// Scene files and `shatter run`: every mistake named with its JSON path, the bundled scenes run,
// the same hash on any thread count, outputs that read back (meshio) and stay complete when a run
// is stopped.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "shatter/core/parallel.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/scene/scene.h"
#include "support/test_support.h"

namespace shatter {
namespace {

std::string scenes_dir() { return std::string(SHATTER_SOURCE_DIR) + "/scenes"; }

// A valid scene with one vase, `extra` spliced into the top-level object and `body_extra` into the
// body's.
std::string scene_text(const std::string& extra = "", const std::string& body_extra = "") {
  return R"({"name": "t", "duration": 0.1, )" + extra +
         R"( "bodies": [{"name": "vase", "mesh": "../assets/meshes/vase.msh", "material": "porcelain", "height": 0.5)" +
         body_extra + "}]}";
}

Result<Scene> parse(const std::string& text) { return parse_scene(text, "scene.json", scenes_dir()); }

TEST(SceneFile, ParsesAValidScene) {
  auto s = parse(scene_text(
      R"("world": {"time_step": 0.01, "substeps": 4, "gravity": [0, -10, 0], "seed": 42, "contact_reuse": 0.002}, "ground": {"height": 0.1, "friction": 0.3}, "impact": {"collision_radius": 0.4}, "materials": {"china": {"preset": "porcelain", "tensile_strength": 30e6, "weibull_modulus": 8}}, "actions": [{"time": 0.05, "type": "strike", "body": "vase", "impulse": [1, 0, 0], "speed": 5}],)",
      R"(, "rotation": {"axis": [0, 0, 1], "degrees": 90}, "velocity": [1, 0, 0], "impact": {"max_plastic_strain": 0.5})"));
  ASSERT_OK(s);
  EXPECT_EQ(s->name, "t");
  EXPECT_EQ(s->world.substeps, 4);
  EXPECT_DOUBLE_EQ(s->world.time_step, 0.01);
  EXPECT_EQ(s->world.seed, 42U);
  EXPECT_DOUBLE_EQ(s->world.contact_reuse_distance, 0.002);
  EXPECT_DOUBLE_EQ(s->ground_height, 0.1);
  ASSERT_EQ(s->bodies.size(), 1U);
  EXPECT_DOUBLE_EQ(s->bodies[0].impact.collision_radius, 0.4);                        // the scene's
  EXPECT_DOUBLE_EQ(s->bodies[0].impact.fracture.plasticity.max_plastic_strain, 0.5);  // the body's
  EXPECT_NEAR((s->bodies[0].rotation * Vec3::UnitX() - Vec3::UnitY()).norm(), 0, 1e-15);
  ASSERT_EQ(s->actions.size(), 1U);
  EXPECT_EQ(s->actions[0].kind, SceneAction::Kind::strike);
  EXPECT_FALSE(s->actions[0].point_given);
}

TEST(SceneFile, EveryMistakeIsNamed) {
  struct Bad {
    std::string text;
    std::string expected;  // a part of the message
  };
  const Bad cases[] = {
      {"{", "scene.json:1: invalid JSON"},
      {"[]", "object"},
      {R"({"bodies": []})", "bodies: expected at least one body"},
      {R"({"name": "x"})", "bodies: missing"},
      {scene_text(R"("bodys": 1,)"), "bodys: unknown key"},
      {scene_text(R"("duration": -1,)").replace(scene_text().find("\"duration\": 0.1, "), 0, ""), "duration"},
      {scene_text(R"("world": {"substeps": 0},)"), "world.substeps: expected an integer in [1, 1000]"},
      {scene_text(R"("world": {"time_step": "fast"},)"), "world.time_step"},
      {scene_text(R"("world": {"contact_mode": "magic"},)"), "world.contact_mode"},
      {scene_text(R"("world": {"seed": -1},)"), "world.seed: expected an integer >= 0"},
      {scene_text(R"("world": {"contact_reuse": -0.001},)"), "world.contact_reuse: expected a distance in [0, 0.1] m"},
      {scene_text(R"("world": {"seed": 1.5},)"), "world.seed"},
      {scene_text(R"("materials": {"m": {"preset": "glass", "weibull_modulus": 0.1}},)"),
       "materials.m.weibull_modulus: material 'glass (modified)': Weibull modulus must be 0"},
      {scene_text(R"("ground": 3,)"), "ground: expected true, false"},
      {scene_text(R"("impact": {"hold": "glue"},)"), "impact.hold"},
      {scene_text("", R"(, "material": "unobtainium")"), "bodies[0].material"},
      {scene_text("", R"(, "shape": "x.json")"), "bodies[0]: give either \"mesh\" or \"shape\""},
      {scene_text("", R"(, "rotation": {"axis": [0, 0, 0], "degrees": 3})"), "bodies[0].rotation.axis"},
      {scene_text("", R"(, "type": "floating")"), "bodies[0].type"},
      {scene_text("", R"(, "heigth": 1)"), "did you mean \"height\""},
      {scene_text("", R"(, "friction": -1)"), "bodies[0].friction"},
      {scene_text("", R"(, "impact": {"max_fragments": 0})"), "bodies[0].impact.max_fragments"},
      {scene_text("", R"(, "deformable": "yes")"), "bodies[0].deformable: expected true, false or an object"},
      {scene_text("", R"(, "deformable": {"substeps": 0})"), "bodies[0].deformable.substeps: expected an integer"},
      {scene_text("", R"(, "deformable": {"stiffness_damping": -1})"), "bodies[0].deformable.stiffness_damping"},
      {scene_text("", R"(, "deformable": {"damping": 1})"), "bodies[0].deformable.damping: unknown key"},
      {scene_text("", R"(, "type": "static", "deformable": true)"),
       "bodies[0].deformable: only a dynamic body can be deformable"},
      {scene_text(R"("actions": [{"time": 0, "type": "strike", "body": "vsae", "impulse": [1, 0, 0], "speed": 1}],)"),
       "actions[0].body: no body is named \"vsae\""},
      {scene_text(R"("actions": [{"time": 0, "type": "strike", "body": "vase", "impulse": [1, 0, 0]}],)"),
       "actions[0].speed: missing"},
      {scene_text(R"("actions": [{"time": 0, "type": "press", "body": "vase", "force": [1, 0, 0]}],)"),
       "actions[0].duration: missing"},
      {scene_text(R"("actions": [{"time": 0, "type": "press", "body": "vase", "impulse": [1, 0, 0], "duration": 1}],)"),
       "actions[0].impulse: a press takes \"force\""},
      {scene_text(R"("actions": [{"time": 0, "type": "kick", "body": "vase", "impulse": [1, 0, 0]}],)"),
       "actions[0].type"},
      {scene_text(R"("output": {"frames_per_second": -2},)"), "output.frames_per_second"},
      {R"({"bodies": [{"mesh": "a.msh", "material": "glass", "name": "a"}, {"mesh": "a.msh", "material": "glass", "name": "a"}]})",
       "bodies[1].name: a second body named \"a\""},
  };
  for (const Bad& c : cases) {
    auto s = parse(c.text);
    ASSERT_FALSE(s.ok()) << c.text;
    const std::string message = s.error().to_string();
    EXPECT_NE(message.find("scene.json"), std::string::npos) << message;
    EXPECT_NE(message.find(c.expected), std::string::npos) << "expected \"" << c.expected << "\" in: " << message;
  }
  // Files that do not exist are named when the scene is built.
  auto missing = parse(scene_text().replace(scene_text().find("vase.msh"), 8, "nope.msh"));
  ASSERT_OK(missing);
  auto built = build_scene(*missing);
  ASSERT_FALSE(built.ok());
  EXPECT_NE(built.error().to_string().find("body \"vase\""), std::string::npos) << built.error().to_string();
  EXPECT_NE(built.error().to_string().find("nope.msh"), std::string::npos);
}

TEST(SceneRun, EveryBundledSceneRuns) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(scenes_dir())) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    auto scene = read_scene(entry.path().string());
    ASSERT_OK(scene);
    test::TempDir dir;
    auto run = run_scene(*scene, {.out_dir = dir.path().string(), .duration = 0.1});
    ASSERT_OK(run);
    EXPECT_EQ(run->steps, 6) << entry.path();
    EXPECT_GE(run->bodies, 1);
  }
  EXPECT_GE(count, 3);
}

// The large scenes are too big to build in CI; their files must still read (keys, paths, values).
TEST(SceneRun, EveryLargeSceneReads) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(scenes_dir() + "/large")) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    auto scene = read_scene(entry.path().string());
    ASSERT_OK(scene);
  }
  EXPECT_GE(count, 4);
}

std::uint64_t vase_hash(int threads) {
  const int saved = num_threads();
  set_num_threads(threads);
  auto scene = read_scene(scenes_dir() + "/vase_drop.json");
  EXPECT_TRUE(scene.ok());
  auto run = run_scene(*scene, {});
  set_num_threads(saved);
  EXPECT_TRUE(run.ok());
  EXPECT_GE(run->fragments, 2);  // it broke
  return run->state_hash;
}

TEST(SceneRun, SameHashOnAnyThreadCount) { EXPECT_EQ(vase_hash(1), vase_hash(2)); }

// Outputs: the frames and the series read back with meshio; events and summary parse; a run
// stopped early leaves them complete.
TEST(SceneRun, OutputsReadBackAndSurviveAStop) {
  auto scene = read_scene(scenes_dir() + "/vase_drop.json");
  ASSERT_OK(scene);
  test::TempDir dir;
  std::atomic<bool> stop{false};
  RunOptions options{.out_dir = dir.path().string(), .stop = &stop};
  options.progress = [&](double t, std::int64_t, Index) {
    if (t > 0.9) stop = true;  // after the impact
  };
  auto run = run_scene(*scene, options);
  ASSERT_OK(run);
  EXPECT_TRUE(run->stopped);
  EXPECT_LT(run->simulated_time, 1.0);
  std::ifstream summary_file(dir.path() / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  EXPECT_TRUE(summary.at("stopped").get<bool>());
  EXPECT_EQ(summary.at("steps").get<std::int64_t>(), run->steps);
  EXPECT_EQ(summary.at("bodies").size(), static_cast<std::size_t>(run->bodies));
  std::ifstream events_file(dir.path() / "events.jsonl");
  std::string line;
  int impacts = 0;
  while (std::getline(events_file, line)) {
    const nlohmann::json e = nlohmann::json::parse(line);
    impacts += e.at("type") == "impact";
    if (e.at("type") == "impact") {
      EXPECT_GE(e.at("newton_iterations").get<int>(), 1) << line;
      EXPECT_GE(e.at("load_fraction").get<double>(), 0.0) << line;
      EXPECT_LE(e.at("load_fraction").get<double>(), 1.0) << line;
    }
    EXPECT_LE(e.at("time").get<double>(), run->simulated_time + 1e-12);
  }
  EXPECT_EQ(impacts, run->impacts);
  // The series lists only frames that exist.
  std::ifstream pvd_file(dir.path() / "scene.pvd");
  std::stringstream pvd;
  pvd << pvd_file.rdbuf();
  int frames = 0;
  for (std::size_t at = pvd.str().find("file=\""); at != std::string::npos; at = pvd.str().find("file=\"", at + 1)) {
    const std::size_t end = pvd.str().find('"', at + 6);
    EXPECT_TRUE(std::filesystem::exists(dir.path() / pvd.str().substr(at + 6, end - at - 6)));
    ++frames;
  }
  EXPECT_GE(frames, 25);
  // Surfaces at every frame, with crack faces once the vase broke.
  auto surface = read_surface((dir.path() / "frames" / "surface_000027.ply").string());
  ASSERT_OK(surface);
  EXPECT_GT(surface->surface.triangles.size(), 1000U);
  std::ifstream ply(dir.path() / "frames" / "surface_000027.ply", std::ios::binary);
  std::string header((std::istreambuf_iterator<char>(ply)), {});
  EXPECT_NE(header.find("property int crack"), std::string::npos);
  // meshio reads the series and the last frame.
  const bool meshio = test::run_command("/usr/bin/python3 -c 'import meshio' 2>/dev/null").status == 0;
  SHATTER_REQUIRE_TOOL(meshio, "/usr/bin/python3 cannot import meshio");
  const std::string py =
      "import meshio,sys,glob\n"
      "fs=sorted(glob.glob(sys.argv[1]+'/frames/*.vtu'))\n"
      "m=meshio.read(fs[-1])\n"
      "assert m.cells_dict['tetra'].shape[0]>0\n"
      "assert 'body' in m.cell_data and 'plastic_strain' in m.cell_data and 'rest' in m.point_data\n"
      // Tension shown in the stress view is the largest principal stress of the same load.
      "ds=m.cell_data['display_stress'][0]; ps=m.cell_data['max_principal'][0]\n"
      "assert ps.max()>0 and (ps[ds>0]==ds[ds>0]).all() and (ps>=ds).all()\n"
      "print(len(fs), m.cells_dict['tetra'].shape[0])\n";
  std::ofstream(dir.path() / "check.py") << py;
  const test::CommandResult r =
      test::run_command("/usr/bin/python3 " + (dir.path() / "check.py").string() + " " + dir.path().string(), true);
  EXPECT_EQ(r.status, 0) << r.output;
}

// A run's outputs replace an earlier run's all together at its end: while it runs, the earlier
// files stay as they were; afterwards the folder holds this run only (the longer run's extra
// frames are gone) and no temporary.
TEST(SceneRun, ASecondRunReplacesTheFirstAllTogether) {
  auto scene = read_scene(scenes_dir() + "/vase_drop.json");
  ASSERT_OK(scene);
  test::TempDir dir;
  const std::filesystem::path frames = dir.path() / "frames";
  ASSERT_OK(run_scene(*scene, {.out_dir = dir.path().string(), .duration = 0.5}));
  ASSERT_TRUE(std::filesystem::exists(frames / "frame_000015.vtu"));
  const auto first_summary_time = std::filesystem::last_write_time(dir.path() / "summary.json");
  bool earlier_kept = true;
  RunOptions options{.out_dir = dir.path().string(), .duration = 0.2};
  options.progress = [&](double, std::int64_t, Index) {
    earlier_kept = earlier_kept && std::filesystem::exists(frames / "frame_000015.vtu") &&
                   std::filesystem::last_write_time(dir.path() / "summary.json") == first_summary_time;
  };
  auto second = run_scene(*scene, options);
  ASSERT_OK(second);
  EXPECT_TRUE(earlier_kept);
  EXPECT_TRUE(std::filesystem::exists(frames / "frame_000006.vtu"));
  EXPECT_FALSE(std::filesystem::exists(frames / "frame_000007.vtu"));
  EXPECT_FALSE(std::filesystem::exists(frames / "frame_000015.vtu"));
  EXPECT_FALSE(std::filesystem::exists(frames / "surface_000015.ply"));
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".shatter-"), std::string::npos) << e.path();
  std::ifstream summary_file(dir.path() / "summary.json");
  EXPECT_EQ(nlohmann::json::parse(summary_file).at("steps").get<std::int64_t>(), second->steps);
}

// Ctrl-C: the run stops after the current step, exits 130 and leaves complete files. The run is
// made 300 simulated seconds long (several seconds of work), so the interrupt at 0.7 s always
// falls inside it (the 5 s scene alone now runs in about that time).
TEST(SceneRun, CliInterruptLeavesCompleteFiles) {
  test::TempDir dir;
  const std::string out = (dir.path() / "out").string();
  const test::CommandResult r = test::run_command("timeout --preserve-status -s INT 0.7 " + test::cli_path() + " run " +
                                                      scenes_dir() + "/teddy_drops.json --time 300 --out " + out,
                                                  true);
  ASSERT_EQ(r.status, 130) << r.output;
  std::ifstream summary_file(dir.path() / "out" / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  EXPECT_TRUE(summary.at("stopped").get<bool>());
  EXPECT_LT(summary.at("simulated_time").get<double>(), 300.0);
  std::ifstream events_file(dir.path() / "out" / "events.jsonl");
  std::string line;
  while (std::getline(events_file, line)) EXPECT_TRUE(nlohmann::json::accept(line)) << line;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path() / "out"))
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
}

// The clay teddy's first landing is solved to part of its load (StVK's compressive limit,
// docs/impacts.md "Limits"), and the summary counts it.
// The teddy scene with the StVK model: its first landing has no equilibrium at the full load
// (docs/impacts.md "Limits").
TEST(SceneRun, CliCountsImpactsSolvedToPartOfTheLoad) {
  test::TempDir dir;
  nlohmann::json scene = nlohmann::json::parse(std::ifstream(scenes_dir() + "/teddy_drops.json"));
  scene["bodies"][0]["model"] = "stvk";
  scene["bodies"][0]["mesh"] = std::string(SHATTER_SOURCE_DIR) + "/assets/meshes/teddy.msh";
  const std::string path = (dir.path() / "teddy_stvk.json").string();
  std::ofstream(path) << scene.dump(2);
  const test::CommandResult r =
      test::run_command(test::cli_path() + " run " + path + " --time 0.5 --json --no-output", false);
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j.at("impacts").get<int>(), 1);
  EXPECT_EQ(j.at("impacts_partly_solved").get<int>(), 1);
  const test::CommandResult text =
      test::run_command(test::cli_path() + " run " + path + " --time 0.5 --no-output", false);
  ASSERT_EQ(text.status, 0) << text.output;
  EXPECT_NE(text.output.find("1 analysed (1 solved to part of the load)"), std::string::npos) << text.output;
}

TEST(SceneRun, CliRunsTheBundledVaseDrop) {
  test::TempDir dir;
  const test::CommandResult r =
      test::run_command(test::cli_path() + " run --time 0.2 --json --out " + (dir.path() / "out").string(), false);
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j.at("scene"), "vase_drop");
  EXPECT_EQ(j.at("steps"), 12);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out" / "summary.json"));
  const test::CommandResult bad = test::run_command(test::cli_path() + " run /nonexistent.json", true);
  EXPECT_EQ(bad.status, 3) << bad.output;
  EXPECT_NE(bad.output.find("/nonexistent.json"), std::string::npos);
}

}  // namespace
}  // namespace shatter

namespace shatter {
namespace {

// The bundled soft landing: the vase dropped on stone breaks, the one dropped on the deformable
// rubber mat does not, and the rubber ball bounces.
TEST(SceneRun, ARubberMatCushionsAVaseAndABallBounces) {
  auto scene = read_scene(std::string(SHATTER_SOURCE_DIR) + "/scenes/soft_landing.json");
  ASSERT_OK(scene);
  auto built = build_scene(*scene);
  ASSERT_OK(built);
  World& w = *built->world;
  const BodyId mat = built->bodies[0], on_stone = built->bodies[1], on_rubber = built->bodies[2],
               ball = built->bodies[3];
  EXPECT_TRUE(w.deformable(mat));
  EXPECT_TRUE(w.deformable(ball));
  EXPECT_FALSE(w.deformable(on_rubber));
  bool landed = false;
  double rebound = 0;
  while (w.time() < 0.75) {  // both vases land at 0.47 s; the ball is back up at about 0.6 s
    w.step();
    double lowest = kInfinity;
    for (const Vec3& x : w.node_positions(ball)) lowest = std::min(lowest, x.y());
    if (lowest < 0.01) landed = true;
    if (landed) rebound = std::max(rebound, lowest);
  }
  EXPECT_TRUE(w.removed(on_stone));
  EXPECT_FALSE(w.removed(on_rubber));
  EXPECT_EQ(w.model(on_rubber)->mesh.num_tets(), 1440);
  EXPECT_TRUE(landed);
  EXPECT_GT(rebound, 0.05);  // bounced at least 5 cm clear of the ground after landing from 0.8 m
}

TEST(SceneRun, ABodyAppearsWhenItsTimeComes) {
  const std::string text = R"({
    "bodies": [
      {"name": "first", "mesh": ")" +
                           std::string(SHATTER_SOURCE_DIR) + R"(/assets/meshes/cinder_block.msh",
       "material": "concrete", "height": 0.0005},
      {"name": "later", "mesh": ")" +
                           std::string(SHATTER_SOURCE_DIR) + R"(/assets/meshes/cinder_block.msh",
       "material": "concrete", "position": [1, 0, 0], "height": 0.05, "appear": 0.5, "velocity": [0.5, 0, 0]}
    ],
    "actions": [{"time": 0.2, "type": "impulse", "body": "later", "impulse": [0, 5, 0]}]
  })";
  auto scene = parse_scene(text, "appear.json");
  ASSERT_OK(scene);
  EXPECT_EQ(scene->bodies[1].appear, 0.5);
  auto built = build_scene(*scene);
  ASSERT_OK(built);
  World& w = *built->world;
  EXPECT_EQ(built->bodies[1].index, -1);
  std::size_t next = 0;
  Index before = 0;
  while (w.time() < 0.45) {
    ASSERT_OK(apply_due_actions(*scene, *built, next));  // the impulse at 0.2 s finds no body: skipped
    w.step();
    before = w.live_body_count();
  }
  EXPECT_EQ(before, 2);  // the ground and the first block
  while (w.time() < 0.55) {
    ASSERT_OK(apply_due_actions(*scene, *built, next));
    w.step();
  }
  ASSERT_GE(built->bodies[1].index, 0);
  EXPECT_EQ(w.live_body_count(), 3);
  const RigidState& r = w.rigid_state(built->bodies[1]);
  EXPECT_NEAR(r.linear_velocity.x(), 0.5, 1e-9);  // its own velocity (gravity acts along y)
  EXPECT_LT(r.linear_velocity.y(), 0.0);
  EXPECT_GT(r.position.x(), 1.0);
  // A run names it in the summary.
  test::TempDir dir;
  auto run = run_scene(*scene, {.out_dir = dir.path().string(), .duration = 0.7});
  ASSERT_OK(run);
  EXPECT_EQ(run->bodies, 2);
  std::ifstream in(dir.file("summary.json"));
  const auto summary = nlohmann::json::parse(in);
  bool named = false;
  for (const auto& b : summary["bodies"]) named |= b["name"] == "later";
  EXPECT_TRUE(named);
  auto bad = parse_scene(R"({"bodies": [{"mesh": "a.msh", "material": "glass", "appear": -1}]})", "bad.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().to_string().find("bodies[0].appear"), std::string::npos) << bad.error().to_string();
}

}  // namespace
}  // namespace shatter
