// `shatter view [SCENE] [--script FILE] [--frames N] [--size WxH] [--out DIR]`: the interactive viewer
// (docs/viewer.md). Without a display it says so and points to `shatter render`.
#include <cstdio>
#include <memory>
#include <string>

#include "command.h"
#include "viewer.h"

namespace shatter::cli {
namespace {

struct ViewArgs {
  viewer::ViewerOptions options;
  std::string size = "1280x720";
};

int view(ViewArgs& args) {
  int width = 0, height = 0;
  if (!parse_size(args.size, 64, 8192, width, height))
    return report_error("--size: expected WIDTHxHEIGHT, each 64..8192 (e.g. 1280x720), got \"" + args.size + "\"",
                        kExitUsage);
  args.options.width = width;
  args.options.height = height;
  if (args.options.scene.empty()) args.options.scene = default_scene_path();
  return viewer::run_viewer(args.options);
}

RunFn setup_view(CLI::App& sub) {
  auto args = std::make_shared<ViewArgs>();
  sub.add_option("scene", args->options.scene, "Scene file (JSON, docs/scenes.md); default: the bundled vase drop");
  sub.add_option("--size", args->size, "Window size WIDTHxHEIGHT (default 1280x720)");
  sub.add_option("--out", args->options.out_dir, "Folder for screenshots (default: the current one)");
  sub.add_option("--script", args->options.script, "Run a script of tool actions and screenshots (docs/viewer.md)");
  sub.add_option("--frames", args->options.frames, "Quit after this many frames")->check(CLI::PositiveNumber);
  sub.add_flag("--fixed-step", args->options.fixed_step, "One simulation step per frame instead of real time");
  sub.add_flag("!--no-vsync", args->options.vsync, "Draw as fast as possible (frame-rate measurements)");
  sub.add_option("--msaa", args->options.msaa, "Multisample anti-aliasing samples (default 0; 4 for smooth edges)")
      ->check(CLI::Range(0, 16));
  return [args] { return view(*args); };
}

const Registration view_command{"view", "Open a scene in the interactive viewer (tools, stress view, recording)",
                                &setup_view};

}  // namespace
}  // namespace shatter::cli
