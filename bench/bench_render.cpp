// The window's cost (viewer/): the snapshot the simulation thread fills after each frame, and the
// render thread's frame, on the bundled skin patch (4 950 tetrahedra) and on the same patch at
// twice the resolution in the plane (19 800), both cut by the bundled incision: the scene as the
// window draws it, and a picture as `replay --images` writes it. Rendering is offscreen (EGL); on a
// machine without a GPU Mesa draws with llvmpipe. Prints p50 and p99.
//
//   ./build/release/bench/bench_render [frames]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "sim/quantile.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "viewer/gl.hpp"
#include "viewer/pictures.hpp"
#include "viewer/renderer.hpp"

using namespace scalpel;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

struct Cut {
  FrameSnapshot snapshot, with_edges;
  std::vector<double> fill_seconds, fill_edges_seconds;
  double frame_seconds_p50 = 0;  // the simulation's own frame, for scale
};

// Replays the bundled incision on the bundled scenario with `cells` in the plane; at the last frame
// fills the snapshot `fills` times, timed.
Cut cut_patch(const std::string& cells, int fills) {
  const fs::path file = fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml";
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const std::string key = "cells: [15, 11]";
  yaml.replace(yaml.find(key), key.size(), "cells: " + cells);
  const Scenario scenario = parse_scenario(yaml, file.string(), file.parent_path());
  Cut c;
  ReplayOptions options;
  options.out_dir = fs::temp_directory_path() / "scalpelsim_bench_render";
  options.on_frame = [&](const Simulation& sim, std::size_t, bool last) {
    if (!last) return;
    for (int i = 0; i < fills; ++i) {
      const auto t0 = Clock::now();
      sim.snapshot(c.snapshot);
      const auto t1 = Clock::now();
      sim.snapshot(c.with_edges, true);
      const auto t2 = Clock::now();
      c.fill_seconds.push_back(std::chrono::duration<double>(t1 - t0).count());
      c.fill_edges_seconds.push_back(std::chrono::duration<double>(t2 - t1).count());
    }
  };
  const ReplayResult r = replay(scenario, *scenario.log, options);
  c.frame_seconds_p50 = 1e-3 * r.run["timings"]["frame_ms"]["p50"].get<double>();
  return c;
}

// `picture`: drawn multisampled, resolved and read back, as `replay --images` does; otherwise only
// drawn, as the window does (without its overlay and swap).
void render(const char* name, OffscreenRenderer& renderer, const FrameSnapshot& s, const RenderOptions& o,
            int frames, bool picture) {
  const Camera camera = replay_views(s, static_cast<double>(renderer.width()) / renderer.height())[1].camera;
  std::vector<double> t;
  for (int i = 0; i < frames; ++i) {
    const auto t0 = Clock::now();
    if (picture)
      (void)renderer.render(s, camera, o);
    else
      renderer.draw(s, camera, o);
    t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  std::printf("  %-44s p50 %6.2f ms  p99 %6.2f ms\n", name, 1e3 * quantile(t, 0.5), 1e3 * quantile(t, 0.99));
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::max(1, std::atoi(argv[1])) : 100;
  OffscreenRenderer window(1024, 640, 1), pictures(1200, 900, 4);
  std::printf("renderer: %s, %s\n", reinterpret_cast<const char*>(glGetString(GL_RENDERER)),
              reinterpret_cast<const char*>(glGetString(GL_VERSION)));
  for (const auto& [cells, label] : {std::pair{std::string("[15, 11]"), "bundled patch"},
                                     std::pair{std::string("[30, 22]"), "patch at twice the resolution"}}) {
    const Cut c = cut_patch(cells, frames);
    std::printf("%s, cut: %zu tetrahedra, %zu surface triangles (%zu wound), %zu edges\n", label,
                c.snapshot.tetrahedra, c.snapshot.surface.size() / 3, c.snapshot.wound_vertices / 3,
                c.with_edges.edges.size() / 2);
    std::printf("  %-44s p50 %6.2f ms  p99 %6.2f ms  (simulation frame p50 %.2f ms)\n",
                "snapshot (simulation thread)", 1e3 * quantile(c.fill_seconds, 0.5),
                1e3 * quantile(c.fill_seconds, 0.99), 1e3 * c.frame_seconds_p50);
    std::printf("  %-44s p50 %6.2f ms  p99 %6.2f ms\n", "snapshot with edges",
                1e3 * quantile(c.fill_edges_seconds, 0.5), 1e3 * quantile(c.fill_edges_seconds, 0.99));
    RenderOptions plain, see_through, edges;
    see_through.transparent_skin = true;
    edges.wireframe = true;
    render("scene as the window draws it, 1024 x 640", window, c.snapshot, plain, frames, false);
    render("  see-through skin", window, c.snapshot, see_through, frames, false);
    render("  tetrahedra", window, c.with_edges, edges, frames, false);
    render("picture, 1200 x 900, 4x multisampled, read back", pictures, c.snapshot, plain, frames, true);
  }
  return 0;
}
