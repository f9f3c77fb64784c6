// The pictures of a replay (viewer/pictures.hpp), checked for what a person would look for in them:
// the wound along the target line and nowhere else, the blade where the last sample put it, and
// the tissue filling the picture. Rendered offscreen (EGL, Mesa); no display needed.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "devices/pose_log.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "viewer/pictures.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

// The wound's colour, lit or in shadow: strongly red. Skin, fat, the target line, the blade and
// the background are not.
bool is_wound(const std::uint8_t* p) {
  return p[0] > 40 && p[0] > 3 * p[1] && p[0] > 3 * p[2];
}
bool is_background(const std::uint8_t* p) {
  const auto& bg = Palette::kBackground;
  for (int c = 0; c < 3; ++c)
    if (std::abs(p[c] - std::lround(bg[static_cast<size_t>(c)] * 255)) > 2) return false;
  return true;
}
// The blade is a light, nearly grey steel.
bool is_blade(const std::uint8_t* p) {
  return p[0] > 120 && p[2] >= p[0] && std::abs(p[0] - p[1]) < 20;
}

double background_fraction(const Image& im) {
  std::size_t n = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) n += is_background(im.at(x, y)) ? 1 : 0;
  return static_cast<double>(n) / (static_cast<double>(im.width) * im.height);
}

struct Replayed {
  Scenario scenario;
  FrameSnapshot last;
  double gape_max = 0.0;            // [m] the report's widest lateral gape
  double cut_from = 0, cut_to = 0;  // [m] x range where the blade's edge crossed the skin surface
};

Replayed replay_bundled() {
  Replayed r{
      load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml"), {}, 0, 0, 0};
  ReplayOptions options;
  options.out_dir = fs::temp_directory_path() / "scalpelsim_test_pictures";
  options.on_frame = [&](const Simulation& sim, std::size_t, bool last) {
    if (last) sim.snapshot(r.last);
  };
  const ReplayResult result = replay(r.scenario, *r.scenario.log, options);
  REQUIRE(result.invariants_ok);
  r.gape_max = result.report["tissue"]["wound_opening"]["max"].get<double>();
  // Where the blade's edge met the rest surface z = 0, over the samples that cut into it.
  const Simulation reference(r.scenario);
  r.cut_from = 1.0;
  r.cut_to = -1.0;
  for (const ToolSample& s : read_pose_log(r.scenario.log->string())) {
    const BladePose b = reference.blade(s);
    if (b.tip.z() >= 0.0 || b.back.z() <= 0.0) continue;
    const double u = b.back.z() / (b.back.z() - b.tip.z());
    const double x = (b.back + u * (b.tip - b.back)).x();
    r.cut_from = std::min(r.cut_from, x);
    r.cut_to = std::max(r.cut_to, x);
  }
  REQUIRE(r.cut_from < r.cut_to);
  return r;
}

}  // namespace

TEST_CASE("the bundled replay's pictures show the gaping wound along the target line, and the blade" *
          doctest::test_suite("slow")) {
  const Replayed r = replay_bundled();
  constexpr int kWidth = 800, kHeight = 600;
  OffscreenRenderer renderer(kWidth, kHeight);
  const std::vector<View> views = replay_views(r.last, static_cast<double>(kWidth) / kHeight);
  REQUIRE(views.size() == 3);
  const View& top = views[0];
  REQUIRE(top.name == "top");
  REQUIRE(top.camera.ortho_half_height > 0.0);
  const Image image = renderer.render(r.last, top.camera, top.options);

  // The top view is orthographic: a pixel is a fixed square of the xy plane.
  const double metres_per_pixel = 2 * top.camera.ortho_half_height / kHeight;
  const Vec3 origin = top.camera.project(Vec3::Zero(), kWidth, kHeight);
  const auto world_x = [&](int px) { return (px + 0.5 - origin.x()) * metres_per_pixel; };
  const auto world_y = [&](int py) { return -(py + 0.5 - origin.y()) * metres_per_pixel; };

  // The target path runs along y = 0 from x = -10 to 10 mm.
  const Incision& task = r.scenario.task->incisions.front();
  REQUIRE(task.path.size() == 2);
  REQUIRE(task.path[0].y() == 0.0);
  REQUIRE(task.path[1].y() == 0.0);
  // Lips stand at most half the widest gape off the cut, the cut at most the tolerance off the path.
  const double lateral = task.tolerance + r.gape_max / 2 + 2 * metres_per_pixel;
  const double margin = 0.5e-3 + 2 * metres_per_pixel;  // the skin's retraction along the cut
  // The blade lies over the wound's end: look at the wound without it.
  RenderOptions no_blade = top.options;
  no_blade.blade = false;
  const Image wound_image = renderer.render(r.last, top.camera, no_blade);
  std::size_t wound = 0, stray = 0;
  std::vector<int> columns(kWidth, 0);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      if (!is_wound(wound_image.at(x, y))) continue;
      ++wound;
      const double wx = world_x(x), wy = world_y(y);
      if (std::abs(wy) > lateral || wx < r.cut_from - margin || wx > r.cut_to + margin) ++stray;
      columns[static_cast<size_t>(x)] = 1;
    }
  MESSAGE("wound pixels " << wound << ", stray " << stray << "; cut from " << r.cut_from * 1e3 << " to "
                          << r.cut_to * 1e3 << " mm, gape max " << r.gape_max * 1e3 << " mm");
  CHECK(stray == 0);
  // The wound is open along the target path, from 1 mm inside its ends. Where the blade lifts out
  // the lips may still be joined at the skin over a fraction of a millimetre (a bridge, counted in
  // the report's wound_opening): 95 % of the pixel columns.
  int open = 0, columns_on_path = 0;
  for (int x = 0; x < kWidth; ++x) {
    const double wx = world_x(x);
    if (wx < task.path[0].x() + 1e-3 || wx > task.path[1].x() - 1e-3) continue;
    ++columns_on_path;
    open += columns[static_cast<size_t>(x)];
  }
  CHECK(columns_on_path > 100);
  MESSAGE("wound open over " << open << " of " << columns_on_path << " pixel columns along the path");
  CHECK(open >= 0.95 * columns_on_path);
  // It gapes: wider than a crack, about its measured width.
  CHECK(static_cast<double>(wound) * metres_per_pixel * metres_per_pixel > 0.5 * 0.020 * r.gape_max / 2);

  // The blade: the middle of its edge, where the last sample put it, is drawn in steel.
  REQUIRE(r.last.has_blade);
  const Vec3 middle = top.camera.project((r.last.blade_back + r.last.blade_tip) / 2, kWidth, kHeight);
  REQUIRE(middle.x() >= 1);
  REQUIRE(middle.y() >= 1);
  REQUIRE(middle.x() < kWidth - 1);
  REQUIRE(middle.y() < kHeight - 1);
  bool blade = false;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      blade =
          blade || is_blade(image.at(static_cast<int>(middle.x()) + dx, static_cast<int>(middle.y()) + dy));
  CHECK(blade);

  // Every view shows the tissue, and the wound in it.
  for (const View& v : views) {
    const Image im = v.name == "top" ? image : renderer.render(r.last, v.camera, v.options);
    std::size_t red = 0;
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x) red += is_wound(im.at(x, y)) ? 1 : 0;
    INFO("view " << v.name);
    CHECK(background_fraction(im) < 0.6);
    CHECK(red > 200);
  }
}

TEST_CASE("a picture of the uncut patch shows no wound") {
  const Simulation sim(load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml"));
  FrameSnapshot s;
  sim.snapshot(s);
  OffscreenRenderer renderer(400, 300);
  for (const View& v : replay_views(s, 400.0 / 300.0)) {
    const Image im = renderer.render(s, v.camera, v.options);
    std::size_t red = 0;
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x) red += is_wound(im.at(x, y)) ? 1 : 0;
    INFO("view " << v.name);
    CHECK(red == 0);
    CHECK(background_fraction(im) < 0.6);
  }
}

TEST_CASE("a picture is written as a PNG file") {
  Image im{4, 2, std::vector<std::uint8_t>(24, 200)};
  const fs::path path = fs::temp_directory_path() / "scalpelsim_test_picture.png";
  fs::remove(path);
  write_png(im, path);
  REQUIRE(fs::exists(path));
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  CHECK(std::string(magic + 1, 3) == "PNG");
  CHECK_THROWS(write_png(im, fs::path("/nonexistent-folder/picture.png")));
}

TEST_CASE(
    "volume data: seen through the outer surface, the cut faces show the field in its colour map, and the "
    "colour bar its range" *
    doctest::test_suite("slow")) {
  const Scenario scenario =
      load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/strata_volume.yaml");
  FrameSnapshot last;
  ReplayOptions options;
  options.out_dir = fs::temp_directory_path() / "scalpelsim_test_volume_pictures";
  options.on_frame = [&](const Simulation& sim, std::size_t, bool end) {
    if (end) sim.snapshot(last);
  };
  REQUIRE(replay(scenario, *scenario.log, options).invariants_ok);
  REQUIRE(last.field.has_value());
  CHECK(last.field->name == "amplitude");
  CHECK(last.field->lo == -1.0);
  CHECK(last.field->hi == 1.0);

  constexpr int kWidth = 600, kHeight = 450;
  OffscreenRenderer renderer(kWidth, kHeight, 1);
  const std::vector<View> views = replay_views(last, double(kWidth) / kHeight);
  const auto inside =
      std::find_if(views.begin(), views.end(), [](const View& v) { return v.name == "inside"; });
  REQUIRE(inside != views.end());
  CHECK(inside->options.transparent_skin);
  // Bright, saturated blue and red: opaque faces in the map's two halves (the see-through skin is
  // dim over the dark background). Left of the colour bar.
  auto count = [&](const Image& im) {
    std::array<std::size_t, 2> n{};
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width * 8 / 10; ++x) {
        const std::uint8_t* p = im.at(x, y);
        if (p[2] > 150 && p[0] < 90 && p[1] < 90) ++n[0];
        if (p[0] > 150 && p[1] < 90 && p[2] < 90) ++n[1];
      }
    return n;
  };
  const Image coloured = renderer.render(last, inside->camera, inside->options);
  const auto [blue, red] = count(coloured);
  CHECK(blue > 500);
  CHECK(red > 500);
  // The colour bar: the top of the map at its top, the bottom at its bottom, unlit.
  const int bar_x = kWidth - static_cast<int>(0.03 * kWidth) - static_cast<int>(0.0125 * kWidth);
  const auto top = Palette::colour(ColourMap::Seismic, 1.0, -1.0, 1.0);
  const auto bottom = Palette::colour(ColourMap::Seismic, -1.0, -1.0, 1.0);
  const std::uint8_t* t = coloured.at(bar_x, static_cast<int>(0.225 * kHeight));
  const std::uint8_t* b = coloured.at(bar_x, static_cast<int>(0.775 * kHeight));
  for (std::size_t c = 0; c < 3; ++c) {
    CHECK(std::abs(t[c] - top[c] * 255) < 12);
    CHECK(std::abs(b[c] - bottom[c] * 255) < 12);
  }
  // Coloured by region instead: the cut faces are the wound's red, nothing blue.
  RenderOptions by_region = inside->options;
  by_region.field = false;
  CHECK(count(renderer.render(last, inside->camera, by_region))[0] == 0);
}
