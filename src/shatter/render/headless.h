// An OpenGL 3.3 core context without a window, through EGL (Mesa's llvmpipe renders on the CPU
// where there is no GPU): `shatter render` and the render tests.
#pragma once

#include <memory>

#include "shatter/core/error.h"

namespace shatter::render {

class HeadlessContext {
 public:
  /// Make a context and make it current on this thread. Errors say which EGL step failed.
  static Result<std::unique_ptr<HeadlessContext>> create();
  ~HeadlessContext();
  HeadlessContext(const HeadlessContext&) = delete;
  HeadlessContext& operator=(const HeadlessContext&) = delete;

 private:
  HeadlessContext() = default;
  void* display_ = nullptr;
  void* context_ = nullptr;
  void* surface_ = nullptr;
};

}  // namespace shatter::render
