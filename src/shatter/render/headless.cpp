#include "shatter/render/headless.h"

#include <epoxy/egl.h>

#include <string>

namespace shatter::render {
namespace {

std::string egl_error(const char* what) {
  char code[16];
  std::snprintf(code, sizeof code, "0x%04x", static_cast<unsigned>(eglGetError()));
  return std::string("headless OpenGL: ") + what + " failed (EGL error " + code + ")";
}

}  // namespace

Result<std::unique_ptr<HeadlessContext>> HeadlessContext::create() {
  std::unique_ptr<HeadlessContext> c(new HeadlessContext);
  EGLDisplay display = EGL_NO_DISPLAY;
  // Mesa's surfaceless platform needs no X server or device; else the default display.
  if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless"))
    display = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (display == EGL_NO_DISPLAY) display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (display == EGL_NO_DISPLAY) return make_error(egl_error("eglGetDisplay"));
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor)) return make_error(egl_error("eglInitialize"));
  c->display_ = display;
  if (!eglBindAPI(EGL_OPENGL_API)) return make_error(egl_error("eglBindAPI(OpenGL)"));
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT,
                                   EGL_RENDERABLE_TYPE,
                                   EGL_OPENGL_BIT,
                                   EGL_RED_SIZE,
                                   8,
                                   EGL_GREEN_SIZE,
                                   8,
                                   EGL_BLUE_SIZE,
                                   8,
                                   EGL_DEPTH_SIZE,
                                   24,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglChooseConfig(display, config_attribs, &config, 1, &count) || count < 1) {
    // Surfaceless displays may offer no pbuffer configs: take any OpenGL one.
    const EGLint any[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    if (!eglChooseConfig(display, any, &config, 1, &count) || count < 1)
      return make_error(egl_error("eglChooseConfig (no OpenGL configuration)"));
  }
  const EGLint context_attribs[] = {
      EGL_CONTEXT_MAJOR_VERSION,           3,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
  if (context == EGL_NO_CONTEXT) return make_error(egl_error("eglCreateContext (OpenGL 3.3 core)"));
  c->context_ = context;
  // Rendering goes to our own framebuffers: no surface where the driver allows it.
  EGLSurface surface = EGL_NO_SURFACE;
  if (!epoxy_has_egl_extension(display, "EGL_KHR_surfaceless_context")) {
    const EGLint pbuffer_attribs[] = {EGL_WIDTH, 16, EGL_HEIGHT, 16, EGL_NONE};
    surface = eglCreatePbufferSurface(display, config, pbuffer_attribs);
    if (surface == EGL_NO_SURFACE) return make_error(egl_error("eglCreatePbufferSurface"));
    c->surface_ = surface;
  }
  if (!eglMakeCurrent(display, surface, surface, context)) return make_error(egl_error("eglMakeCurrent"));
  return c;
}

HeadlessContext::~HeadlessContext() {
  if (!display_) return;
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (surface_) eglDestroySurface(display_, surface_);
  if (context_) eglDestroyContext(display_, context_);
  // The display is not terminated: EGL displays are shared by the whole process (a second context
  // gets the same one), and terminating unloads the driver, whose remaining allocations then
  // show up as leaks.
}

}  // namespace shatter::render
