// The task's score (docs/scoring.md): the depth probe by hand on a box, and the score of whole
// sessions: the reference log `make-log` writes, the same log off the line, with a pause and with
// a re-entry.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "devices/pose_log.hpp"
#include "mesh/generators.hpp"
#include "sim/log_generator.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/surface_probe.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

fs::path scenarios_dir() {
  return fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios";
}

// Replays `samples` on `scenario` and returns the report's task.
nlohmann::ordered_json replay_task(const Scenario& scenario, const std::vector<ToolSample>& samples,
                                   const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("scalpelsim_score_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    PoseLogWriter writer((dir / "log.csv").string(), task_log_metadata(scenario));
    for (const ToolSample& s : samples) writer.write(s);
    writer.flush();
  }
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r = replay(scenario, dir / "log.csv", options);
  REQUIRE(r.invariants_ok);
  REQUIRE(r.report.contains("task"));
  return r.report["task"];
}

const nlohmann::ordered_json& component(const nlohmann::ordered_json& task, const std::string& name) {
  for (const auto& c : task["components"])
    if (c["name"] == name) return c;
  FAIL("no component " << name);
  static const nlohmann::ordered_json none;
  return none;
}

// A 1 x 1 cm layer 4 mm thick, its skin at z = 4 mm.
TetMesh layer() {
  BoxSpec spec;
  spec.min = Vec3(0, 0, 0);
  spec.max = Vec3(0.01, 0.01, 0.004);
  spec.cells = {4, 4, 2};
  return make_box(spec);
}

}  // namespace

TEST_CASE("surface probe: depth below the surface the blade's line leaves through, by hand on a box") {
  const TetMesh box = layer();
  const SurfaceProbe probe(box);
  // Upright blade, tip 1.5 mm below the top face.
  const Vec3 tip(0.0043, 0.0061, 0.0025);
  auto hit = probe.above(box, tip, tip + Vec3(0, 0, 0.01));
  REQUIRE(hit);
  CHECK(hit->depth == doctest::Approx(0.0015).epsilon(1e-9));
  CHECK(hit->normal.z() == doctest::Approx(1.0));
  CHECK(hit->point.z() == doctest::Approx(0.004));
  // Leaning back 40 degrees: the depth is still the distance to the surface plane.
  const Vec3 lean(-std::sin(40 * M_PI / 180), 0, std::cos(40 * M_PI / 180));
  hit = probe.above(box, tip, tip + 0.01 * lean);
  REQUIRE(hit);
  CHECK(hit->depth == doctest::Approx(0.0015).epsilon(1e-9));
  // Near the side x = 0, leaning towards it: the line leaves through the side, 2 mm away.
  const Vec3 near_side(0.002, 0.005, 0.001);
  hit = probe.above(box, near_side, near_side + Vec3(-0.01, 0, 0.001));
  REQUIRE(hit);
  CHECK(hit->normal.x() == doctest::Approx(-1.0));
  CHECK(hit->depth == doctest::Approx(0.002).epsilon(1e-9));
  // Above the box, or beside it: not under the surface.
  CHECK_FALSE(probe.above(box, Vec3(0.005, 0.005, 0.005), Vec3(0.005, 0.005, 0.02)));
  CHECK_FALSE(probe.above(box, Vec3(-0.001, 0.005, 0.002), Vec3(-0.001, 0.005, 0.02)));
  // In the current positions: the box lowered by 1 mm leaves the tip 0.5 mm under its top.
  TetMesh lowered = box;
  for (const NodeId n : lowered.nodes()) lowered.positions()[n.index] -= Vec3(0, 0, 0.001);
  hit = probe.above(lowered, tip, tip + Vec3(0, 0, 0.01));
  REQUIRE(hit);
  CHECK(hit->depth == doctest::Approx(0.0005).epsilon(1e-9));
}

TEST_CASE("surface probe: the deepest point of a blade through a thin layer, and its depth below the skin") {
  const TetMesh box = layer();
  const SurfaceProbe probe(box);
  const Vec3 up(0, 0, 1);
  // Tip 0.5 mm above the bottom of the 4 mm layer: 3.5 mm below the skin it came through, not
  // 0.5 mm below the far side, which faces away from the blade's back.
  const Vec3 tip(0.0043, 0.0061, 0.0005);
  const auto in = probe.deepest_in_tissue(box.rest_positions(), tip, tip + 0.01 * up);
  REQUIRE(in);
  CHECK(*in == tip);
  CHECK(probe.nearest(box.rest_positions(), tip, up).depth == doctest::Approx(0.0035).epsilon(1e-9));
  CHECK(probe.nearest(box.rest_positions(), tip, up).normal.z() == doctest::Approx(1.0));
  // Tip 2 mm under the layer, the blade 3 cm long: it cuts the whole thickness, down to where it
  // enters through the bottom face; 4 mm below the skin there.
  const Vec3 through(0.0043, 0.0061, -0.002);
  const auto entry = probe.deepest_in_tissue(box.rest_positions(), through, through + 0.03 * up);
  REQUIRE(entry);
  CHECK(entry->z() == doctest::Approx(0.0).epsilon(1e-12));
  CHECK(entry->head<2>() == through.head<2>());
  CHECK(probe.nearest(box.rest_positions(), *entry, up).depth == doctest::Approx(0.004).epsilon(1e-9));
  // A blade too short to reach the layer, one beside it, and one above it: not in the tissue.
  CHECK_FALSE(probe.deepest_in_tissue(box.rest_positions(), through, through + 0.001 * up));
  CHECK_FALSE(
      probe.deepest_in_tissue(box.rest_positions(), Vec3(-0.001, 0.005, -0.002), Vec3(-0.001, 0.005, 0.02)));
  CHECK_FALSE(
      probe.deepest_in_tissue(box.rest_positions(), Vec3(0.005, 0.005, 0.005), Vec3(0.005, 0.005, 0.02)));
  // Beside the layer, leaning over it: a blade that stops short of its side wall is not in it; one
  // long enough enters through the wall, 2 mm up, and cuts from there.
  const Vec3 beside(-0.001, 0.005, 0.001);
  CHECK_FALSE(probe.deepest_in_tissue(box.rest_positions(), beside, beside + Vec3(0.0005, 0, 0.001)));
  const auto wall = probe.deepest_in_tissue(box.rest_positions(), beside, beside + Vec3(0.005, 0, 0.01));
  REQUIRE(wall);
  CHECK(wall->x() == doctest::Approx(0.0).epsilon(1e-12));
  CHECK(wall->z() == doctest::Approx(0.003).epsilon(1e-12));
  // A side wall is not skin to an upright blade, nor to one leaning a hair towards it: the depth of
  // a tip 1 mm from the wall x = 0 and 3.5 mm under the top stays 3.5 mm.
  const Vec3 near_wall(0.001, 0.005, 0.0005);
  const Vec3 hair(-1e-9, 0, 1);
  CHECK(probe.nearest(box.rest_positions(), near_wall, up).depth == doctest::Approx(0.0035).epsilon(1e-9));
  CHECK(probe.nearest(box.rest_positions(), near_wall, hair).depth == doctest::Approx(0.0035).epsilon(1e-9));
}

TEST_CASE("score: the reference log make-log writes passes at 95 or more on every bundled scenario" *
          doctest::test_suite("slow")) {
  int scored = 0;
  for (const auto& entry : fs::directory_iterator(scenarios_dir())) {
    if (entry.path().extension() != ".yaml") continue;
    const Scenario scenario = load_scenario(entry.path());
    if (!scenario.task || !scenario.task->scored) continue;
    CAPTURE(entry.path().filename().string());
    const auto task = replay_task(scenario, generate_task_log(scenario), "reference_" + scenario.name);
    CAPTURE(task.dump(1));
    CHECK(task["score"].get<double>() >= 95.0);
    CHECK(task["passed"].get<bool>());
    for (const auto& c : task["components"]) CHECK(c["passed"].get<bool>());
    // Every incision of the task made in one stroke, to the depth asked.
    for (const auto& in : task["incisions"]) {
      CHECK(in["strokes"] == 1);
      CHECK(in["coverage"].get<double>() == 1.0);
      CHECK(in["depth"]["in_band"].get<double>() >= 0.95);
    }
    ++scored;
  }
  CHECK(scored >= 2);
}

TEST_CASE("score: the reference incision shifted sideways by twice the tolerance fails" *
          doctest::test_suite("slow")) {
  const Scenario scenario = load_scenario(scenarios_dir() / "skin_incision.yaml");
  const Incision& target = scenario.task->incisions.front();
  const Vec3 along = (target.path.back() - target.path.front()).normalized();
  const Vec3 across(-along.y(), along.x(), 0.0);
  std::vector<ToolSample> samples = generate_task_log(scenario);
  for (ToolSample& s : samples) s.position += 2 * target.tolerance * across;
  const auto task = replay_task(scenario, samples, "shifted");
  CAPTURE(task.dump(1));
  CHECK_FALSE(task["passed"].get<bool>());
  CHECK(task["score"].get<double>() < 50.0);
  CHECK_FALSE(component(task, "coverage")["passed"].get<bool>());
  CHECK_FALSE(component(task, "deviation")["passed"].get<bool>());
  CHECK(component(task, "deviation")["value"].get<double>() == doctest::Approx(2.0).epsilon(0.1));
  CHECK_FALSE(component(task, "shape")["passed"].get<bool>());
  CHECK(component(task, "collateral")["value"].get<double>() > 90.0);
}

TEST_CASE("score: a pause in the tissue is a hesitation, a lift and re-entry a second stroke" *
          doctest::test_suite("slow")) {
  const Scenario scenario = load_scenario(scenarios_dir() / "skin_incision.yaml");
  const std::vector<ToolSample> reference = generate_task_log(scenario);
  // Mid-way along the cut (the reference cuts from 0.875 s to 2.875 s).
  constexpr double kMid = 1.9;
  SUBCASE("a pause of 1 s") {
    std::vector<ToolSample> samples;
    for (const ToolSample& s : reference) {
      if (s.t < kMid) {
        samples.push_back(s);
        continue;
      }
      if (samples.back().t < kMid)  // hold the pose, one sample a millisecond
        for (int k = 1; k <= 1000; ++k) {
          ToolSample hold = samples.back();
          hold.t = kMid + (k - 1) * 1e-3;
          samples.push_back(hold);
        }
      ToolSample later = s;
      later.t += 1.0;
      samples.push_back(later);
    }
    const auto task = replay_task(scenario, samples, "pause");
    CAPTURE(task.dump(1));
    CHECK(task["incisions"][0]["hesitations"] == 1);
    CHECK(task["incisions"][0]["strokes"] == 1);
    CHECK(component(task, "hesitations")["points"].get<double>() == doctest::Approx(2.0));
    CHECK(component(task, "hesitations")["why"].get<std::string>().find("1 time") != std::string::npos);
  }
  SUBCASE("lifted out for 0.3 s") {
    std::vector<ToolSample> samples = reference;
    for (ToolSample& s : samples)
      if (s.t >= kMid && s.t < kMid + 0.3) s.position.z() += 0.01;
    const auto task = replay_task(scenario, samples, "reentry");
    CAPTURE(task.dump(1));
    CHECK(task["incisions"][0]["strokes"] == 2);
    CHECK(task["incisions"][0]["hesitations"] == 0);
    CHECK(component(task, "strokes")["points"].get<double>() == doctest::Approx(3.5));
    CHECK(component(task, "strokes")["passed"].get<bool>());  // two strokes allowed by default
  }
}
