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
  // With a field in the snapshot: the surface coloured by it, and its colour bar at the right edge.
  bool field = true;
  bool legend = true;
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
  // The colour maps (ColourMap) at nine evenly spaced values, interpolated linearly between them:
  // matplotlib's viridis and seismic.
  using ColourMapStops = std::array<std::array<float, 3>, 9>;
  static constexpr ColourMapStops kViridis{{{0.267f, 0.005f, 0.329f},
                                            {0.279f, 0.175f, 0.483f},
                                            {0.230f, 0.322f, 0.546f},
                                            {0.173f, 0.449f, 0.558f},
                                            {0.128f, 0.567f, 0.551f},
                                            {0.158f, 0.684f, 0.502f},
                                            {0.369f, 0.789f, 0.383f},
                                            {0.678f, 0.864f, 0.190f},
                                            {0.993f, 0.906f, 0.144f}}};
  static constexpr ColourMapStops kSeismic{{{0.000f, 0.000f, 0.300f},
                                            {0.000f, 0.000f, 0.651f},
                                            {0.004f, 0.004f, 1.000f},
                                            {0.506f, 0.506f, 1.000f},
                                            {1.000f, 0.992f, 0.992f},
                                            {1.000f, 0.490f, 0.490f},
                                            {0.994f, 0.000f, 0.000f},
                                            {0.743f, 0.000f, 0.000f},
                                            {0.500f, 0.000f, 0.000f}}};
  [[nodiscard]] static const ColourMapStops& stops(ColourMap map) {
    return map == ColourMap::Viridis ? kViridis : kSeismic;
  }
  // The colour `map` gives `value` on the range [lo, hi] (clamped), as the shader computes it.
  [[nodiscard]] static std::array<float, 3> colour(ColourMap map, double value, double lo, double hi);
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
  // The field's colour bar with its name and values, in pixels from the top left.
  void build_legend(const FrameSnapshot::Field& field, int width, int height);
  void draw_flat(unsigned mode, const std::vector<FlatVertex>& vertices);

  unsigned surface_program_ = 0, flat_program_ = 0;
  unsigned surface_vao_ = 0, surface_vbo_ = 0, flat_vao_ = 0, flat_vbo_ = 0;
  std::vector<FlatVertex> triangles_, lines_, legend_;  // overlays, rebuilt every frame
  std::vector<char> text_;                              // stb_easy_font's quads
};

}  // namespace scalpel
