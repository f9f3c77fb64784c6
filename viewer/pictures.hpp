// Pictures without a display: the renderer draws into framebuffer objects of an offscreen context
// (viewer/offscreen_context.hpp), and the pictures go to PNG files through stb_image_write.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/snapshot.hpp"
#include "viewer/camera.hpp"
#include "viewer/renderer.hpp"

namespace scalpel {

// An RGB picture, 8 bits per channel, rows from the top.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  [[nodiscard]] const std::uint8_t* at(int x, int y) const {
    return &rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                 static_cast<std::size_t>(x)) *
                3];
  }
};

// The current read framebuffer's pixels, width x height from the origin, rows from the top.
[[nodiscard]] Image read_pixels(int width, int height);

// Writes `image` as a PNG file; throws std::runtime_error naming the file when it cannot.
void write_png(const Image& image, const std::filesystem::path& path);

class OffscreenContext;

// Draws snapshots into pictures of one size, multisampled `samples` times (1: not). Owns its
// context: create and use it on one thread.
class OffscreenRenderer {
 public:
  OffscreenRenderer(int width, int height, int samples = 4);  // throws RenderError
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  [[nodiscard]] Image render(const FrameSnapshot& snapshot, const Camera& camera,
                             const RenderOptions& options);
  // Draws without reading the picture back, and waits until it is drawn (for timing).
  void draw(const FrameSnapshot& snapshot, const Camera& camera, const RenderOptions& options);
  [[nodiscard]] int width() const { return width_; }
  [[nodiscard]] int height() const { return height_; }

 private:
  std::unique_ptr<OffscreenContext> context_;
  std::unique_ptr<Renderer> renderer_;
  int width_, height_;
  unsigned multisampled_fbo_ = 0, colour_rb_ = 0, depth_rb_ = 0;
  unsigned resolved_fbo_ = 0, resolved_rb_ = 0;
};

// The named views of a replay's pictures, framed on the snapshot's tissue and target:
// - top: straight down, orthographic (a pixel is a fixed square of the skin), the whole patch;
// - oblique: from the front and above, on the target;
// - section: across the middle of the target path, the tissue beyond the plane clipped away, so
//   the incision's depth and its gape show in profile;
// - with a field (volume data): inside, the oblique view with the outer surface see-through;
// - with the tetrahedra's edges in the snapshot: mesh, the same with them drawn.
struct View {
  std::string name;
  Camera camera;
  RenderOptions options;
};
[[nodiscard]] std::vector<View> replay_views(const FrameSnapshot& snapshot, double aspect);

// Writes the views of `snapshot` as out_dir/<prefix><view>.png; returns the files written.
std::vector<std::filesystem::path> write_views(OffscreenRenderer& renderer, const FrameSnapshot& snapshot,
                                               const std::vector<View>& views,
                                               const std::filesystem::path& out_dir,
                                               const std::string& prefix = "");

}  // namespace scalpel

namespace scalpel {

class Simulation;

// The pictures of a replay (`scalpelsim replay --images`): the replay_views of the final frame as
// <dir>/top.png, oblique.png and section.png and, with `every` > 0, the oblique view of every
// every-th frame as <dir>/frames/oblique_<frame>.png. Pass it as ReplayOptions::on_frame.
struct PictureOptions {
  std::filesystem::path dir;
  std::size_t every = 0;  // [frames] 0: the final pictures only
  int width = 1200, height = 900;
};
class ReplayPictures {
 public:
  explicit ReplayPictures(PictureOptions options);  // throws RenderError
  void operator()(const Simulation& sim, std::size_t frame, bool last);
  [[nodiscard]] const std::vector<std::filesystem::path>& written() const { return written_; }

 private:
  PictureOptions options_;
  OffscreenRenderer renderer_;
  FrameSnapshot snapshot_;
  std::vector<std::filesystem::path> written_;
};

}  // namespace scalpel
