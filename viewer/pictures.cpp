#include "viewer/pictures.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <stb_image_write.h>

#include "viewer/gl.hpp"
#include "viewer/offscreen_context.hpp"

namespace scalpel {

void write_png(const Image& image, const std::filesystem::path& path) {
  if (!stbi_write_png(path.string().c_str(), image.width, image.height, 3, image.rgb.data(), image.width * 3))
    throw std::runtime_error("cannot write the picture " + path.string());
}

Image read_pixels(int width, int height) {
  Image image{width, height, std::vector<std::uint8_t>(static_cast<std::size_t>(width) * height * 3)};
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, image.rgb.data());
  // OpenGL's rows run from the bottom.
  const std::size_t row = static_cast<std::size_t>(width) * 3;
  for (int y = 0; y < height / 2; ++y)
    std::swap_ranges(image.rgb.begin() + static_cast<std::ptrdiff_t>(y * row),
                     image.rgb.begin() + static_cast<std::ptrdiff_t>((y + 1) * row),
                     image.rgb.begin() + static_cast<std::ptrdiff_t>((height - 1 - y) * row));
  return image;
}

OffscreenRenderer::OffscreenRenderer(int width, int height, int samples)
    : context_(std::make_unique<OffscreenContext>()), width_(width), height_(height) {
  renderer_ = std::make_unique<Renderer>();
  glGenFramebuffers(1, &multisampled_fbo_);
  glGenRenderbuffers(1, &colour_rb_);
  glGenRenderbuffers(1, &depth_rb_);
  glBindFramebuffer(GL_FRAMEBUFFER, multisampled_fbo_);
  glBindRenderbuffer(GL_RENDERBUFFER, colour_rb_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples > 1 ? samples : 0, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_rb_);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_rb_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples > 1 ? samples : 0, GL_DEPTH_COMPONENT24, width,
                                   height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_rb_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw RenderError("offscreen rendering: the multisampled framebuffer is incomplete");
  glGenFramebuffers(1, &resolved_fbo_);
  glGenRenderbuffers(1, &resolved_rb_);
  glBindFramebuffer(GL_FRAMEBUFFER, resolved_fbo_);
  glBindRenderbuffer(GL_RENDERBUFFER, resolved_rb_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, resolved_rb_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw RenderError("offscreen rendering: the framebuffer is incomplete");
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

OffscreenRenderer::~OffscreenRenderer() {
  try {
    context_->make_current();
  } catch (const RenderError&) {
    return;  // the context is gone; so are its objects
  }
  renderer_.reset();
  glDeleteFramebuffers(1, &multisampled_fbo_);
  glDeleteFramebuffers(1, &resolved_fbo_);
  glDeleteRenderbuffers(1, &colour_rb_);
  glDeleteRenderbuffers(1, &depth_rb_);
  glDeleteRenderbuffers(1, &resolved_rb_);
}

void OffscreenRenderer::draw(const FrameSnapshot& snapshot, const Camera& camera,
                             const RenderOptions& options) {
  context_->make_current();
  glBindFramebuffer(GL_FRAMEBUFFER, multisampled_fbo_);
  renderer_->draw(snapshot, camera, options, width_, height_);
  glFinish();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

Image OffscreenRenderer::render(const FrameSnapshot& snapshot, const Camera& camera,
                                const RenderOptions& options) {
  context_->make_current();
  glBindFramebuffer(GL_FRAMEBUFFER, multisampled_fbo_);
  glEnable(GL_MULTISAMPLE);
  renderer_->draw(snapshot, camera, options, width_, height_);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, multisampled_fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, resolved_fbo_);
  glBlitFramebuffer(0, 0, width_, height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, resolved_fbo_);
  Image image = read_pixels(width_, height_);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return image;
}

std::vector<View> replay_views(const FrameSnapshot& s, double aspect) {
  const Vec3 lo = s.bounds_min, hi = s.bounds_max;
  const Vec3 centre = (lo + hi) / 2;
  const Vec3 extent = hi - lo;
  // The target's middle and direction; without a task, the patch's top centre along x.
  Vec3 focus(centre.x(), centre.y(), hi.z()), along = Vec3::UnitX();
  double length = extent.x() / 2;
  if (!s.targets.empty()) {
    const Vec3 a = s.targets.front().path.front(), b = s.targets.front().path.back();
    focus = (a + b) / 2;
    along = Vec3(b.x() - a.x(), b.y() - a.y(), 0.0);
    length = along.norm();
    along = length > 0 ? Vec3(along / length) : Vec3::UnitX();
  }
  const double heading = std::atan2(along.y(), along.x());
  std::vector<View> views;

  View top{"top", {}, {}};
  top.camera.target = Vec3(centre.x(), centre.y(), hi.z());
  top.camera.pitch = M_PI / 2;
  top.camera.yaw = -M_PI / 2;
  top.camera.distance = std::max(extent.norm(), 1e-3) * 2;
  top.camera.ortho_half_height = 0.55 * std::max(extent.y(), extent.x() / aspect);
  top.options.handle = false;  // from above, it would hide the wound
  views.push_back(top);

  View oblique{"oblique", {}, {}};
  oblique.camera.target = focus;
  oblique.camera.yaw = heading - M_PI / 2 - 0.5;
  oblique.camera.pitch = 0.75;
  oblique.camera.distance =
      std::max(1.4 * length, 0.5 * extent.norm()) / std::tan(oblique.camera.fov_y / 2) / 2;
  views.push_back(oblique);

  // Looking along the incision at the plane through its middle, the far half kept.
  View section{"section", {}, {}};
  section.camera.target = Vec3(focus.x(), focus.y(), focus.z() - 0.4 * extent.z());
  section.camera.yaw = heading;
  section.camera.pitch = 0.0;
  section.camera.distance = std::max(extent.norm(), 1e-3) * 2;
  section.camera.ortho_half_height = 0.55 * std::max(1.6 * extent.z(), 0.4 * length / aspect + 0.0);
  section.options.clip = Eigen::Vector4d(-along.x(), -along.y(), 0.0, along.head<2>().dot(focus.head<2>()));
  section.options.target = false;
  views.push_back(section);

  // Volume data (paper section 7.1, Fig. 14): the outer surface see-through, so the cut faces show
  // the field inside; then the same with the tetrahedra's edges (the snapshot must hold them).
  View inside{"inside", oblique.camera, {}};
  inside.options.transparent_skin = true;
  inside.options.target = false;
  if (s.field) views.push_back(inside);
  // Sculpting (section 7.3, Fig. 16b): the refinement near the cut surfaces, with every edge.
  if (!s.edges.empty()) {
    View mesh = inside;
    mesh.name = "mesh";
    mesh.options.wireframe = true;
    views.push_back(mesh);
  }
  return views;
}

std::vector<std::filesystem::path> write_views(OffscreenRenderer& renderer, const FrameSnapshot& snapshot,
                                               const std::vector<View>& views,
                                               const std::filesystem::path& out_dir,
                                               const std::string& prefix) {
  std::filesystem::create_directories(out_dir);
  std::vector<std::filesystem::path> written;
  for (const View& v : views) {
    const std::filesystem::path path = out_dir / (prefix + v.name + ".png");
    write_png(renderer.render(snapshot, v.camera, v.options), path);
    written.push_back(path);
  }
  return written;
}

}  // namespace scalpel

#include <cstdio>

#include "sim/simulation.hpp"

namespace scalpel {

ReplayPictures::ReplayPictures(PictureOptions options)
    : options_(std::move(options)), renderer_(options_.width, options_.height) {}

void ReplayPictures::operator()(const Simulation& sim, std::size_t frame, bool last) {
  const bool sequence = options_.every > 0 && frame % options_.every == 0;
  if (!sequence && !last) return;
  sim.snapshot(snapshot_, /*with_edges=*/last && (sim.scenario().volume || sim.scenario().tissue.rigid));
  snapshot_.frame = frame;
  const auto views = replay_views(snapshot_, static_cast<double>(options_.width) / options_.height);
  if (sequence) {
    char prefix[32];
    std::snprintf(prefix, sizeof prefix, "oblique_%06zu", frame);
    const View oblique = views[1];
    std::filesystem::create_directories(options_.dir / "frames");
    const auto path = options_.dir / "frames" / (std::string(prefix) + ".png");
    write_png(renderer_.render(snapshot_, oblique.camera, oblique.options), path);
    written_.push_back(path);
  }
  if (last)
    for (const auto& p : write_views(renderer_, snapshot_, views, options_.dir)) written_.push_back(p);
}

}  // namespace scalpel
