// The renderer: PNG files, the camera, and headless renders checked against the simulation (the
// object is where the world says, the stress view's colours follow the stress signs, golden images).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>

#include "shatter/mesh/generate.h"
#include "shatter/render/camera.h"
#include "shatter/render/frame.h"
#include "shatter/render/headless.h"
#include "shatter/render/image.h"
#include "shatter/render/renderer.h"
#include "shatter/rigid/body.h"
#include "shatter/scene/scene.h"
#include "support/test_support.h"

namespace shatter::render {
namespace {

using test::cli_path;
using test::data_path;
using test::run_command;
using test::TempDir;

TEST(Png, RoundTripsRgbAndRgba) {
  Image img(37, 23);
  std::uint64_t state = 12345;
  for (auto& c : img.rgba) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    c = static_cast<std::uint8_t>(state >> 56);
  }
  for (bool alpha : {false, true}) {
    auto back = decode_png(encode_png(img, alpha));
    ASSERT_OK(back);
    ASSERT_EQ(back->width, 37);
    ASSERT_EQ(back->height, 23);
    for (std::size_t i = 0; i < img.rgba.size(); ++i)
      ASSERT_EQ(back->rgba[i], (i % 4 == 3 && !alpha) ? 255 : img.rgba[i]) << i;
  }
}

TEST(Png, RejectsWhatItCannotRead) {
  EXPECT_FALSE(decode_png("not a png", "x.png").ok());
  Image img(4, 4);
  std::string png = encode_png(img);
  EXPECT_FALSE(decode_png(png.substr(0, png.size() / 2), "half.png").ok());
  png[png.size() / 2] ^= 0x55;  // corrupt the compressed data
  EXPECT_FALSE(decode_png(png, "bad.png").ok());
  auto missing = read_png("/nonexistent/file.png");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("/nonexistent/file.png"), std::string::npos);
}

TEST(Png, WriteIsAtomicAndRefusesEmptyImages) {
  TempDir dir;
  const std::string path = dir.file("a.png");
  ASSERT_OK(write_png(path, Image(8, 8)));
  EXPECT_FALSE(write_png(path, Image()).ok());
  auto back = read_png(path);  // the earlier file is intact
  ASSERT_OK(back);
  EXPECT_EQ(back->width, 8);
  EXPECT_FALSE(write_png(dir.file("no/such/folder/a.png"), Image(2, 2)).ok());
}

TEST(Camera, ProjectsAndCastsRaysConsistently) {
  Camera c;
  c.target = Vec3(0.3, 0.5, -0.2);
  c.distance = 2.5;
  c.yaw = 0.8;
  c.pitch = 0.3;
  const Vec3 centre = c.project(c.target, 640, 480);
  EXPECT_NEAR(centre.x(), 320, 1e-9);
  EXPECT_NEAR(centre.y(), 240, 1e-9);
  EXPECT_NEAR(centre.z(), 2.5, 1e-9);  // depth = distance
  for (const Vec3& p : {Vec3(0, 0, 0), Vec3(1, 1, 0.5), Vec3(-0.5, 0.2, 0.4)}) {
    const Vec3 px = c.project(p, 640, 480);
    Vec3 o, d;
    c.ray(px.x(), px.y(), 640, 480, o, d);
    EXPECT_LT((o + d * d.dot(p - o) - p).norm(), 1e-9);  // the ray through its pixel meets it
  }
  // A point above the target appears above the centre (y grows downwards).
  EXPECT_LT(c.project(c.target + Vec3(0, 0.1, 0), 640, 480).y(), 240);
}

TEST(Appearance, FollowsTheMaterial) {
  using G = Appearance::Grain;
  EXPECT_EQ(appearance_for(*material_preset("porcelain")).grain, G::porcelain);
  EXPECT_EQ(appearance_for(*material_preset("concrete")).grain, G::stone);
  EXPECT_EQ(appearance_for(*material_preset("modelling_clay")).grain, G::clay);
  EXPECT_EQ(appearance_for(*material_preset("steel")).grain, G::metal);
  Material custom{.name = "custom", .youngs_modulus = 5e5, .yield_stress = 1e4};
  EXPECT_EQ(appearance_for(custom).grain, G::clay);
}

// A headless context and renderer for the tests below (skipped on a developer machine without
// EGL; a failure under CI, where scripts/setup.sh installs Mesa).
struct Gl {
  std::unique_ptr<HeadlessContext> context;
  std::unique_ptr<Renderer> renderer;
  std::string error;
};
Gl& gl() {
  static Gl g = [] {
    Gl r;
    auto c = HeadlessContext::create();
    if (!c) {
      r.error = c.error().message;
      return r;
    }
    r.context = std::move(*c);
    auto rr = Renderer::create();
    if (!rr) {
      r.error = rr.error().message;
      return r;
    }
    r.renderer = std::move(*rr);
    return r;
  }();
  return g;
}
#define REQUIRE_GL() SHATTER_REQUIRE_TOOL(gl().renderer != nullptr, "headless OpenGL: " + gl().error)

Image draw(const DrawFrame& frame, const Camera& camera, int w, int h, const RenderOptions& options = {},
           RenderStats* stats = nullptr) {
  auto target = OffscreenTarget::create(w, h, 4);
  EXPECT_TRUE(target.ok());
  (*target)->bind();
  const RenderStats s = gl().renderer->draw(frame, camera, w, h, options);
  if (stats) *stats = s;
  return (*target)->read();
}

SceneWorld vase_scene() {
  auto scene = read_scene(std::string(SHATTER_SOURCE_DIR) + "/scenes/vase_drop.json");
  EXPECT_TRUE(scene.ok());
  auto built = build_scene(*scene);
  EXPECT_TRUE(built.ok());
  return std::move(*built);
}

TEST(Render, TheVaseIsWhereTheWorldSaysAtEachFrame) {
  REQUIRE_GL();
  SceneWorld s = vase_scene();
  World& w = *s.world;
  constexpr int kW = 320, kH = 180;
  const Camera camera = frame_camera(frame_from_world(w), static_cast<double>(kW) / kH);
  RenderOptions options;
  options.marks = false;
  DrawFrame empty = frame_from_world(w);
  empty.bodies.clear();
  const Image background = draw(empty, camera, kW, kH, options);
  for (const double t : {0.0, 0.2, 0.4}) {
    while (w.time() + 1e-9 < t) w.step();
    const BodyId vase = s.bodies[0];
    ASSERT_FALSE(w.removed(vase));
    const Image img = draw(frame_from_world(w), camera, kW, kH, options);
    // Pixels that differ from the empty scene (the vase, and its shadow on the ground below).
    // The shadow lies below the vase on screen while the vase is in the air: take the pixels
    // inside the box of the vase's projected surface, and compare the box of all changed pixels
    // above the ground shadow with it.
    const BodySurface surf = w.surface(vase);
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    for (const Vec3& p : surf.positions) {
      const Vec3 px = camera.project(p, kW, kH);
      x0 = std::min(x0, px.x());
      x1 = std::max(x1, px.x());
      y0 = std::min(y0, px.y());
      y1 = std::max(y1, px.y());
    }
    double cx = 0, cy = 0, n = 0;
    int inside = 0, changed_in_box = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const std::uint8_t* a = img.pixel(x, y);
        const std::uint8_t* b = background.pixel(x, y);
        const int diff = std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]);
        const bool in_box = x + 0.5 >= x0 && x + 0.5 <= x1 && y + 0.5 >= y0 && y + 0.5 <= y1;
        if (in_box) ++inside;
        if (diff > 30 && in_box) {
          ++changed_in_box;
          cx += x + 0.5;
          cy += y + 0.5;
          n += 1;
        }
      }
    if (n <= 50) {
      (void)write_png(::testing::TempDir() + "/vase_pose.png", img);
      (void)write_png(::testing::TempDir() + "/vase_pose_background.png", background);
    }
    ASSERT_GT(n, 50) << "t = " << t << ", box " << x0 << ".." << x1 << " x " << y0 << ".." << y1;
    cx /= n;
    cy /= n;
    const Vec3 com = camera.project(w.rigid_state(vase).position, kW, kH);
    std::printf(
        "t %.1f: vase box %.0f..%.0f x %.0f..%.0f px, changed centroid (%.1f, %.1f), centre of mass (%.1f, %.1f),"
        " %.0f%% of the box covered\n",
        t, x0, x1, y0, y1, cx, cy, com.x(), com.y(), 100.0 * changed_in_box / inside);
    // The drawn vase fills much of its projected box (a tilted vase's silhouette), and its pixels
    // centre near its projected centre of mass.
    EXPECT_GT(static_cast<double>(changed_in_box) / inside, 0.4);
    EXPECT_LT(std::hypot(cx - com.x(), cy - com.y()), 0.1 * std::max(x1 - x0, y1 - y0) + 1);
    // Nothing of the vase is drawn outside its box: above it, only the sky and the ground.
    int above = 0;
    for (int y = 0; y < std::max(0, static_cast<int>(y0) - 2); ++y)
      for (int x = 0; x < kW; ++x) {
        const std::uint8_t* a = img.pixel(x, y);
        const std::uint8_t* b = background.pixel(x, y);
        above += std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]) > 30 ? 1 : 0;
      }
    EXPECT_EQ(above, 0) << "t = " << t;
  }
}

// The vase in the air casts its shadow on the ground where the light's ray through it meets the
// ground: darker there than the same ground with no body, and the ground elsewhere untouched.
TEST(Render, TheShadowOnTheGroundIsWhereTheLightProjectsTheBody) {
  REQUIRE_GL();
  SceneWorld s = vase_scene();
  World& w = *s.world;
  while (w.time() + 1e-9 < 0.2) w.step();
  constexpr int kW = 320, kH = 180;
  const Camera camera = frame_camera(frame_from_world(w), static_cast<double>(kW) / kH);
  RenderOptions options;
  options.marks = false;
  const DrawFrame frame = frame_from_world(w);
  ASSERT_TRUE(frame.ground.has_value());
  DrawFrame empty = frame;
  empty.bodies.clear();
  const Image img = draw(frame, camera, kW, kH, options);
  const Image ground = draw(empty, camera, kW, kH, options);
  // Each surface vertex sent along the light onto the ground, and the pixels of that shadow's box.
  const Plane& plane = *frame.ground;
  const Vec3 light = options.light.normalized();
  const BodySurface surf = w.surface(s.bodies[0]);
  double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
  for (const Vec3& p : surf.positions) {
    const Vec3 q = p - light * ((plane.normal.dot(p) - plane.offset) / plane.normal.dot(light));
    const Vec3 px = camera.project(q, kW, kH);
    x0 = std::min(x0, px.x());
    x1 = std::max(x1, px.x());
    y0 = std::min(y0, px.y());
    y1 = std::max(y1, px.y());
  }
  const Vec3 vase_px = camera.project(w.rigid_state(s.bodies[0]).position, kW, kH);
  ASSERT_GT(x1 - x0, 5);
  ASSERT_GT(vase_px.y(), 0);
  ASSERT_LT(vase_px.y() + 0, y0) << "the vase is in the air: its shadow lies below it on screen";
  // In shadow the ground keeps its colour without the sun: per channel (gamma-encoded) the ratio
  // sqrt(ambient / (ambient + 0.95 sun warm)) of the ground shader's formula, once, however many
  // of the vase's faces cover the pixel (the stencil).
  const double sun = plane.normal.dot(light);
  const Vec3 ambient(0.38, 0.42, 0.5), warm(1.0, 0.97, 0.92);
  const Vec3 shade = ambient.cwiseQuotient(ambient + 0.95 * sun * warm).cwiseSqrt();
  int darker_inside = 0, inside = 0, darker_outside = 0, at_shade = 0, too_dark = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const std::uint8_t* a = img.pixel(x, y);
      const std::uint8_t* b = ground.pixel(x, y);
      const bool darker = a[0] + a[1] + a[2] + 30 < b[0] + b[1] + b[2];
      const bool in_box = x + 0.5 >= x0 && x + 0.5 <= x1 && y + 0.5 >= y0 && y + 0.5 <= y1;
      if (darker && in_box) {  // the ground in shadow (the vase itself is drawn above the box)
        bool matches = true;
        for (int c = 0; c < 3; ++c) {
          const double ratio = (a[c] + 0.5) / (b[c] + 0.5);
          matches = matches && std::abs(ratio - shade[c]) < 0.03;
          too_dark += ratio < shade[c] - 0.05 ? 1 : 0;
        }
        at_shade += matches ? 1 : 0;
      }
      const bool near_box = x + 0.5 >= x0 - 2 && x + 0.5 <= x1 + 2 && y + 0.5 >= y0 - 2 && y + 0.5 <= y1 + 2;
      if (in_box) {
        ++inside;
        darker_inside += darker ? 1 : 0;
      } else if (!near_box && y + 0.5 > vase_px.y() + 0.5 * (y0 - vase_px.y())) {
        darker_outside += darker ? 1 : 0;  // the ground away from the shadow (below the vase itself)
      }
    }
  std::printf("shadow box %.0f..%.0f x %.0f..%.0f px: %d of %d pixels darker; %d darker elsewhere\n", x0, x1, y0, y1,
              darker_inside, inside, darker_outside);
  std::printf("shade %.3f %.3f %.3f: %d darker pixels at it, %d channels darker than it\n", shade[0], shade[1],
              shade[2], at_shade, too_dark);
  EXPECT_GT(darker_inside, inside / 3);  // a tilted vase's shadow fills much of its box
  EXPECT_EQ(darker_outside, 0);
  EXPECT_GT(at_shade, darker_inside * 3 / 4);  // the rest: the shadow's multisampled edge
  EXPECT_EQ(too_dark, 0);                      // no pixel darkened twice
}

// Pixels under a covered rectangle (an opaque panel) are left with the background.
TEST(Render, CoveredRectanglesAreNotShaded) {
  REQUIRE_GL();
  SceneWorld s = vase_scene();
  constexpr int kW = 320, kH = 180;
  const DrawFrame frame = frame_from_world(*s.world);
  const Camera camera = frame_camera(frame, static_cast<double>(kW) / kH);
  RenderOptions options;
  options.marks = false;
  const Image full = draw(frame, camera, kW, kH, options);
  // One rectangle on the ground in the lower left, one past the lower right corner.
  options.covered = {{.x = 10, .y = 120, .width = 100, .height = 50},
                     {.x = 300, .y = 170, .width = 100, .height = 100}};
  const Image part = draw(frame, camera, kW, kH, options);
  options.covered.clear();
  EXPECT_EQ(draw(frame, camera, kW, kH, options).rgba, full.rgba);  // nothing of it stays for the next frame
  const Vec3 bg = options.background.array().sqrt();
  int differ_outside = 0, ground_under = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const bool covered = (x >= 10 && x < 110 && y >= 120 && y < 170) || (x >= 300 && y >= 170);
      const std::uint8_t* a = part.pixel(x, y);
      if (covered) {
        const std::uint8_t* b = full.pixel(x, y);
        ground_under += std::abs(b[0] - 255 * bg[0]) + std::abs(b[1] - 255 * bg[1]) > 20 ? 1 : 0;
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(a[c], 255 * bg[c], 1.5) << x << ", " << y;
      } else {
        const std::uint8_t* b = full.pixel(x, y);
        differ_outside += (a[0] != b[0] || a[1] != b[1] || a[2] != b[2]) ? 1 : 0;
      }
    }
  EXPECT_EQ(differ_outside, 0);
  EXPECT_GT(ground_under, 4000);  // the covered pixels would have shown the ground, not the sky
}

TEST(Render, StressViewIsRedInTensionAndGreenInCompression) {
  REQUIRE_GL();
  // A beam held far from a press on its top face: compression under the pad, tension below.
  BoxMeshDef def{.min = Vec3(-0.3, -0.04, -0.05), .max = Vec3(0.3, 0.04, 0.05), .cells = {24, 4, 4}};
  const Material strong{.name = "custom", .youngs_modulus = 70e9, .tensile_strength = kInfinity};
  auto model = make_body_model(make_box_mesh(def), strong, ModelKind::stvk);
  ASSERT_OK(model);
  World w({.gravity = Vec3::Zero()});
  auto id = w.add_body(std::make_shared<const BodyModel>(std::move(*model)), {});
  ASSERT_OK(id);
  ASSERT_OK(w.press(*id, Vec3(0, 0.04, 0), Vec3(0, -2e5, 0), 0.04, 0.1));
  w.step();
  ASSERT_OK(w.set_rigid_state(*id, {}));  // the press pushed it away: put it back in view
  const std::span<const double> stress = w.display_stress(*id);
  ASSERT_FALSE(stress.empty());
  // From the front (+z), level.
  Camera camera;
  camera.target = Vec3(0, 0, 0);
  camera.yaw = 0;
  camera.pitch = 0;
  camera.distance = 1.0;
  constexpr int kW = 480, kH = 240;
  RenderOptions options;
  options.view = ViewMode::stress;
  options.marks = false;
  options.legend = false;
  RenderStats stats;
  const Image img = draw(frame_from_world(w), camera, kW, kH, options, &stats);
  ASSERT_GT(stats.stress_scale, 0);
  // Each front face (normal +z) of a strongly stressed tet: its pixel shows the sign.
  const BodyModel& m = *w.model(*id);
  const BodySurface surf = w.surface(*id);
  ASSERT_EQ(surf.triangles.size(), m.surface.triangle_tet.size());
  ASSERT_EQ(stress.size(), static_cast<std::size_t>(m.mesh.num_tets()));
  int red = 0, green = 0, wrong = 0;
  for (std::size_t t = 0; t < surf.triangles.size(); ++t) {
    const TriIndices& tri = surf.triangles[t];
    const Vec3 a = surf.positions[tri[0]], b = surf.positions[tri[1]], c = surf.positions[tri[2]];
    if ((b - a).cross(c - a).normalized().z() < 0.99) continue;
    const double s = stress[static_cast<std::size_t>(m.surface.triangle_tet[t])] / stats.stress_scale;
    if (std::abs(s) < 0.5) continue;
    const Vec3 px = camera.project((a + b + c) / 3, kW, kH);
    ASSERT_TRUE(px.x() >= 0 && px.x() < kW && px.y() >= 0 && px.y() < kH) << px.transpose();
    const std::uint8_t* p = img.pixel(static_cast<int>(px.x()), static_cast<int>(px.y()));
    // Lighting dims the colours: compare channels by ratio.
    if (s > 0) {
      if (p[0] > 1.25 * p[1] && p[0] > 1.25 * p[2])
        ++red;
      else
        ++wrong;
    } else {
      if (p[1] > 1.25 * p[0] && p[1] > 1.25 * p[2])
        ++green;
      else
        ++wrong;
    }
  }
  std::printf("stress view: %d red (tension), %d green (compression), %d wrong; scale %.3g Pa\n", red, green, wrong,
              stats.stress_scale);
  EXPECT_GT(red, 5);
  EXPECT_GT(green, 5);
  EXPECT_LE(wrong, (red + green) / 20);
}

TEST(Render, IsDeterministicAndMatchesTheGoldenImage) {
  REQUIRE_GL();
  SceneWorld s = vase_scene();
  World& w = *s.world;
  EventMarks marks;
  while (w.time() + 1e-9 < 0.5) {
    w.step();
    marks.add(w.events(), w.time());
  }
  constexpr int kW = 320, kH = 180;
  const Camera camera = frame_camera(frame_from_world(*vase_scene().world), static_cast<double>(kW) / kH);
  const Image a = draw(frame_from_world(w, &marks), camera, kW, kH);
  const Image b = draw(frame_from_world(w, &marks), camera, kW, kH);
  EXPECT_EQ(a.rgba, b.rgba);
  const std::string golden = data_path("render/vase_0.5s.png");
  if (std::getenv("SHATTER_UPDATE_GOLDEN")) {
    ASSERT_OK(write_png(golden, a));
  }
  auto expected = read_png(golden);
  ASSERT_OK(expected);
  const ImageDifference d = compare_images(a, *expected);
  std::printf("golden vase at 0.5 s: mean difference %.3f, %.3f%% of pixels differ by more than 32\n", d.mean_abs,
              100 * d.fraction_over);
  EXPECT_LT(d.mean_abs, 2.0);
  EXPECT_LT(d.fraction_over, 0.01);
  if (d.mean_abs >= 2.0 || d.fraction_over >= 0.01) {
    (void)write_png(::testing::TempDir() + "/vase_0.5s_actual.png", a);
  }
}

TEST(Render, PickFindsTheBodyUnderThePixel) {
  SceneWorld s = vase_scene();
  World& w = *s.world;
  const Camera camera = frame_camera(frame_from_world(w), 16.0 / 9);
  const Vec3 px = camera.project(w.rigid_state(s.bodies[0]).position, 1280, 720);
  Vec3 o, d;
  camera.ray(px.x(), px.y(), 1280, 720, o, d);
  const Pick hit = pick_body(w, o, d);
  EXPECT_EQ(hit.body, s.bodies[0]);
  EXPECT_GT(hit.distance, 0);
  EXPECT_LT((hit.point - w.rigid_state(s.bodies[0]).position).norm(), 0.3);
  camera.ray(2, 2, 1280, 720, o, d);  // the sky
  EXPECT_EQ(pick_body(w, o, d).body.index, -1);
}

TEST(CmdRender, WritesFramesAndRefusesBadArguments) {
  SHATTER_REQUIRE_TOOL(!cli_path().empty(), "the shatter CLI");
  REQUIRE_GL();
  TempDir dir;
  const std::string cli = cli_path();
  const std::string scene = std::string(SHATTER_SOURCE_DIR) + "/scenes/vase_drop.json";
  auto r = run_command(cli + " render " + scene + " --out " + dir.path().string() +
                       " --time 0.2 --fps 10 --size 64x48 --no-mp4 --json");
  ASSERT_EQ(r.status, 0) << r.output;
  for (int k = 0; k <= 2; ++k) {
    auto img = read_png(dir.path().string() + "/frame_00000" + std::to_string(k) + ".png");
    ASSERT_OK(img);
    EXPECT_EQ(img->width, 64);
    EXPECT_EQ(img->height, 48);
  }
  EXPECT_NE(r.output.find("\"frames\": 3"), std::string::npos) << r.output;
  EXPECT_EQ(run_command(cli + " render " + scene + " --size 64by48 --out " + dir.path().string()).status, 2);
  EXPECT_EQ(run_command(cli + " render " + scene + " --view heat --out " + dir.path().string()).status, 2);
  EXPECT_EQ(run_command(cli + " render " + scene + " --camera 1,2,3,4 --out " + dir.path().string()).status, 2);
  EXPECT_EQ(run_command(cli + " render /nonexistent.json --out " + dir.path().string()).status, 3);
  EXPECT_EQ(run_command(cli + " render " + scene + " --out /proc/none --time 0.1").status, 4);
}

TEST(CmdRender, MakesAnMp4WhenFfmpegIsInstalled) {
  SHATTER_REQUIRE_TOOL(!cli_path().empty(), "the shatter CLI");
  REQUIRE_GL();
  // ffmpeg is optional (the frames are the output; the MP4 is a convenience): skipped without it.
  if (run_command("command -v ffmpeg >/dev/null 2>&1 && command -v ffprobe >/dev/null 2>&1").status != 0)
    GTEST_SKIP() << "ffmpeg is not installed";
  TempDir dir;
  const std::string scene = std::string(SHATTER_SOURCE_DIR) + "/scenes/vase_drop.json";
  auto r = run_command(cli_path() + " render " + scene + " --out " + dir.path().string() +
                       " --time 0.3 --fps 10 --size 96x64");
  ASSERT_EQ(r.status, 0) << r.output;
  auto probe = run_command("ffprobe -v error -show_entries stream=codec_name,width,height,nb_frames -of csv=p=0 " +
                           dir.file("render.mp4"));
  ASSERT_EQ(probe.status, 0) << probe.output;
  EXPECT_NE(probe.output.find("h264,96,64,4"), std::string::npos) << probe.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file(".render.mp4.tmp.mp4")));
}

}  // namespace
}  // namespace shatter::render

namespace shatter::render {
namespace {

bool have_xvfb() { return test::run_command("command -v xvfb-run >/dev/null 2>&1").status == 0; }

// `shatter view` on the vase drop under Xvfb with a script (written to the folder) and `options`.
test::CommandResult view_with_script(const test::TempDir& dir, const std::string& script, const std::string& options) {
  const std::string path = dir.file("script.json");
  {
    std::ofstream out(path);
    out << script;
  }
  // The X authority file lives in the test's folder: xvfb-run's own temporary folder is removed
  // on exit, and a failure to remove it (seen on busy machines) would replace the exit status.
  return test::run_command("xvfb-run -a -f " + dir.file("Xauthority") + " -s '-screen 0 1024x768x24' " +
                               test::cli_path() + " view " + std::string(SHATTER_SOURCE_DIR) +
                               "/scenes/vase_drop.json " + options + " --script " + path,
                           true);
}

// The live bodies the script's expect_bodies_at_least printed (-1 when it printed none).
int printed_bodies(const std::string& output) {
  const auto at = output.find("bodies ");
  return at == std::string::npos ? -1 : std::atoi(output.c_str() + at + 7);
}

TEST(CmdView, AHammerBlowThroughTheToolPathBreaksTheVase) {
  SHATTER_REQUIRE_TOOL(!test::cli_path().empty(), "the shatter CLI");
  SHATTER_REQUIRE_TOOL(have_xvfb(), "xvfb-run (package xvfb)");
  test::TempDir dir;
  // Paused in the air, the hammer tool is chosen and the vase clicked (the mouse's path: pick,
  // then World::strike), then it plays on; a screenshot, and the bodies are counted.
  const auto r = view_with_script(dir,
                                  R"([
      {"frame": 0, "action": "pause"},
      {"frame": 1, "action": "tool", "tool": "hammer", "impulse": 5, "speed": 10},
      {"frame": 2, "action": "click", "body": "vase"},
      {"frame": 2, "action": "play"},
      {"frame": 8, "action": "expect_bodies_at_least", "count": 2},
      {"frame": 8, "action": "screenshot", "path": ")" +
                                      dir.file("shot.png") + R"("},
      {"frame": 9, "action": "quit"}
    ])",
                                  "--size 960x540 --fixed-step --no-vsync");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("screenshot"), std::string::npos) << r.output;
  EXPECT_GE(printed_bodies(r.output), 2) << r.output;
  auto shot = read_png(dir.file("shot.png"));
  ASSERT_OK(shot);
  EXPECT_EQ(shot->width, 960);
  EXPECT_EQ(shot->height, 540);
  // Beside the panels (top left, bottom right) the picture shows the dark ground and the pieces
  // of the white glazed vase.
  int bright = 0, dark = 0;
  for (int y = 0; y < 390; ++y)
    for (int x = 420; x < 960; ++x) {
      const std::uint8_t* p = shot->pixel(x, y);
      bright += p[0] > 190 && p[1] > 190 && p[2] > 190 ? 1 : 0;
      dark += p[0] < 140 && p[1] < 140 && p[2] < 140 ? 1 : 0;
    }
  EXPECT_GT(bright, 300);
  EXPECT_GT(dark, 390 * 540 / 3);
}

TEST(CmdView, ASliceStrokeCutsTheVase) {
  SHATTER_REQUIRE_TOOL(!test::cli_path().empty(), "the shatter CLI");
  SHATTER_REQUIRE_TOOL(have_xvfb(), "xvfb-run (package xvfb)");
  test::TempDir dir;
  const auto r = view_with_script(dir, R"([
      {"frame": 0, "action": "pause"},
      {"frame": 1, "action": "tool", "tool": "slice"},
      {"frame": 2, "action": "drag", "across": "vase"},
      {"frame": 3, "action": "expect_bodies_at_least", "count": 2},
      {"frame": 3, "action": "quit"}
    ])",
                                  "--size 640x360");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_GE(printed_bodies(r.output), 2) << r.output;
}

TEST(CmdView, WithoutADisplayItSaysSoAndPointsToRender) {
  SHATTER_REQUIRE_TOOL(!test::cli_path().empty(), "the shatter CLI");
  auto r = test::run_command("env -u DISPLAY -u WAYLAND_DISPLAY " + test::cli_path() + " view " +
                                 std::string(SHATTER_SOURCE_DIR) + "/scenes/vase_drop.json",
                             true);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("shatter render"), std::string::npos) << r.output;
}

TEST(CmdView, RefusesABadScript) {
  SHATTER_REQUIRE_TOOL(!test::cli_path().empty(), "the shatter CLI");
  SHATTER_REQUIRE_TOOL(have_xvfb(), "xvfb-run (package xvfb)");
  test::TempDir dir;
  const auto r = view_with_script(dir, R"([{"frame": 1, "action": "explode"}])", "--size 320x240");
  EXPECT_EQ(r.status, 3) << r.output;
  EXPECT_NE(r.output.find("unknown action \"explode\""), std::string::npos) << r.output;
}

}  // namespace
}  // namespace shatter::render
