// `shatter run [SCENE] [--out DIR | --no-output] [--time T] [--threads N] [--json]`: simulate a scene file and
// write its outputs (docs/scenes.md). Without SCENE it runs the bundled vase drop. Progress goes to
// stderr: one updating line on a terminal, a line every few seconds otherwise. Ctrl-C stops after
// the current step with every file written so far complete.
#include <fmt/format.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "command.h"
#include "shatter/core/parallel.h"
#include "shatter/scene/scene.h"

namespace shatter::cli {
namespace {

struct RunArgs {
  std::string scene;
  std::string out_dir;
  double time = -1;
  int threads = -1;
  bool json = false;
  bool no_output = false;
};

std::atomic<bool> g_run_stop{false};

extern "C" void on_interrupt(int /*signal*/) { g_run_stop.store(true); }

int run(const RunArgs& args) {
  const std::string path = args.scene.empty() ? default_scene_path() : args.scene;
  auto scene = read_scene(path);
  if (!scene) return report_error(scene.error().to_string(), kExitBadInput);
  if (args.threads > 1024) return report_error("--threads: expected at most 1024", kExitUsage);
  if (args.time > 24 * 3600.0) return report_error("--time: expected at most 86400 s", kExitUsage);
  const int threads = args.threads >= 0 ? args.threads : scene->threads;
  if (threads > 0) set_num_threads(threads);
  RunOptions options;
  if (args.no_output && !args.out_dir.empty())
    return report_error("--no-output and --out exclude each other", kExitUsage);
  options.out_dir = args.no_output ? "" : args.out_dir.empty() ? scene->name + "_out" : args.out_dir;
  if (args.time >= 0) options.duration = args.time;
  options.stop = &g_run_stop;
  const bool tty = isatty(fileno(stderr)) != 0;
  const auto t0 = std::chrono::steady_clock::now();
  auto last_print = t0;
  const double duration = options.duration.value_or(scene->duration);
  options.progress = [&](double t, std::int64_t steps, Index bodies) {
    const auto now = std::chrono::steady_clock::now();
    const double wall = std::chrono::duration<double>(now - t0).count();
    const double since = std::chrono::duration<double>(now - last_print).count();
    const bool done = t + 1e-9 >= duration;
    if (!done && since < (tty ? 0.1 : 5.0)) return;
    last_print = now;
    const std::string line = fmt::format("t {:.2f} / {:.2f} s, {} steps, {:.0f} steps/s, {} bodies", t, duration, steps,
                                         wall > 0 ? static_cast<double>(steps) / wall : 0.0, bodies);
    if (tty)
      std::fprintf(stderr, "\r%-70s%s", line.c_str(), done ? "\n" : "");
    else
      std::fprintf(stderr, "%s\n", line.c_str());
  };
  const auto old_handler = std::signal(SIGINT, on_interrupt);
  auto summary = run_scene(*scene, options);
  std::signal(SIGINT, old_handler);
  if (!summary) {
    // An output that could not be written names a file in the output folder (exit 4); anything
    // else is the scene's (a body's mesh, an action: exit 3).
    const std::string& file = summary.error().file;
    const bool output = !options.out_dir.empty() && file.rfind(options.out_dir, 0) == 0 && file != scene->file;
    return report_error(summary.error().to_string(), output ? kExitOutput : kExitBadInput);
  }
  const RunSummary& s = *summary;
  if (args.json) {
    nlohmann::json j{{"scene", scene->name},
                     {"steps", s.steps},
                     {"simulated_time", s.simulated_time},
                     {"stopped", s.stopped},
                     {"bodies", s.bodies},
                     {"fragments_born", s.fragments},
                     {"impacts", s.impacts},
                     {"impacts_partly_solved", s.impacts_partly_solved},
                     {"cracks", s.cracks},
                     {"state_hash", fmt::format("{:016x}", s.state_hash)},
                     {"files", s.files}};
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("scene       %s (%s)\n", scene->name.c_str(), path.c_str());
    std::printf("simulated   %.3f s in %lld steps%s\n", s.simulated_time, static_cast<long long>(s.steps),
                s.stopped ? " (stopped early)" : "");
    const std::string partly =
        s.impacts_partly_solved > 0 ? fmt::format(" ({} solved to part of the load)", s.impacts_partly_solved) : "";
    std::printf("impacts     %d analysed%s, %d crack(s), %d fragment(s) born, %.3g kg of debris\n",
                static_cast<int>(s.impacts), partly.c_str(), static_cast<int>(s.cracks), static_cast<int>(s.fragments),
                s.debris_mass);
    std::printf("bodies      %d at the end\n", static_cast<int>(s.bodies));
    std::printf("time        %.0f ms wall: rigid %.0f, impacts %.0f, deformable %.0f, output %.0f\n", s.wall_ms,
                s.rigid_ms, s.impact_ms, s.deformable_ms, s.output_ms);
    std::printf("state hash  %016llx\n", static_cast<unsigned long long>(s.state_hash));
    for (const std::string& f : s.files) std::printf("wrote       %s\n", f.c_str());
    if (!s.files.empty())
      std::printf("open %s/scene.pvd in ParaView (colour by \"body\" or \"plastic_strain\")\n",
                  options.out_dir.c_str());
  }
  return s.stopped ? 130 : kExitOk;
}

RunFn setup_run(CLI::App& sub) {
  auto args = std::make_shared<RunArgs>();
  sub.add_option("scene", args->scene, "Scene file (JSON, docs/scenes.md); default: the bundled vase drop");
  sub.add_option("--out", args->out_dir, "Output folder (default: <scene name>_out)");
  sub.add_option("--time", args->time, "Simulated seconds (default: the scene's duration)")
      ->check(CLI::NonNegativeNumber);
  sub.add_option("--threads", args->threads, "Threads (default: the scene's, else all; results are the same)")
      ->check(CLI::NonNegativeNumber);
  sub.add_flag("--json", args->json, "Print the summary as JSON");
  sub.add_flag("--no-output", args->no_output, "Write no files (timing runs)");
  return [args] { return run(*args); };
}

const Registration run_command{"run", "Simulate a scene: drops, impacts, dents and fractures", &setup_run};

}  // namespace
}  // namespace shatter::cli
