// An OpenGL 3.3 core context with no window and no display: EGL on Mesa's surfaceless platform,
// rendering with whatever driver Mesa picks (llvmpipe, its software rasteriser, on a machine with no
// GPU). Pictures are drawn into framebuffer objects. One context per thread that renders.
#pragma once

namespace scalpel {

class OffscreenContext {
 public:
  // Creates the context and makes it current on the calling thread. Throws RenderError, saying
  // what is missing, when EGL or a 3.3 core context is not available.
  OffscreenContext();
  ~OffscreenContext();
  // Makes it current on the calling thread (another context may have been).
  void make_current();
  OffscreenContext(const OffscreenContext&) = delete;
  OffscreenContext& operator=(const OffscreenContext&) = delete;

 private:
  void* display_ = nullptr;
  void* context_ = nullptr;
};

}  // namespace scalpel
