// The OpenGL 3.3 core renderer behind `shatter view` and `shatter render` (docs/viewer.md): lit
// bodies with a shadow map, a ground with the bodies' shadows projected onto it, per-material
// looks with solid textures on crack faces, the stress view (the paper's Fig. 7: per tet, tension
// red, compression green, the larger in magnitude) with its legend, and marks of impacts and crack
// planes. It draws into whatever framebuffer is bound, in the GL context current when it was made;
// that framebuffer needs a depth buffer and, for the ground's shadows, a stencil buffer (without
// one, the ground is drawn without the bodies' shadows).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/render/camera.h"
#include "shatter/render/frame.h"
#include "shatter/render/image.h"

namespace shatter::render {

/// What to show.
enum class ViewMode : std::uint8_t {
  material,  ///< the bodies' looks
  stress,    ///< display stress per tet (red tension, green compression)
};

/// A rectangle of the framebuffer drawn into (the width x height given to Renderer::draw), pixels,
/// from its top-left corner.
struct PixelRect {
  int x = 0, y = 0, width = 0, height = 0;
};

struct RenderOptions {
  ViewMode view = ViewMode::material;
  /// Stress that takes the full colour, Pa (0: the largest magnitude in the frame, at least 1 kPa).
  double stress_scale = 0;
  bool shadows = true;
  bool marks = true;   ///< impact points and crack planes
  bool legend = true;  ///< the stress view's colour bar and scale
  bool ground = true;
  Vec3 background{0.62, 0.68, 0.76};  ///< linear RGB
  Vec3 light{0.45, 1.0, 0.3};         ///< toward the sun (a directional light), any length
  /// Where opaque panels will be drawn over the picture: the scene is not shaded there (a software
  /// rasterizer spends most of a frame shading). Those pixels keep the background, but for the
  /// marks and the stress legend, which are drawn over everything.
  std::vector<PixelRect> covered;
};

/// Per frame: what it drew.
struct RenderStats {
  std::int64_t bodies = 0;
  std::int64_t triangles = 0;
  double stress_scale = 0;  ///< Pa, the legend's full scale
};

class Renderer {
 public:
  /// Needs a current OpenGL 3.3 (or later) core context. Errors: an older context, a shader
  /// that does not compile (with the driver's log).
  static Result<std::unique_ptr<Renderer>> create();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Draw the frame into the bound framebuffer of width x height pixels.
  RenderStats draw(const DrawFrame& frame, const Camera& camera, int width, int height, const RenderOptions& options);

  /// The GL_RENDERER string (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
  [[nodiscard]] const std::string& device() const { return device_; }

  struct Impl;

 private:
  Renderer();
  std::unique_ptr<Impl> impl_;
  std::string device_;
};

/// An offscreen framebuffer (multisampled, resolved on read) to render into and read back.
class OffscreenTarget {
 public:
  /// Errors: an incomplete framebuffer. Needs a current context.
  static Result<std::unique_ptr<OffscreenTarget>> create(int width, int height, int samples = 4);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;
  void bind();
  /// Resolve and read the pixels (row 0 at the top).
  [[nodiscard]] Image read();
  [[nodiscard]] int width() const { return width_; }
  [[nodiscard]] int height() const { return height_; }

 private:
  OffscreenTarget() = default;
  int width_ = 0, height_ = 0;
  unsigned fbo_ = 0, color_ = 0, depth_ = 0, resolve_fbo_ = 0, resolve_color_ = 0;
};

/// Read back the bound framebuffer of width x height pixels (row 0 at the top).
Image read_framebuffer(int width, int height);

}  // namespace shatter::render
