// The frame snapshot a renderer draws (sim/snapshot.hpp): skin and wound told apart.
#include <doctest/doctest.h>

#include <filesystem>

#include "devices/pose_log.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

double area(const FrameSnapshot& s, std::size_t begin, std::size_t end) {
  double a = 0.0;
  for (std::size_t i = begin; i + 2 < end; i += 3) {
    const auto p = [&](std::size_t k) {
      const auto& v = s.surface[k].position;
      return Vec3(v[0], v[1], v[2]);
    };
    a += (p(i + 1) - p(i)).cross(p(i + 2) - p(i)).norm() / 2;
  }
  return a;
}

Scenario bundled() {
  return load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml");
}

}  // namespace

TEST_CASE("an uncut patch's snapshot is all skin: the patch's outer surface, and no wound") {
  const Simulation sim(bundled());
  FrameSnapshot s;
  sim.snapshot(s, true);
  CHECK(s.wound_vertices == 0);
  REQUIRE(s.surface.size() % 3 == 0);
  // 40 x 30 x 8 mm: two faces of 40 x 30, two of 40 x 8, two of 30 x 8 [m^2].
  const double box = 2 * (0.040 * 0.030 + 0.040 * 0.008 + 0.030 * 0.008);
  CHECK(std::abs(area(s, 0, s.surface.size()) / box - 1.0) < 1e-6);
  // The top is the epidermis (region 0), the bottom the fat (region 2).
  for (const SurfaceVertex& v : s.surface) {
    if (v.position[2] > -1e-9 && v.normal[2] > 0.99f) CHECK(v.region == 0.0f);
    if (v.position[2] < -0.008 + 1e-9 && v.normal[2] < -0.99f) CHECK(v.region == 2.0f);
  }
  // Every edge of the 4950 tetrahedra once: a 15 x 11 x 5 grid of cells, 6 tetrahedra each, has
  // the grid's edges, each cell's face diagonals and one body diagonal per cell.
  const std::size_t nx = 15, ny = 11, nz = 5;
  const std::size_t grid = nx * (ny + 1) * (nz + 1) + ny * (nx + 1) * (nz + 1) + nz * (nx + 1) * (ny + 1);
  const std::size_t diagonals = nx * ny * (nz + 1) + nx * nz * (ny + 1) + ny * nz * (nx + 1) + nx * ny * nz;
  CHECK(s.edges.size() == 2 * (grid + diagonals));
  CHECK(s.bounds_min.isApprox(Vec3(-0.020, -0.015, -0.008)));
  CHECK(s.bounds_max.isApprox(Vec3(0.020, 0.015, 0.0)));
  REQUIRE(s.targets.size() == 1);
  REQUIRE(s.targets[0].path.size() == 2);
  CHECK(s.targets[0].tolerance == doctest::Approx(0.001));
  CHECK_FALSE(s.has_blade);
}

TEST_CASE("after the bundled incision the wound is both lips of the cut surface" *
          doctest::test_suite("slow")) {
  const Scenario scenario = bundled();
  FrameSnapshot last;
  double cut_area = 0.0;
  ReplayOptions options;
  options.out_dir = fs::temp_directory_path() / "scalpelsim_test_snapshot";
  options.on_frame = [&](const Simulation& sim, std::size_t, bool is_last) {
    if (!is_last) return;
    sim.snapshot(last);
    cut_area = sim.cutter().cut_surface_area();
  };
  const ReplayResult r = replay(scenario, *scenario.log, options);
  REQUIRE(r.invariants_ok);
  REQUIRE(last.wound_vertices > 0);
  // Each crack face is a boundary face on each lip: twice the one-side area, up to the lips'
  // different deformation.
  const double wound = area(last, 0, last.wound_vertices);
  MESSAGE("wound area " << wound * 1e6 << " mm^2, cut surface " << cut_area * 1e6 << " mm^2");
  CHECK(wound / (2 * cut_area) > 0.9);
  CHECK(wound / (2 * cut_area) < 1.1);
  // Wound faces lie inside the patch and around the incision; none on its outer faces.
  for (std::size_t i = 0; i < last.wound_vertices; ++i) {
    const auto& p = last.surface[i].position;
    CHECK(p[2] < 1e-3f);
    CHECK(p[2] > -0.0045f);
    CHECK(std::abs(p[1]) < 0.004f);
  }
  // The blade is where the last sample put it: above the skin, lifted out.
  REQUIRE(last.has_blade);
  const std::vector<ToolSample> log = read_pose_log(scenario.log->string());
  const Simulation reference(scenario);
  const BladePose b = reference.blade(log.back());
  CHECK((last.blade_tip - b.tip).norm() < 1e-12);
  CHECK((last.blade_back - b.back).norm() < 1e-12);
}
