#include "viewer/offscreen_context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <string>

#include "viewer/gl.hpp"

namespace scalpel {

namespace {

std::string egl_error(const char* what) {
  char code[16];
  std::snprintf(code, sizeof code, "0x%04x", static_cast<unsigned>(eglGetError()));
  return std::string("offscreen rendering: ") + what + " (EGL error " + code + ")";
}

}  // namespace

OffscreenContext::OffscreenContext() {
  const auto get_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!get_display) throw RenderError("offscreen rendering: EGL has no eglGetPlatformDisplayEXT");
  EGLDisplay display = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  // Initialising the display again (a second context) is harmless.
  if (display == EGL_NO_DISPLAY || !eglInitialize(display, &major, &minor))
    throw RenderError(
        egl_error("no EGL surfaceless display (install Mesa's libegl-mesa0 and libgl1-mesa-dri)"));
  display_ = display;
  if (!eglBindAPI(EGL_OPENGL_API)) {
    throw RenderError(egl_error("EGL cannot bind desktop OpenGL"));
  }
  const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                               3,
                               EGL_CONTEXT_MINOR_VERSION,
                               3,
                               EGL_CONTEXT_OPENGL_PROFILE_MASK,
                               EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                               EGL_NONE};
  // Configless: the context draws only into framebuffer objects.
  EGLContext context = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attributes);
  if (context == EGL_NO_CONTEXT) {
    throw RenderError(egl_error("no OpenGL 3.3 core context"));
  }
  context_ = context;
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
    eglDestroyContext(display, context);
    throw RenderError(egl_error("cannot make the context current"));
  }
}

void OffscreenContext::make_current() {
  if (eglGetCurrentContext() != context_ &&
      !eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    throw RenderError(egl_error("cannot make the context current"));
}

OffscreenContext::~OffscreenContext() {
  if (eglGetCurrentContext() == context_)
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(display_, context_);
  // The display is the process's one surfaceless display, shared by every context: not terminated.
}

}  // namespace scalpel
