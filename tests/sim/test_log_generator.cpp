#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <string>

#include "base/input_error.hpp"
#include "devices/pose_log.hpp"
#include "sim/log_generator.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

Scenario bundled() {
  return load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml");
}

Vec3 tip_of(const Scenario& s, const ToolSample& x) {
  return x.position + x.orientation * s.tool.blade_tip;
}
Vec3 back_of(const Scenario& s, const ToolSample& x) {
  return x.position + x.orientation * s.tool.blade_back;
}

}  // namespace

// The generator steps the scenario's tissue to follow it (IncisionMotion::follow_settled_tissue):
// the tests that make a bundled log take seconds here and minutes at -O0, so they are `slow`.
TEST_CASE("log generator: the bundled log is reproducible byte for byte" * doctest::test_suite("slow")) {
  const Scenario s = bundled();
  REQUIRE(s.log.has_value());
  const fs::path dir = fs::temp_directory_path() / "scalpelsim_test_make_log";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path out = dir / "skin_incision.csv";
  write_task_log(s, out.string());
  const std::string bundled_bytes = read_bytes(*s.log);
  REQUIRE_FALSE(bundled_bytes.empty());
  // Regenerate with: scalpelsim make-log config/scenarios/skin_incision.yaml --out
  // config/logs/skin_incision.csv
  const std::string made = read_bytes(out);
  // Report the first differing line rather than two whole files.
  std::size_t line = 1;
  const auto diff = std::mismatch(made.begin(), made.end(), bundled_bytes.begin(), bundled_bytes.end());
  line += static_cast<std::size_t>(std::count(made.begin(), diff.first, '\n'));
  INFO("first difference on line " << line);
  CHECK(made.size() == bundled_bytes.size());
  CHECK(diff.first == made.end());
  fs::remove_all(dir);
}

// The motion along the task as written, without following the settled tissue: for checks of the
// trajectory's geometry.
IncisionMotion as_written(IncisionMotion m = {}) {
  m.follow_settled_tissue = false;
  return m;
}

// The second bundled log: the same incision with hand tremor, two pull-backs and re-cuts.
IncisionMotion trembling_motion() {
  IncisionMotion m;
  m.tremble = 0.0005;
  m.pull_back = 0.004;
  return m;
}

TEST_CASE("log generator: the bundled tremble and pull-back log is reproducible byte for byte" *
          doctest::test_suite("slow")) {
  const Scenario s = bundled();
  const fs::path dir = fs::temp_directory_path() / "scalpelsim_test_make_log_tremble";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path out = dir / "skin_incision_tremble.csv";
  write_task_log(s, out.string(), trembling_motion());
  // Regenerate with: scalpelsim make-log config/scenarios/skin_incision.yaml --tremble 0.0005
  // --pull-back 0.004 --out config/logs/skin_incision_tremble.csv
  const std::string bundled_bytes =
      read_bytes(fs::path(SCALPEL_SOURCE_DIR) / "config/logs/skin_incision_tremble.csv");
  REQUIRE_FALSE(bundled_bytes.empty());
  CHECK(read_bytes(out) == bundled_bytes);
  // The blade runs backwards along the path while it is in the tissue (the pull-backs), and the
  // tremor moves it across the path.
  const auto made = generate_task_log(s, as_written(trembling_motion()));
  int reversals = 0;
  double across = 0;
  for (std::size_t k = 1; k < made.size(); ++k) {
    reversals += made[k].position.x() < made[k - 1].position.x() && made[k].position.z() < 0.0 ? 1 : 0;
    across = std::max(across, std::abs(made[k].position.y()));
  }
  CHECK(reversals > 100);
  CHECK(across > 0.0001);
  CHECK(across <= 0.00025 + 1e-9);
  fs::remove_all(dir);
}

TEST_CASE("log generator: the bundled crossing log is reproducible and cuts across the first incision" *
          doctest::test_suite("slow")) {
  const Scenario s =
      load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision_cross.yaml");
  CHECK(s.simulation.cut_recursion_depth == 8);
  REQUIRE(s.task->incisions.size() == 2);
  const fs::path dir = fs::temp_directory_path() / "scalpelsim_test_make_log_cross";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path out = dir / "skin_incision_cross.csv";
  write_task_log(s, out.string());
  // Regenerate with: scalpelsim make-log config/scenarios/skin_incision_cross.yaml
  // --out config/logs/skin_incision_cross.csv
  const std::string bundled_bytes =
      read_bytes(fs::path(SCALPEL_SOURCE_DIR) / "config/logs/skin_incision_cross.csv");
  REQUIRE_FALSE(bundled_bytes.empty());
  CHECK(read_bytes(out) == bundled_bytes);
  // The task's two incisions are the first incision and a second across its middle (--cross) made
  // one after the other.
  IncisionMotion cross = as_written();
  cross.cross = 0.012;
  const auto two = generate_task_log(s, as_written());
  const auto made = generate_task_log(bundled(), cross);
  REQUIRE(made.size() == two.size());
  for (std::size_t k = 0; k < made.size(); ++k) CHECK(made[k].position == two[k].position);
  // The first incision as without --cross, then the tool leaves the tissue and draws a second one
  // along y through the middle of the first, at the same depth.
  const auto single = generate_task_log(bundled(), as_written());
  REQUIRE(made.size() > single.size());
  for (std::size_t k = 0; k < single.size(); ++k) {
    CHECK(made[k].t == single[k].t);
    CHECK(made[k].position == single[k].position);
  }
  double y_lo = 0, y_hi = 0, x_far = 0, z_lo = 0;
  for (std::size_t k = single.size(); k < made.size(); ++k) {
    CHECK(made[k].t > made[k - 1].t);
    const ToolSample& a = made[k];
    const Vec3 tip = a.position + a.orientation * s.tool.blade_tip;
    if (tip.z() >= 0.0) continue;
    y_lo = std::min(y_lo, tip.y());
    y_hi = std::max(y_hi, tip.y());
    x_far = std::max(x_far, std::abs(tip.x()));
    z_lo = std::min(z_lo, tip.z());
  }
  CHECK(y_lo == doctest::Approx(-0.006).epsilon(1e-6));
  CHECK(y_hi == doctest::Approx(0.006).epsilon(1e-6));
  CHECK(x_far < 1e-6);
  CHECK(z_lo == doctest::Approx(-0.00275).epsilon(1e-6));
  fs::remove_all(dir);
}

TEST_CASE("log generator: the bundled log is valid and performs the task" * doctest::test_suite("slow")) {
  const Scenario s = bundled();
  PoseLogReader reader(s.log->string());
  CHECK(reader.metadata("generator") == "scalpelsim make-log");
  CHECK(reader.metadata("scenario") == "skin_incision");
  CHECK_FALSE(reader.has_force());
  std::vector<ToolSample> log;
  ToolSample x;
  while (reader.next(x)) log.push_back(x);
  // A few seconds at the haptic rate.
  REQUIRE(log.size() > 2000);
  CHECK(log.size() < 6000);
  for (std::size_t k = 0; k < log.size(); ++k) CHECK(log[k].t == static_cast<double>(k) / s.device.rate);

  // What was read is what the generator makes.
  const auto made = generate_task_log(s);
  REQUIRE(made.size() == log.size());
  for (std::size_t k = 0; k < log.size(); ++k) {
    CHECK(made[k].position == log[k].position);
    CHECK(made[k].orientation.coeffs() == log[k].orientation.coeffs());
  }
  // It follows the settled tissue: within half a millimetre of the task as written, which the
  // checks below take.
  const auto written = generate_task_log(s, as_written());
  REQUIRE(written.size() == log.size());
  for (std::size_t k = 0; k < log.size(); ++k) CHECK((written[k].position - log[k].position).norm() < 0.5e-3);
  log = written;

  const Incision& task = s.task->incisions.front();
  const Vec3 start = task.path.front(), end = task.path.back();
  const Vec3 dir = (end - start).normalized();
  CHECK(tip_of(s, log.front()).z() > 0.002);  // starts above the surface
  CHECK(tip_of(s, log.back()).z() > 0.002);   // and ends above it

  bool entered = false;
  double deepest = 0.0, max_cut_speed = 0.0, max_x = -1.0;
  for (std::size_t k = 0; k < log.size(); ++k) {
    const Vec3 tip = tip_of(s, log[k]), back = back_of(s, log[k]);
    // Blade 30-45 degrees from vertical, back point above and behind the tip.
    const Vec3 blade = back - tip;
    const double tilt = std::acos(blade.normalized().z()) * 180.0 / std::numbers::pi;
    CHECK(tilt >= 30.0);
    CHECK(tilt <= 45.0);
    CHECK(blade.dot(dir) < 0.0);
    if (tip.z() < 0.0) {
      if (!entered) CHECK((tip - start).head<2>().norm() < 1e-6);  // enters at the start of the path
      entered = true;
      CHECK(back.z() > 0.0);  // the blade spans the skin surface
      CHECK(std::abs(tip.y() - start.y()) <= task.tolerance);
      CHECK(tip.x() >= start.x() - task.tolerance);
      CHECK(tip.x() <= end.x() + task.tolerance);
      deepest = std::max(deepest, -tip.z());
      max_x = std::max(max_x, tip.x());
      if (k > 0 && tip_of(s, log[k - 1]).z() < -task.depth_min)
        max_cut_speed = std::max(max_cut_speed, (tip - tip_of(s, log[k - 1])).norm() * s.device.rate);
    }
  }
  CHECK(entered);
  // Through epidermis and dermis, not into the fat.
  CHECK(deepest >= task.depth_min);
  CHECK(deepest <= task.depth_max);
  CHECK(max_x == doctest::Approx(end.x()).epsilon(1e-6));
  // A realistic drawing speed [m/s].
  CHECK(max_cut_speed >= 0.010);
  CHECK(max_cut_speed <= 0.020);
}

TEST_CASE("log generator: a polyline task turns the blade smoothly") {
  Scenario s = bundled();
  s.task->incisions.front().path = {Vec3(-0.008, -0.004, 0), Vec3(0.0, -0.004, 0), Vec3(0.004, 0.004, 0)};
  const auto log = generate_task_log(s, as_written());
  double max_step = 0.0;
  for (std::size_t k = 1; k < log.size(); ++k)
    max_step = std::max(max_step, log[k].orientation.angularDistance(log[k - 1].orientation));
  CHECK(max_step < std::numbers::pi / 180.0);  // < 1 degree per millisecond: no jump at the corner
  // The tip follows the polyline: it passes through the corner at the cutting depth.
  double closest = 1.0;
  for (const auto& x : log) closest = std::min(closest, (tip_of(s, x) - Vec3(0, -0.004, -0.00275)).norm());
  CHECK(closest < 2e-5);
}

TEST_CASE("log generator: a scenario without a task is an error") {
  Scenario s = bundled();
  s.task.reset();
  CHECK_THROWS_WITH_AS((void)generate_task_log(s), doctest::Contains("task"), InputError);
}

namespace {

// Regenerates the bundled log of config/scenarios/<name>.yaml through the scenario's task, each cut
// begun and ended `extend` beyond its path and `depth` deep (make-log --extend --depth), compares it
// with config/logs/<name>.csv byte for byte and returns its samples.
std::vector<ToolSample> check_through_cut_log(const std::string& name, double extend, double depth) {
  const fs::path root(SCALPEL_SOURCE_DIR);
  const Scenario s = load_scenario(root / "config/scenarios" / (name + ".yaml"));
  IncisionMotion m;
  m.extend = extend;
  m.depth = depth;
  const fs::path dir = fs::temp_directory_path() / ("scalpelsim_test_make_log_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path out = dir / (name + ".csv");
  write_task_log(s, out.string(), m);
  CHECK(read_bytes(out) == read_bytes(root / "config/logs" / (name + ".csv")));
  std::vector<ToolSample> samples = read_pose_log(out.string());
  fs::remove_all(dir);
  return samples;
}

}  // namespace

TEST_CASE(
    "log generator: the bundled volume data log is reproducible, and --extend starts and ends each cut "
    "outside the block" *
    doctest::test_suite("slow")) {
  // Regenerate with: scalpelsim make-log config/scenarios/strata_volume.yaml --extend 0.008
  // --depth 0.044 --out config/logs/strata_volume.csv
  const std::vector<ToolSample> samples = check_through_cut_log("strata_volume", 0.008, 0.044);
  // The first cut runs along x at y = 1.6 mm from x = -30 to 30 mm: its tip goes from 8 mm before
  // the block to 8 mm beyond it, 44 mm down, under the 40 mm block.
  const Simulation reference(
      load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/strata_volume.yaml"));
  double x_min = 1.0, x_max = -1.0, z_min = 1.0;
  for (const ToolSample& sample : samples) {
    const BladePose b = reference.blade(sample);
    if (std::abs(b.tip.y() - 0.0016) > 1e-6) break;  // the second cut
    x_min = std::min(x_min, b.tip.x());
    x_max = std::max(x_max, b.tip.x());
    z_min = std::min(z_min, b.tip.z());
  }
  CHECK(x_min == doctest::Approx(-0.038).epsilon(1e-6));
  CHECK(x_max == doctest::Approx(0.038).epsilon(1e-6));
  CHECK(z_min == doctest::Approx(-0.044).epsilon(1e-6));
}

TEST_CASE("log generator: the bundled sculpting log is reproducible" * doctest::test_suite("slow")) {
  // Regenerate with: scalpelsim make-log config/scenarios/bracket_sculpt.yaml --extend 0.007
  // --depth 0.013 --out config/logs/bracket_sculpt.csv
  CHECK_FALSE(check_through_cut_log("bracket_sculpt", 0.007, 0.013).empty());
}
