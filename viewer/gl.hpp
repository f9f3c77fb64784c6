// OpenGL 3.3 core, called through libOpenGL (GLVND): its entry points are exported whole, and
// dispatch to the vendor of whichever context is current, an EGL one offscreen or GLFW's in a
// window, so no loader is needed.
#pragma once

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/gl.h>
#include <GL/glext.h>

#include <stdexcept>
#include <string>

namespace scalpel {

// No usable OpenGL: no 3.3 context, no display, a shader that does not compile.
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace scalpel
