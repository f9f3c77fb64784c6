// The report's figures against what a person computes by hand for cases small enough to do so: a
// 1 cm box of 48 tetrahedra, held still, cut through by a blade on the plane x = 1.3 mm (counts,
// volumes, quality, cut states, nodes, cycles, contact force, wound nodes, the task's figures), and
// a column hanging under its own weight (the elastic energy). docs/formats.md names each field.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <utility>

#include "devices/pose_log.hpp"
#include "mesh/generators.hpp"
#include "mesh/topology.hpp"
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
// 20 mm/s, one sample a millisecond: 801 samples over 0.8 s, 500 of them strictly inside the box
// (none on its faces y = +-5 mm).
std::vector<ToolSample> through_cut() {
  std::vector<ToolSample> out;
  for (int k = 0; k <= 800; ++k) {
    ToolSample s;
    s.t = 0.001 * k;
    s.position = Vec3(kPlaneX, -0.00801 + 0.02 * s.t, -0.012);
    out.push_back(s);
  }
  return out;
}

// What the plane x = kPlaneX crosses in the uncut box: edges, faces (each once) and tetrahedra by
// how they split (one corner against three: a triangle section; two against two: a quadrilateral),
// all and on the outer surface.
struct Crossed {
  std::set<std::array<std::uint32_t, 2>> edges, boundary_edges;
  std::set<std::array<std::uint32_t, 3>> faces, boundary_faces;
  int tets_1_3 = 0, tets_2_2 = 0;
};

Crossed crossed_by_plane(const TetMesh& box) {
  Crossed out;
  const auto below = [&box](std::uint32_t n) { return box.rest(box.node_handle(n)).x() < kPlaneX; };
  for (const BoundaryFace& f : boundary_faces(box)) {
    std::array<std::uint32_t, 3> v = f.nodes;
    std::sort(v.begin(), v.end());
    const int n_below = below(v[0]) + below(v[1]) + below(v[2]);
    if (n_below == 0 || n_below == 3) continue;
    out.boundary_faces.insert(v);
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j)
        if (below(v[i]) != below(v[j])) out.boundary_edges.insert({v[i], v[j]});
  }
  for (const TetId t : box.tets()) {
    std::array<std::uint32_t, 4> v{};
    for (int i = 0; i < 4; ++i) v[i] = box.tet_nodes(t)[static_cast<std::size_t>(i)].index;
    std::sort(v.begin(), v.end());
    const int n_below = below(v[0]) + below(v[1]) + below(v[2]) + below(v[3]);
    if (n_below == 0 || n_below == 4) continue;
    (n_below == 2 ? out.tets_2_2 : out.tets_1_3) += 1;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (below(v[i]) != below(v[j])) out.edges.insert({v[i], v[j]});
    for (int skip = 0; skip < 4; ++skip) {
      std::array<std::uint32_t, 3> f{};
      for (int i = 0, k = 0; i < 4; ++i)
        if (i != skip) f[k++] = v[i];
      const int fb = below(f[0]) + below(f[1]) + below(f[2]);
      if (fb != 0 && fb != 3) out.faces.insert(f);
    }
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

// The through-cut replayed in a fresh folder (each case replays on its own, to stand alone).
struct HeldBoxRun {
  fs::path dir;
  ReplayResult result;
};
HeldBoxRun replay_held_box(const std::string& name) {
  HeldBoxRun run{folder_with_log(name), {}};
  const Scenario scenario = parse_scenario(kScenario, "held_box.yaml", run.dir);
  ReplayOptions options;
  options.out_dir = run.dir / "out";
  run.result = replay(scenario, run.dir / "cut.csv", options);
  return run;
}

}  // namespace

TEST_CASE("report fields: a held box cut through on a plane, against a count by hand") {
  const auto [dir, r] = replay_held_box("fields");
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
  const Crossed crossed = crossed_by_plane(box);
  const auto& cutting = report["cutting"];
  CHECK(cutting["edges_cut"] == crossed.edges.size());
  CHECK(crossed.edges.size() == 25);

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

  // Held everywhere, the tissue does not move: one step a frame, each converged with nothing to
  // solve, no energy, nothing severed free.
  const auto& tissue = report["tissue"];
  CHECK(tissue["steps"] == 49);
  CHECK(tissue["converged"] == 49);
  CHECK(tissue["non_finite"] == 0);
  CHECK(tissue["iteration_cap"] == 0);
  CHECK(tissue["cg_iterations"]["max"] == 0);
  CHECK(tissue["local_solves"]["steps"] == 0);
  CHECK(tissue["strain_limited_elements"]["max"] == 0);
  CHECK(tissue["energy"]["elastic"].get<double>() < 1e-20);
  CHECK(tissue["energy"]["kinetic"].get<double>() == 0.0);
  CHECK(tissue["severed_pieces"].empty());
  // The wound cannot gape; its surface cut nodes are one per crossed edge and face of the outer
  // surface (edge nodes and the mid nodes of the crossed faces), all within the band of the line.
  const auto& wound = tissue["wound_opening"];
  CHECK(wound["max"].get<double>() < 1e-15);
  CHECK(wound["surface_cut_nodes"] == crossed.boundary_edges.size() + crossed.boundary_faces.size());
  CHECK(wound["surface_cut_nodes"] == 32);
  CHECK(wound["bridges"] == 0);
  CHECK(wound["profile"].size() == 32);
  fs::remove_all(dir);
}

TEST_CASE("report fields: the held box's mesh, cut and contact figures, against a count by hand") {
  const auto [dir, r] = replay_held_box("counts");
  REQUIRE(r.invariants_ok);
  const auto& report = r.report;
  const TetMesh box =
      make_box({.min = Vec3(-0.005, -0.005, -0.01), .max = Vec3(0.005, 0.005, 0.0), .cells = {2, 2, 2}});
  const Crossed crossed = crossed_by_plane(box);

  // 6 sides of 2 x 2 squares, two triangles each; one region. Every tetrahedron of a cube's six
  // around its diagonal has three edges a, two a sqrt(2) and one a sqrt(3), volume a^3 / 6:
  // q = 6 sqrt(2) V / l_rms^3 = sqrt(2) / (10/6)^(3/2).
  const auto& initial = report["mesh"]["initial"];
  CHECK(initial["boundary_faces"] == 48);
  CHECK(initial["regions"] == 1);
  const double q = std::sqrt(2.0) / std::pow(10.0 / 6.0, 1.5);
  CHECK(initial["quality"]["min"].get<double>() == doctest::Approx(q).epsilon(1e-12));
  CHECK(initial["quality"]["max"].get<double>() == doctest::Approx(q).epsilon(1e-12));
  CHECK(initial["quality"]["mean"].get<double>() == doctest::Approx(q).epsilon(1e-12));
  CHECK(initial["quality"]["slivers"] == 0);

  // The cut: the plane crosses the 4 cells of the slab 0 < x < 5 mm, 24 tetrahedra: 16 split one
  // corner against three (complete state D3, 11 sub-tetrahedra), 8 two against two (E3, 15).
  const auto& cutting = report["cutting"];
  CHECK(crossed.tets_1_3 == 16);
  CHECK(crossed.tets_2_2 == 8);
  CHECK(cutting["coarse_tetrahedra_cut"] == 24);
  int to_d3 = 0, to_e3 = 0;
  for (const auto& [pair, count] : cutting["transitions"].items()) {
    if (pair.ends_with("->D3")) to_d3 += count.get<int>();
    if (pair.ends_with("->E3")) to_e3 += count.get<int>();
  }
  CHECK(to_d3 == crossed.tets_1_3);
  CHECK(to_e3 == crossed.tets_2_2);
  const auto& per_tet = cutting["tetrahedra_per_cut_tetrahedron"];
  CHECK(per_tet["histogram"]["11"] == crossed.tets_1_3);
  CHECK(per_tet["histogram"]["15"] == crossed.tets_2_2);
  CHECK(per_tet["histogram"].size() == 2);
  CHECK(per_tet["mean"].get<double>() == doctest::Approx((16.0 * 11 + 8 * 15) / 24).epsilon(1e-12));
  // Each crossed edge and face gets a node on either side of the cut; the 24 cut tetrahedra are
  // replaced by their 296 sub-tetrahedra.
  CHECK(cutting["nodes_created"] == 2 * (crossed.edges.size() + crossed.faces.size()));
  CHECK(report["mesh"]["final"]["nodes"] == 27 + cutting["nodes_created"].get<int>());
  CHECK(cutting["tetrahedra_created"].get<int>() - cutting["tetrahedra_removed"].get<int>() == 296 - 24);
  CHECK(report["mesh"]["final"]["tetrahedra"] == 48 - 24 + 296);
  // One forward pass of a blade taller than the box: nothing crossed backward or twice, no pierce
  // by the tip (it stays below the box), nothing for the recursive continuation.
  for (const char* zero : {"backward_crossings", "replaced_crossings", "recrossed_edges", "recrossed_faces",
                           "face_pierces", "undone_face_subdivisions", "recursive_continuations",
                           "recursive_continuations_within_stroke", "sealed_crossings", "final_pierces",
                           "tetrahedra_promoted", "max_recursion_depth", "recursion_fallbacks"}) {
    CAPTURE(zero);
    CHECK(cutting[zero] == 0);
  }

  // 49 frames of 1/60 s: the haptic loop ran at 1 kHz from 0 to 816 ms, 817 cycles, the last 16
  // after the log's 801 samples.
  const auto& run = report["replay"];
  CHECK(run["haptic_rate"].get<double>() == 1000.0);
  CHECK(run["visual_rate"].get<double>() == 60.0);
  CHECK(run["haptic_cycles"] == 817);
  CHECK(run["device_not_ok_cycles"] == 16);
  CHECK(run["merged_samples"] == 0);

  // The blade is in the tissue while its path crosses the 10 mm box at 20 mm/s: 0.5 s, 30 frames,
  // along all 10 mm of its height: 350 N/m x 10 mm = 3.5 N.
  const auto& contact = report["tool_contact"];
  CHECK(contact["cutting_resistance"].get<double>() == 350.0);
  CHECK(contact["frames"] == 30);
  CHECK(contact["force_on_tissue"]["max"].get<double>() == doctest::Approx(3.5).epsilon(1e-12));
  CHECK(contact["force_on_tissue"]["mean_in_contact"].get<double>() == doctest::Approx(3.5).epsilon(1e-12));
  fs::remove_all(dir);
}

TEST_CASE("report fields: the held box's through-cut scores full marks, its task figures by hand") {
  const auto [dir, r] = replay_held_box("task");
  REQUIRE(r.invariants_ok);
  const auto& task = r.report["task"];

  // The blade's tip runs 2 mm under the box: it cuts the whole 10 mm thickness, what the task's
  // band [9, 10] mm asks, upright (no bevel), in one stroke without a pause, on the line.
  CHECK(task["time_in_tissue"].get<double>() == doctest::Approx(0.5).epsilon(1e-9));
  CHECK(task["path_in_tissue"].get<double>() == doctest::Approx(0.01).epsilon(1e-9));
  CHECK(task["hand_force_while_cutting"]["max"].get<double>() == doctest::Approx(3.5).epsilon(1e-12));
  const auto& incision = task["incisions"][0];
  CHECK(incision["depth"]["max"].get<double>() == doctest::Approx(0.01).epsilon(1e-12));
  CHECK(incision["depth"]["mean"].get<double>() == doctest::Approx(0.01).epsilon(1e-12));
  CHECK(incision["depth"]["in_band"].get<double>() == 1.0);
  CHECK(incision["bevel_deg"]["max"].get<double>() == 0.0);
  CHECK(incision["strokes"] == 1);
  CHECK(incision["hesitations"] == 0);
  CHECK(incision["cut_points_outside_tolerance"] == 0);
  // The discrete Frechet distance of a path on the line is at most the spacing of its samples (an
  // eighth of the tolerance).
  CHECK(incision["lateral_deviation"]["frechet"].get<double>() <= 0.001 / 8 + 1e-12);
  CHECK(task["score"].get<double>() == doctest::Approx(100.0).epsilon(1e-9));
  CHECK(task["passed"] == true);
  for (const auto& c : task["components"]) {
    CAPTURE(c["name"].get<std::string>());
    CHECK(c["why"] == "");
  }
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

TEST_CASE(
    "report fields: a column hanging under its own weight holds the elastic energy of the hand formula") {
  // A 1 x 1 x 5 cm column, its top held, Poisson's ratio 0: uniaxial stress rho g z at height z
  // above its foot, energy A (rho g)^2 L^3 / (6 E) at rest. The tool stays away for 2 s.
  const char* column = R"(name: column
mesh:
  generator: box
  min: [-0.005, -0.005, -0.05]
  max: [0.005, 0.005, 0.0]
  cells: [1, 1, 10]
materials:
  tissue: {young: 1.0e5, poisson: 0.0, density: 1000}
tissue: {gravity: [0, 0, -9.81]}
fixed:
  - {box: {min: [-1, -1, -1.0e-6], max: [1, 1, 1]}}
tool:
  blade: {back: [0, 0, 0.03], tip: [0, 0, 0]}
)";
  const fs::path dir = fs::temp_directory_path() / "scalpelsim_report_column";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    PoseLogWriter writer((dir / "away.csv").string(), {{"scenario", "column"}});
    for (int k = 0; k <= 2000; ++k) {
      ToolSample s;
      s.t = 0.001 * k;
      s.position = Vec3(0.1, 0.1, 0.1);
      writer.write(s);
    }
  }
  const Scenario scenario = parse_scenario(column, "column.yaml", dir);
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r = replay(scenario, dir / "away.csv", options);
  REQUIRE(r.failure.empty());
  const auto& tissue = r.report["tissue"];
  const double area = 1e-4, length = 0.05, weight = 1000 * 9.81, young = 1e5;
  const double energy = area * weight * weight * std::pow(length, 3) / (6 * young);
  // Linear tetrahedra hold the strain constant in each of the 10 layers: a fraction of a per cent
  // below the exact energy.
  CHECK(tissue["energy"]["elastic"].get<double>() == doctest::Approx(energy).epsilon(0.01));
  CHECK(tissue["energy"]["elastic"].get<double>() <= energy);
  CHECK(tissue["energy"]["kinetic"].get<double>() < 1e-6 * energy);
  CHECK(tissue["rate"].get<double>() == 60.0);
  CHECK(tissue["steps"] == 121);
  CHECK(tissue["converged"] == 121);
  CHECK(tissue["strain_limited_elements"]["max"] == 0);
  CHECK(r.report["tool_contact"]["frames"] == 0);
  fs::remove_all(dir);
}
