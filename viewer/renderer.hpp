// Draws a FrameSnapshot with OpenGL 3.3 core into the current framebuffer: the skin lit and
// coloured by region, the wound (the cut surface) in its own colour, the target incision with its
// tolerance band, the blade, and on request the surface see-through and the tetrahedra's edges (the
// paper's views of sections 7.1 and 7.3). A section view clips the tissue by a plane; the inside
// then shows in a flat section colour. Needs a current context; use it on that context's thread.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "sim/snapshot.hpp"
#include "viewer/camera.hpp"

namespace scalpel {

struct RenderOptions {
  bool transparent_skin = false;  // skin at a quarter opacity, so the wound shows through
  bool wireframe = false;         // the tetrahedra's edges (the snapshot must hold them)
  bool target = true;             // the target incision and its tolerance band
  bool blade = true;
  bool handle = true;  // the scalpel's handle behind the blade
  // Keep the side where clip.head<3>().dot(x) + clip.w() >= 0 (x in metres); none: everything.
  std::optional<Eigen::Vector4d> clip;
};

// The palette, linear RGB in [0, 1]: the pictures' tests find the wound by it.
struct Palette {
  static constexpr std::array<float, 3> kBackground{0.13f, 0.15f, 0.18f};
  static constexpr std::array<float, 3> kWound{0.62f, 0.02f, 0.08f};
  static constexpr std::array<float, 3> kSection{0.55f, 0.50f, 0.50f};
  static constexpr std::array<float, 3> kTarget{0.10f, 0.80f, 0.95f};
  static constexpr std::array<float, 3> kBlade{0.86f, 0.87f, 0.90f};
  static constexpr std::array<float, 3> kHandle{0.20f, 0.35f, 0.65f};
  // Skin regions by id: epidermis, dermis, fat, muscle; further regions take the last.
  static constexpr std::array<std::array<float, 3>, 4> kRegions{
      {{0.93f, 0.78f, 0.66f}, {0.86f, 0.60f, 0.55f}, {0.96f, 0.86f, 0.45f}, {0.72f, 0.30f, 0.28f}}};
};

class Renderer {
 public:
  Renderer();  // compiles the shaders; throws RenderError
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  void draw(const FrameSnapshot& snapshot, const Camera& camera, const RenderOptions& options, int width,
            int height);

 private:
  struct FlatVertex {
    std::array<float, 3> position;
    std::array<float, 4> colour;
  };
  void build_overlays(const FrameSnapshot& s, const RenderOptions& o);
  void draw_flat(unsigned mode, const std::vector<FlatVertex>& vertices);

  unsigned surface_program_ = 0, flat_program_ = 0;
  unsigned surface_vao_ = 0, surface_vbo_ = 0, flat_vao_ = 0, flat_vbo_ = 0;
  std::vector<FlatVertex> triangles_, lines_;  // overlays, rebuilt every frame
};

}  // namespace scalpel
