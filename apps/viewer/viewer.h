// `shatter view`: a window on a scene (GLFW, Dear ImGui, the renderer) with the paper's tools:
// pick and drag, hammer, press, slice, drop and throw; play, pause, step, a recording to scrub, the
// stress view, statistics and an event log (docs/viewer.md). Every tool goes through the public
// World API (strike, press, apply_impulse, add_body), as an embedding program would.
#pragma once

#include <string>

namespace shatter::viewer {

struct ViewerOptions {
  std::string scene;          ///< scene file
  std::string script;         ///< JSON script of tool actions and screenshots ("" for none; docs/viewer.md)
  std::string out_dir = ".";  ///< where screenshots go
  int width = 1280;
  int height = 720;
  int frames = -1;          ///< quit after this many frames (-1: when the window closes)
  bool fixed_step = false;  ///< one simulation step per frame (scripts, frame-rate runs), not real time
  bool vsync = true;
  /// Multisampling of the window (0: none; 4 halves the frame rate of a software rasterizer).
  int msaa = 0;
};

/// Run the viewer until the window closes (or the script or frame count ends). Returns the exit
/// code: 0, 1 when no window can be opened (the message suggests `shatter render`), 3 for a bad
/// scene or script.
int run_viewer(const ViewerOptions& options);

}  // namespace shatter::viewer
