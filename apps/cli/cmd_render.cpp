// `shatter render [SCENE] --out DIR [--time T] [--fps F] [--size WxH] [--view material|stress] ...`:
// simulate a scene and render it without a window (EGL; Mesa's llvmpipe needs no GPU) to PNG
// frames, and to an MP4 when ffmpeg is installed (docs/viewer.md).
#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "command.h"
#include "shatter/core/parallel.h"
#include "shatter/render/frame.h"
#include "shatter/render/headless.h"
#include "shatter/render/renderer.h"
#include "shatter/scene/scene.h"

extern char** environ;

namespace shatter::cli {
namespace {

struct RenderArgs {
  std::string scene;
  std::string out_dir;
  double time = -1;
  double fps = 30;
  std::string size = "1280x720";
  std::string view = "material";
  double stress_scale = 0;
  std::vector<double> camera;  // yaw, pitch in degrees [, distance m]
  std::vector<double> target;  // point looked at, m
  bool no_mp4 = false;
  bool no_marks = false;
  int threads = -1;
  bool json = false;
};

std::atomic<bool> g_render_stop{false};
extern "C" void on_render_interrupt(int /*signal*/) { g_render_stop.store(true); }

// The program's full path when it is on PATH, else "".
std::string find_program(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return "";
  std::string dirs = path;
  std::size_t start = 0;
  while (start <= dirs.size()) {
    const std::size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::filesystem::path p = std::filesystem::path(dirs.substr(start, end - start)) / name;
    if (access(p.c_str(), X_OK) == 0) return p.string();
    start = end + 1;
  }
  return "";
}

// Run a program with arguments (no shell), its output discarded; its exit status.
int run_program(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return -1;
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int render(const RenderArgs& args) {
  int width = 0, height = 0;
  if (!parse_size(args.size, 16, 8192, width, height))
    return report_error("--size: expected WIDTHxHEIGHT, each 16..8192 (e.g. 1280x720), got \"" + args.size + "\"",
                        kExitUsage);
  if (args.view != "material" && args.view != "stress")
    return report_error("--view: expected material or stress, got \"" + args.view + "\"", kExitUsage);
  if (!(args.fps > 0) || args.fps > 1000) return report_error("--fps: expected 0 < fps <= 1000", kExitUsage);
  if (args.time > 3600) return report_error("--time: expected at most 3600 s", kExitUsage);
  if (!args.camera.empty() && args.camera.size() != 2 && args.camera.size() != 3)
    return report_error("--camera: expected YAW,PITCH (degrees) or YAW,PITCH,DISTANCE (m)", kExitUsage);
  if (args.threads > 1024) return report_error("--threads: expected at most 1024", kExitUsage);
  if (!args.target.empty() && args.target.size() != 3) return report_error("--target: expected X,Y,Z (m)", kExitUsage);
  for (const double v : args.camera)
    if (!std::isfinite(v)) return report_error("--camera: expected finite numbers", kExitUsage);
  for (const double v : args.target)
    if (!std::isfinite(v)) return report_error("--target: expected finite numbers", kExitUsage);
  if (args.camera.size() == 3 && !(args.camera[2] > 0))
    return report_error("--camera: the distance must be > 0", kExitUsage);
  const std::string path = args.scene.empty() ? default_scene_path() : args.scene;
  auto scene = read_scene(path);
  if (!scene) return report_error(scene.error().to_string(), kExitBadInput);
  const int threads = args.threads >= 0 ? args.threads : scene->threads;
  if (threads > 0) set_num_threads(threads);
  const std::string out = args.out_dir.empty() ? scene->name + "_render" : args.out_dir;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) return report_error(out + ": cannot create the output folder: " + ec.message(), kExitOutput);

  auto context = render::HeadlessContext::create();
  if (!context) return report_error(context.error().message, kExitFailure);
  auto renderer = render::Renderer::create();
  if (!renderer) return report_error(renderer.error().message, kExitFailure);
  auto target = render::OffscreenTarget::create(width, height, 4);
  if (!target) return report_error(target.error().message, kExitFailure);
  auto built = build_scene(*scene);
  if (!built) return report_error(built.error().to_string(), kExitBadInput);
  World& w = *built->world;

  render::RenderOptions ro;
  ro.view = args.view == "stress" ? render::ViewMode::stress : render::ViewMode::material;
  ro.stress_scale = args.stress_scale;
  ro.marks = !args.no_marks;
  render::EventMarks marks;
  const double aspect = static_cast<double>(width) / height;
  render::Camera camera = render::frame_camera(render::frame_from_world(w), aspect);
  if (!args.camera.empty()) {
    camera.yaw = args.camera[0] * 3.14159265358979 / 180;
    camera.pitch = args.camera[1] * 3.14159265358979 / 180;
    if (args.camera.size() == 3) camera.distance = args.camera[2];
  }
  if (!args.target.empty()) camera.target = Vec3(args.target[0], args.target[1], args.target[2]);

  const double duration = args.time >= 0 ? args.time : scene->duration;
  const double dt = scene->world.time_step;
  const auto total_steps = static_cast<std::int64_t>(std::llround(duration / dt));
  std::size_t next_action = 0;
  std::vector<std::string> files;
  double render_ms = 0, sim_ms = 0;
  const bool tty = isatty(fileno(stderr)) != 0;
  const auto t0 = std::chrono::steady_clock::now();
  auto last_print = t0;
  const auto old_handler = std::signal(SIGINT, on_render_interrupt);
  std::int64_t steps = 0;
  int frame_index = 0;
  bool stopped = false;
  auto write_frame = [&]() -> bool {
    const auto a = std::chrono::steady_clock::now();
    target->get()->bind();
    renderer->get()->draw(render::frame_from_world(w, &marks), camera, width, height, ro);
    const render::Image img = target->get()->read();
    const std::string name = fmt::format("{}/frame_{:06d}.png", out, frame_index);
    auto ok = render::write_png(name, img);
    render_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a).count();
    if (!ok) {
      report_error(ok.error().message, kExitOutput);
      return false;
    }
    files.push_back(name);
    ++frame_index;
    return true;
  };
  if (!write_frame()) return kExitOutput;
  while (steps < total_steps) {
    if (g_render_stop.load()) {
      stopped = true;
      break;
    }
    const auto a = std::chrono::steady_clock::now();
    auto acted = apply_due_actions(*scene, *built, next_action);
    if (!acted) return report_error(acted.error().message, kExitBadInput);
    w.step();
    ++steps;
    marks.add(w.events(), w.time());
    sim_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a).count();
    if (w.time() + 0.5 * dt >= frame_index / args.fps)
      if (!write_frame()) return kExitOutput;
    const auto now = std::chrono::steady_clock::now();
    if (std::chrono::duration<double>(now - last_print).count() >= (tty ? 0.1 : 5.0) || steps == total_steps) {
      last_print = now;
      const std::string line = fmt::format("t {:.2f} / {:.2f} s, {} frames, {} bodies", w.time(), duration, frame_index,
                                           w.live_body_count() - (scene->ground ? 1 : 0));
      if (tty)
        std::fprintf(stderr, "\r%-70s%s", line.c_str(), steps == total_steps ? "\n" : "");
      else
        std::fprintf(stderr, "%s\n", line.c_str());
    }
  }
  std::signal(SIGINT, old_handler);

  // The movie, when ffmpeg is there.
  std::string movie;
  const std::string ffmpeg = args.no_mp4 ? "" : find_program("ffmpeg");
  if (!ffmpeg.empty() && frame_index > 1) {
    const std::string tmp = out + "/.render.mp4.tmp.mp4";
    const int rc = run_program({ffmpeg, "-y", "-loglevel", "error", "-framerate", fmt::format("{}", args.fps), "-i",
                                out + "/frame_%06d.png", "-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "20", tmp});
    if (rc == 0) {
      std::filesystem::rename(tmp, out + "/render.mp4", ec);
      if (!ec) movie = out + "/render.mp4";
    } else {
      std::filesystem::remove(tmp, ec);
      std::fprintf(stderr, "shatter: warning: ffmpeg failed (status %d): no MP4 written\n", rc);
    }
  }
  const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (args.json) {
    nlohmann::json j{{"scene", scene->name},
                     {"frames", frame_index},
                     {"width", width},
                     {"height", height},
                     {"simulated_time", w.time()},
                     {"stopped", stopped},
                     {"device", renderer->get()->device()},
                     {"render_ms_per_frame", frame_index ? render_ms / frame_index : 0.0},
                     {"simulate_ms", sim_ms},
                     {"wall_ms", wall},
                     {"movie", movie},
                     {"folder", out}};
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("scene       %s (%s)\n", scene->name.c_str(), path.c_str());
    std::printf("rendered    %d frames of %dx%d at %g fps, %.3f s simulated%s\n", frame_index, width, height, args.fps,
                w.time(), stopped ? " (stopped early)" : "");
    std::printf("device      %s\n", renderer->get()->device().c_str());
    std::printf("time        %.0f ms wall: simulate %.0f, render and write %.0f (%.1f ms a frame)\n", wall, sim_ms,
                render_ms, frame_index ? render_ms / frame_index : 0.0);
    std::printf("wrote       %s/frame_000000.png .. frame_%06d.png\n", out.c_str(), frame_index - 1);
    if (!movie.empty())
      std::printf("wrote       %s\n", movie.c_str());
    else if (!args.no_mp4)
      std::printf("(install ffmpeg for an MP4 of the frames)\n");
  }
  return stopped ? 130 : kExitOk;
}

RunFn setup_render(CLI::App& sub) {
  auto args = std::make_shared<RenderArgs>();
  sub.add_option("scene", args->scene, "Scene file (JSON, docs/scenes.md); default: the bundled vase drop");
  sub.add_option("--out", args->out_dir, "Output folder (default: <scene name>_render)");
  sub.add_option("--time", args->time, "Simulated seconds (default: the scene's duration)")
      ->check(CLI::NonNegativeNumber);
  sub.add_option("--fps", args->fps, "Frames per simulated second (default 30)");
  sub.add_option("--size", args->size, "Image size WIDTHxHEIGHT (default 1280x720)");
  sub.add_option("--view", args->view, "material (default) or stress (tension red, compression green)");
  sub.add_option("--stress-scale", args->stress_scale, "Stress of full colour, Pa (default: the frame's largest)")
      ->check(CLI::NonNegativeNumber);
  sub.add_option("--camera", args->camera, "YAW,PITCH in degrees [,DISTANCE in m] (default: framed)")->delimiter(',');
  sub.add_option("--target", args->target, "X,Y,Z: the point looked at, m (default: the bodies' centre)")
      ->delimiter(',');
  sub.add_flag("--no-mp4", args->no_mp4, "Do not make render.mp4 even when ffmpeg is installed");
  sub.add_flag("--no-marks", args->no_marks, "Do not mark impact points and crack planes");
  sub.add_option("--threads", args->threads, "Simulation threads (results are the same on any number)")
      ->check(CLI::NonNegativeNumber);
  sub.add_flag("--json", args->json, "Print the summary as JSON");
  return [args] { return render(*args); };
}

const Registration render_command{"render", "Render a scene to PNG frames (and an MP4) without a window",
                                  &setup_render};

}  // namespace
}  // namespace shatter::cli
