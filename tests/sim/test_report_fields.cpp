// The report's figures against what a person computes by hand for a case small enough to do so: a
// 1 cm box of 48 tetrahedra, held still, cut through by a blade on the plane x = 1.3 mm
// (docs/formats.md names each field).
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <utility>

#include "devices/pose_log.hpp"
#include "mesh/generators.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

constexpr double kPlaneX = 0.0013;  // [m] off every grid plane of the 2 x 2 x 2 cells

const char* kScenario = R"(name: held_box
mesh:
  generator: box
  min: [-0.005, -0.005, -0.01]
  max: [0.005, 0.005, 0.0]
  cells: [2, 2, 2]
materials:
  tissue: {young: 1.0e4, poisson: 0.45}
tissue: {gravity: [0, 0, 0]}
fixed:
  - {box: {min: [-1, -1, -1], max: [1, 1, 1]}}
tool:
  blade: {back: [0, 0, 0.03], tip: [0, 0, 0], edge: [0, 1, 0]}
task:
  path: [[0.0013, -0.005, 0.0], [0.0013, 0.005, 0.0]]
  tolerance: 0.001
  depth: [0.009, 0.01]
)";

// The blade, 3 cm tall, its tip 2 mm below the box, drawn along +y through the whole box at
// 20 mm/s, one sample a millisecond: 801 samples over 0.8 s.
std::vector<ToolSample> through_cut() {
  std::vector<ToolSample> out;
  for (int k = 0; k <= 800; ++k) {
    ToolSample s;
    s.t = 0.001 * k;
    s.position = Vec3(kPlaneX, -0.008 + 0.02 * s.t, -0.012);
    out.push_back(s);
  }
  return out;
}

// A fresh folder holding the through-cut's log, `cut.csv`.
fs::path folder_with_log(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("scalpelsim_report_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  PoseLogWriter writer((dir / "cut.csv").string(), {{"scenario", "held_box"}});
  for (const ToolSample& s : through_cut()) writer.write(s);
  return dir;
}

}  // namespace

TEST_CASE("report fields: a held box cut through on a plane, against a count by hand") {
  const fs::path dir = folder_with_log("fields");
  const Scenario scenario = parse_scenario(kScenario, "held_box.yaml", dir);
  const fs::path log = dir / "cut.csv";
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r = replay(scenario, log, options);
  REQUIRE(r.invariants_ok);
  REQUIRE(r.failure.empty());
  const auto& report = r.report;

  // 2 x 2 x 2 cells of 6 tetrahedra, 3 x 3 x 3 grid nodes, 1 cm^3.
  const auto& initial = report["mesh"]["initial"];
  CHECK(initial["tetrahedra"] == 48);
  CHECK(initial["nodes"] == 27);
  CHECK(initial["components"] == 1);
  CHECK(initial["rest_volume"].get<double>() == doctest::Approx(1e-6).epsilon(1e-12));

  // Cut through: two pieces, 6.3 x 10 x 10 mm and 3.7 x 10 x 10 mm, the volume kept.
  const auto& final_mesh = report["mesh"]["final"];
  CHECK(final_mesh["components"] == 2);
  CHECK(final_mesh["rest_volume"].get<double>() == doctest::Approx(1e-6).epsilon(1e-12));

  // One side of the section x = 1.3 mm, 10 x 10 mm, at rest and (held) as it is now.
  CHECK(report["cutting"]["cut_surface_area"].get<double>() == doctest::Approx(1e-4).epsilon(1e-9));
  CHECK(report["task"]["cut_area"].get<double>() == doctest::Approx(1e-4).epsilon(1e-9));
  CHECK(report["task"]["collateral_area"].get<double>() == doctest::Approx(0.0));
  CHECK(report["task"]["protected_area"].get<double>() == 0.0);

  // Every edge of the box mesh that crosses the plane is cut once, and no other.
  const TetMesh box =
      make_box({.min = Vec3(-0.005, -0.005, -0.01), .max = Vec3(0.005, 0.005, 0.0), .cells = {2, 2, 2}});
  std::set<std::pair<std::uint32_t, std::uint32_t>> crossing;
  for (const TetId t : box.tets()) {
    const auto v = box.tet_nodes(t);
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        const auto a = v[static_cast<std::size_t>(i)], b = v[static_cast<std::size_t>(j)];
        if ((box.rest(a).x() < kPlaneX) != (box.rest(b).x() < kPlaneX))
          crossing.insert(std::minmax(a.index, b.index));
      }
  }
  CHECK(report["cutting"]["edges_cut"] == crossing.size());

  // 801 samples at 1 kHz over 0.8 s, at 60 frames a second: ceil(0.8 x 60) + 1 frames.
  CHECK(report["replay"]["samples"] == 801);
  CHECK(report["replay"]["frames"] == 49);
  CHECK(report["inputs"]["log_samples"] == 801);
  CHECK(report["inputs"]["log_duration"].get<double>() == doctest::Approx(0.8));

  // The tip ran on the target's line in x: no lateral deviation, the whole path covered.
  const auto& incision = report["task"]["incisions"][0];
  CHECK(incision["coverage"].get<double>() == doctest::Approx(1.0));
  CHECK(incision["lateral_deviation"]["max"].get<double>() == doctest::Approx(0.0).epsilon(1e-12));
  CHECK(incision["path_length"].get<double>() == doctest::Approx(0.01));
  CHECK(report["task"]["targets_length"].get<double>() == doctest::Approx(0.01));

  // Held everywhere, the tissue does not move: every step converged, nothing was severed free.
  const auto& tissue = report["tissue"];
  CHECK(tissue["non_finite"] == 0);
  CHECK(tissue["converged"] == tissue["steps"]);
  CHECK(tissue["severed_pieces"].empty());
  fs::remove_all(dir);
}

TEST_CASE("report fields: a log whose last line is torn replays, with the warning in the report") {
  const fs::path dir = folder_with_log("torn");
  const Scenario scenario = parse_scenario(kScenario, "held_box.yaml", dir);
  const fs::path log = dir / "cut.csv";
  std::ofstream(log, std::ios::app) << "0.801,0.0013,0.00802";  // killed while writing this line
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r = replay(scenario, log, options);
  CHECK(r.report["replay"]["samples"] == 801);
  bool torn = false;
  for (const auto& w : r.report["warnings"]) torn |= w["code"] == "log_torn";
  CHECK(torn);
  fs::remove_all(dir);
}
