// Volume data (paper section 7.1): a scalar volume sampled onto the mesh, carried through cuts,
// written with the mesh; rigid tissue.
#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>

#include "base/input_error.hpp"
#include "devices/pose_log.hpp"
#include "mesh/validate.hpp"
#include "mesh/volume.hpp"
#include "sim/log_generator.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path dir = fs::temp_directory_path() / ("scalpel_volume_data_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

double linear(const Vec3& x) {
  return 2.0 + 150.0 * x.x() - 80.0 * x.y() + 300.0 * x.z();
}

// A linear field over [-0.012, 0.012] x [-0.01, 0.01] x [-0.008, 0], written as NRRD.
fs::path write_linear_volume() {
  ScalarVolume v;
  v.size = {7, 6, 5};
  v.origin = Vec3(-0.012, -0.01, -0.008);
  v.spacing = Vec3(0.004, 0.004, 0.002);
  for (std::size_t k = 0; k < v.size[2]; ++k)
    for (std::size_t j = 0; j < v.size[1]; ++j)
      for (std::size_t i = 0; i < v.size[0]; ++i)
        v.values.push_back(static_cast<float>(
            linear(v.origin + Vec3(double(i), double(j), double(k)).cwiseProduct(v.spacing))));
  const fs::path path = temp_dir() / "linear.nrrd";
  write_nrrd_volume(v, path);
  return path;
}

// A rigid box with the linear volume, and a task across it (box planes every 2 mm: the path keeps
// off them).
std::string scenario_text(const fs::path& volume, const std::string& extra = "") {
  return "name: volume\n"
         "mesh: {generator: box, min: [-0.012, -0.01, -0.008], max: [0.012, 0.01, 0.0], cells: [12, 10, 4]}\n"
         "tissue: {model: rigid}\n"
         "volume:\n"
         "  file: " +
         volume.string() +
         "\n"
         "  field: density\n" +
         extra +
         "tool: {contact: none, blade: {back: [0, 0, 0.012], tip: [0, 0, 0]}}\n"
         "task:\n"
         "  path: [[-0.0071, 0.0013, 0.0], [0.0069, 0.0013, 0.0]]\n"
         "  tolerance: 0.001\n"
         "  depth: [0.004, 0.005]\n";
}

// Feeds `samples` to `sim` at the scenario's device rate, ending frames at its visual rate.
void run(Simulation& sim, const std::vector<ToolSample>& samples,
         const std::function<void()>& after_frame = {}) {
  ForceChannel forces;
  const double frame = 1.0 / sim.scenario().simulation.visual_rate;
  double next = frame;
  for (const ToolSample& s : samples) {
    sim.on_sample(s);
    while (s.t >= next) {
      sim.end_frame(next, forces);
      if (after_frame) after_frame();
      next += frame;
    }
  }
  sim.end_frame(next, forces);
}

}  // namespace

TEST_CASE(
    "a field sampled from a volume is carried through every cut: each node holds the volume's value at its "
    "rest position" *
    doctest::test_suite("slow")) {
  const Scenario scenario = parse_scenario(scenario_text(write_linear_volume()), "volume.yaml", ".");
  // Tremble slides mid nodes, pulling back re-cuts, the crossing stroke continues into the first
  // cut's subdivision (section 6): every way the cutter makes or moves a node.
  IncisionMotion motion;
  motion.tremble = 0.0004;
  motion.pull_back = 0.002;
  motion.cross = 0.012;
  const std::vector<ToolSample> samples = generate_task_log(scenario, motion);
  Simulation sim(scenario);
  const int id = sim.mesh().field_id("density");
  REQUIRE(id >= 0);
  double worst = 0.0;
  std::size_t frames = 0, slid = 0;
  std::map<std::pair<std::uint32_t, std::uint32_t>, Vec3> first_rest;
  run(sim, samples, [&] {
    ++frames;
    for (const NodeId n : sim.mesh().nodes()) {
      worst = std::max(worst, std::abs(sim.mesh().field(id, n) - linear(sim.mesh().rest(n))));
      const auto [it, fresh] = first_rest.try_emplace({n.index, n.generation}, sim.mesh().rest(n));
      if (!fresh && it->second != sim.mesh().rest(n)) {
        ++slid;
        it->second = sim.mesh().rest(n);
      }
    }
  });
  CHECK(sim.mesh().node_count() > 2 * 13 * 11 * 5);  // the cuts made nodes,
  CHECK(slid > 0);                                   // slid some
  CHECK(sim.cutter().totals().recursions > 0);       // and continued into the first cut
  CHECK(frames > 100);
  // The volume holds floats: its samples of the linear field are off by their rounding, some 1e-7
  // here; a node left at a slid node's old weights would be off by the gradient times the slide.
  CHECK(worst < 1e-6);
  CHECK(validate(sim.mesh()).ok());
}

TEST_CASE("rigid tissue does not move: cut or not, every node stays at its rest position" *
          doctest::test_suite("slow")) {
  const Scenario scenario = parse_scenario(scenario_text(write_linear_volume()), "volume.yaml", ".");
  CHECK(scenario.tissue.rigid);
  CHECK(scenario.materials.empty());
  IncisionMotion motion;
  motion.cross = 0.012;
  Simulation sim(scenario);
  run(sim, generate_task_log(scenario, motion));
  CHECK(sim.cutter().totals().edges_cut > 0);
  CHECK(sim.tissue_steps().empty());
  double moved = 0.0;
  for (const NodeId n : sim.mesh().nodes())
    moved = std::max(moved, (sim.mesh().position(n) - sim.mesh().rest(n)).norm());
  CHECK(moved < 1e-12);  // [m] new nodes are placed by interpolation: round-off, no motion
}

TEST_CASE("a scenario's volume section: bad input names the scenario's line and key") {
  const fs::path volume = write_linear_volume();
  struct Case {
    std::string extra;
    std::string field, message;
  };
  const Case cases[] = {
      {"  colour_map: rainbow\n", "volume.colour_map", "rainbow"},
      {"  range: [1, 0]\n", "volume.range", "range[0] < range[1]"},
      {"  box: {min: [0, 0, 0], max: [0.01, -0.01, 0.01]}\n", "volume.box.max", "axis y"},
      {"  shading: on\n", "volume.shading", "unknown key"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.extra);
    try {
      (void)parse_scenario(scenario_text(volume, c.extra), "volume.yaml", ".");
      FAIL("no error");
    } catch (const InputError& e) {
      CHECK(e.file() == "volume.yaml");
      CHECK(e.line() >= 4);
      CHECK(e.field() == c.field);
      CHECK(std::string(e.what()).find(c.message) != std::string::npos);
    }
  }
  CHECK_THROWS_WITH_AS((void)parse_scenario(scenario_text(temp_dir() / "absent.nrrd"), "volume.yaml", "."),
                       doctest::Contains("volume file not found"), InputError);
  CHECK_THROWS_WITH_AS((void)parse_scenario(scenario_text("strata.vti"), "volume.yaml", "."),
                       doctest::Contains("expected .nrrd or .nhdr"), InputError);
  // Rigid tissue cannot be pressed in.
  std::string indent = scenario_text(volume);
  indent.replace(indent.find("contact: none"), 13, "contact: indent");
  CHECK_THROWS_WITH_AS((void)parse_scenario(indent, "volume.yaml", "."), doctest::Contains("rigid"),
                       InputError);
  // A volume placed where it does not cover the mesh.
  const Scenario away = parse_scenario(
      scenario_text(volume, "  box: {min: [0.1, 0.1, 0.1], max: [0.2, 0.2, 0.2]}\n"), "volume.yaml", ".");
  try {
    (void)load_scenario_mesh(away);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.file() == "volume.yaml");
    CHECK(e.line() == 4);
    CHECK(e.field() == "volume");
    CHECK(std::string(e.what()).find("does not cover the mesh") != std::string::npos);
  }
}

TEST_CASE(
    "the bundled seismic data set is what make-volume writes, and its replay quarters the block, moves two "
    "quarters apart and writes the field with the mesh" *
    doctest::test_suite("slow")) {
  const fs::path root(SCALPEL_SOURCE_DIR);
  const ScalarVolume bundled = read_nrrd_volume(root / "config/volumes/strata.nrrd");
  const ScalarVolume made = strata_volume();
  CHECK(bundled.size == made.size);
  CHECK((bundled.origin - made.origin).norm() < 1e-15);
  CHECK((bundled.spacing - made.spacing).norm() < 1e-15);
  CHECK(bundled.values == made.values);

  const Scenario scenario = load_scenario(root / "config/scenarios/strata_volume.yaml");
  ReplayOptions options;
  options.out_dir = temp_dir() / "strata";
  const ReplayResult result = replay(scenario, *scenario.log, options);
  CHECK(result.invariants_ok);
  CHECK(result.failure.empty());
  CHECK(result.report["warnings"].empty());
  CHECK_FALSE(result.report.contains("task"));  // unscored
  // Two through-cuts, at y = 1.6 mm and x = 0.6 mm: four quarters; two of them moved apart, each
  // its exact volume (40 mm deep).
  CHECK(result.report["mesh"]["final"]["components"] == 4);
  const auto& moves = result.report["piece_moves"];
  REQUIRE(moves.size() == 2);
  CHECK(moves[0]["done"].get<bool>());
  CHECK(moves[1]["done"].get<bool>());
  CHECK(moves[0]["rest_volume_mm3"].get<double>() == doctest::Approx(29.4 * 28.4 * 40).epsilon(1e-9));
  CHECK(moves[1]["rest_volume_mm3"].get<double>() == doctest::Approx(30.6 * 31.6 * 40).epsilon(1e-9));
  std::ifstream in(options.out_dir / "mesh.vtu");
  std::stringstream text;
  text << in.rdbuf();
  CHECK(text.str().find("Name=\"amplitude\"") != std::string::npos);
}

namespace {

// The scenario above with a 30 mm blade, cut through from side to side (the log starts and ends
// 4 mm outside the box, the tip 2 mm below it): two pieces, y below and above 0.0013.
struct Halves {
  Scenario scenario;
  std::vector<ToolSample> samples;
};
Halves halves(const std::string& extra = "") {
  std::string text = scenario_text(write_linear_volume(), extra);
  text.replace(text.find("back: [0, 0, 0.012]"), 19, "back: [0, 0, 0.030]");
  text.replace(text.find("[[-0.0071, 0.0013, 0.0], [0.0069, 0.0013, 0.0]]"), 47,
               "[[-0.012, 0.0013, 0.0], [0.012, 0.0013, 0.0]]");
  text.replace(text.find("depth: [0.004, 0.005]"), 21, "depth: [0.007, 0.008]");
  Halves h{parse_scenario(text, "halves.yaml", "."), {}};
  IncisionMotion motion;
  motion.extend = 0.004;
  motion.depth = 0.010;
  h.samples = generate_task_log(h.scenario, motion);
  return h;
}

// The length of every edge of every live tetrahedron now, in slot order.
std::vector<double> edge_lengths(const TetMesh& mesh) {
  std::vector<double> out;
  for (const TetId t : mesh.tets()) {
    const auto v = mesh.tet_nodes(t);
    for (const auto& e : kEdgeVertices)
      out.push_back((mesh.position(v[static_cast<std::size_t>(e[0])]) -
                     mesh.position(v[static_cast<std::size_t>(e[1])]))
                        .norm());
  }
  return out;
}

double largest_change(const std::vector<double>& a, const std::vector<double>& b) {
  REQUIRE(a.size() == b.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  return worst;
}

}  // namespace

TEST_CASE(
    "a severed piece moves rigidly, keeps its shape and volume exactly, is cut again where it now lies, and "
    "the move undoes" *
    doctest::test_suite("slow")) {
  const Halves h = halves();
  Simulation sim(h.scenario);
  run(sim, h.samples);
  REQUIRE(validate(sim.mesh()).ok());
  const std::vector<Vec3> before = sim.mesh().positions();
  const std::vector<Vec3> rest_before = sim.mesh().rest_positions();

  // Refused: nothing there, or nothing to undo.
  CHECK(sim.move_piece(Vec3(0.1, 0.1, 0.1), Eigen::Quaterniond::Identity(), Vec3(0.01, 0, 0)) ==
        "no tissue at that point");
  CHECK(sim.undo_move() == "no move to undo");

  // The half beyond y = 0.0013: 24 x 8.7 x 8 mm, turned 30 degrees about z and lifted.
  const std::vector<double> lengths = edge_lengths(sim.mesh());
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(std::acos(-1.0) / 6, Vec3::UnitZ()));
  REQUIRE(sim.move_piece(Vec3(0.003, 0.006, -0.004), turn, Vec3(0.0, 0.01, 0.005)) == "");
  const Simulation::MoveRecord& moved = sim.moves().back();
  CHECK(moved.rest_volume == doctest::Approx(0.024 * 0.0087 * 0.008).epsilon(1e-9));
  CHECK(largest_change(lengths, edge_lengths(sim.mesh())) < 1e-16);  // [m] rigid: no edge changed length
  std::size_t moved_nodes = 0, kept_nodes = 0;
  for (const NodeId n : sim.mesh().nodes()) {
    const bool far_side = sim.mesh().rest(n).y() > 0.0013 + 1e-9;
    const bool near_side = sim.mesh().rest(n).y() < 0.0013 - 1e-9;
    const bool still = sim.mesh().position(n) == before[n.index];
    moved_nodes += far_side && !still ? 1 : 0;
    kept_nodes += near_side && still ? 1 : 0;
    if (far_side) CHECK_FALSE(still);
    if (near_side) CHECK(still);
  }
  CHECK(moved_nodes > 100);
  CHECK(kept_nodes > 100);

  // The moved half is cut again where it lies now: a vertical stab down through its middle.
  const Vec3 centre = Vec3(0.0, 0.0056, -0.004) + Vec3(0.0, 0.01, 0.005);  // roughly, after the move
  std::vector<ToolSample> stab;
  const double t0 = h.samples.back().t;
  for (int k = 1; k <= 400; ++k) {
    ToolSample s;
    s.t = t0 + k / 1000.0;
    const double u = k / 400.0;
    s.position = centre + Vec3(-0.006 + 0.012 * u, 0.0, 0.012 - 0.014 * std::min(1.0, 4 * u));
    stab.push_back(s);
  }
  const std::size_t edges_before = sim.cutter().totals().edges_cut;
  run(sim, stab);
  CHECK(sim.cutter().totals().edges_cut > edges_before);
  CHECK(validate(sim.mesh()).ok());
  // Refused while the blade is in the tissue (the undo stays standing).
  REQUIRE(sim.cutter().in_contact());
  CHECK(sim.undo_move() == "the blade is in the tissue");

  // Lift the blade out, then undo: the nodes that were there go back where they were.
  std::vector<ToolSample> out;
  ToolSample s = stab.back();
  for (int k = 1; k <= 100; ++k) {
    s.t += 0.001;
    s.position.z() += 0.0003;
    out.push_back(s);
  }
  run(sim, out);
  REQUIRE_FALSE(sim.cutter().in_contact());
  REQUIRE(sim.undo_move() == "");
  // Every node of the half from before the move that kept its rest position (the stab slid a few
  // cut nodes) is back where it was.
  double back = 0.0;
  std::size_t checked = 0;
  for (const NodeId n : sim.mesh().nodes())
    if (n.index < before.size() && sim.mesh().rest(n) == rest_before[n.index] &&
        sim.mesh().rest(n).y() > 0.0013 + 1e-9) {
      back = std::max(back, (sim.mesh().position(n) - before[n.index]).norm());
      ++checked;
    }
  CHECK(checked > 100);
  CHECK(back < 1e-17);  // [m] round-off of a turn there and back
}

TEST_CASE(
    "a severed piece is deleted: gone from the mesh, its volume off the total, the rest closed and valid, "
    "and "
    "cut again across where the pieces parted" *
    doctest::test_suite("slow")) {
  const Halves h = halves();
  Simulation sim(h.scenario);
  run(sim, h.samples);
  REQUIRE_FALSE(sim.cutter().in_contact());
  const double whole = sim.mesh().total_rest_volume();
  // A move of the far half first: its undo must find the piece gone.
  REQUIRE(sim.move_piece(Vec3(0.003, 0.006, -0.004), Eigen::Quaterniond::Identity(), Vec3(0, 0.002, 0)) ==
          "");
  CHECK(sim.delete_piece(Vec3(0.1, 0.1, 0.1)) == "no tissue at that point");

  // The half beyond y = 0.0013 (24 x 8.7 x 8 mm), where it lies now.
  REQUIRE(sim.delete_piece(Vec3(0.003, 0.008, -0.004)) == "");
  const double far = 0.024 * 0.0087 * 0.008, near = 0.024 * 0.0113 * 0.008;
  CHECK(sim.moves().back().action == PieceAction::Delete);
  CHECK(sim.moves().back().rest_volume == doctest::Approx(far).epsilon(1e-9));
  CHECK(sim.deleted_volume() == doctest::Approx(far).epsilon(1e-9));
  CHECK(sim.mesh().total_rest_volume() == doctest::Approx(whole - far).epsilon(1e-12));
  CHECK(sim.mesh().total_rest_volume() == doctest::Approx(near).epsilon(1e-9));
  CHECK(sim.cutter().rest_volume() == doctest::Approx(near).epsilon(1e-9));
  for (const NodeId n : sim.mesh().nodes()) CHECK(sim.mesh().rest(n).y() <= 0.0013 + 1e-9);
  CHECK(sim.delete_piece(Vec3(0.003, 0.008, -0.004)) == "no tissue at that point");
  CHECK(sim.undo_move() == "no move to undo");  // the deleted piece's move left the undo stack
  // Closed, oriented and conforming, with the volume that is left.
  const auto check = validate(sim.mesh(), {.reference_volume = sim.initial_volume() - sim.deleted_volume()});
  CHECK_MESSAGE(check.ok(), check.summary());
  CHECK(sim.cutter().check_faithful(1e-12) == "");
  // The cut surface is the kept half's face at y = 0.0013: 24 x 8 mm.
  CHECK(sim.cutter().cut_surface_area() == doctest::Approx(0.024 * 0.008).epsilon(1e-6));
  for (const auto& f : sim.cutter().cut_surface_faces())
    for (const NodeId n : f) CHECK(sim.mesh().alive(n));

  CHECK(sim.move_piece(Vec3(0.0, std::nan(""), 0.0), Eigen::Quaterniond::Identity(), Vec3::Zero()) ==
        "not a finite move");

  // Cut again: a blade along y at x = 3.1 mm, 4 mm deep, out through the face where the halves
  // parted. Valid after every frame, against the volume left.
  std::vector<ToolSample> stroke;
  const double t0 = h.samples.back().t + 0.5;
  for (int k = 0; k <= 1200; ++k) {
    ToolSample s;
    s.t = t0 + k / 1000.0;
    const double u = k / 1200.0;
    const double depth = std::min(1.0, 5 * u) * 0.016;
    s.position = Vec3(0.0031, -0.008 + 0.014 * std::max(0.0, (u - 0.2) / 0.8), 0.012 - depth);
    stroke.push_back(s);
  }
  std::string broken;
  run(sim, stroke, [&] {
    const auto r = validate(sim.mesh(), {.reference_volume = sim.initial_volume() - sim.deleted_volume()});
    if (!r.ok() && broken.empty()) broken = r.summary();
  });
  CHECK(broken == "");
  CHECK(sim.cutter().totals().edges_cut > 0);
  CHECK(sim.cutter().check_faithful(1e-12) == "");
  // The new cut reaches the old face: the kept half is now two quarters, each with its own volume.
  const std::vector<std::uint32_t> left = sim.piece_at(Vec3(-0.004, -0.004, -0.002));
  const std::vector<std::uint32_t> right = sim.piece_at(Vec3(0.008, -0.004, -0.002));
  REQUIRE_FALSE(left.empty());
  CHECK(left == right);  // 4 mm of 8 deep: joined below the cut
  // Deleting the last piece is refused.
  CHECK(sim.delete_piece(Vec3(-0.004, -0.004, -0.002)) == "it is all the tissue left");
}

TEST_CASE("a scenario's moves run at their times and are reported, and bad moves name their line and key" *
          doctest::test_suite("slow")) {
  const Halves h = halves(
      "moves:\n"
      "  - {at: 3, point: [0, 0.006, -0.004], translate: [0, 0.01, 0]}\n"
      "  - {at: 10, point: [0, 0.006, -0.004], translate: [0, 0.01, 0]}\n"
      "  - {at: 10, undo: true}\n");
  REQUIRE(h.scenario.moves.size() == 3);
  CHECK(h.scenario.moves[2].action == PieceAction::Undo);
  const double end = h.samples.back().t;
  std::vector<ToolSample> samples = h.samples;
  ToolSample s = samples.back();
  s.t = 11.0;  // after the cut, the knife held above the box
  samples.push_back(s);
  Simulation sim(h.scenario);
  run(sim, samples);
  REQUIRE(sim.moves().size() == 3);
  CHECK(sim.moves()[0].refused == "the blade is in the tissue");  // at 3 s the blade is cutting
  CHECK(sim.moves()[0].time < end);
  CHECK(sim.moves()[1].refused.empty());
  CHECK(sim.moves()[1].rest_volume == doctest::Approx(0.024 * 0.0087 * 0.008).epsilon(1e-9));
  CHECK(sim.moves()[2].action == PieceAction::Undo);
  CHECK(sim.moves()[2].refused.empty());

  struct Case {
    std::string text, field, message;
  };
  const Case cases[] = {
      {"moves:\n  - {at: 2, undo: true}\n  - {at: 1, undo: true}\n", "moves[1].at", "time order"},
      {"moves:\n  - {at: 1, undo: false}\n", "moves[0].undo", "expected true"},
      {"moves:\n  - {at: 1, translate: [0, 0, 1]}\n", "moves[0].point", "point"},
      {"moves:\n  - {at: 1, delete: true}\n", "moves[0].point", "point"},
      {"moves:\n  - {at: 1, point: [0, 0, 0], delete: false}\n", "moves[0].delete", "expected true"},
      {"moves:\n  - {at: 1, point: [0, 0, 0], delete: true, translate: [0, 0, 1]}\n", "moves[0].translate",
       ""},
      {"moves:\n  - {at: 1, point: [0, 0, 0], rotate: {axis: [0, 0, 0], angle_deg: 5}}\n",
       "moves[0].rotate.axis", "non-zero"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.text);
    try {
      (void)parse_scenario(scenario_text(write_linear_volume(), "") + c.text, "moves.yaml", ".");
      FAIL("no error");
    } catch (const InputError& e) {
      CHECK(e.field() == c.field);
      CHECK(std::string(e.what()).find(c.message) != std::string::npos);
    }
  }
  // Only rigid tissue moves.
  std::string soft = scenario_text(write_linear_volume(), "") + "moves:\n  - {at: 1, undo: true}\n";
  soft.replace(soft.find("tissue: {model: rigid}"), 22, "materials: {tissue: {young: 1.0e4, poisson: 0.4}}");
  CHECK_THROWS_WITH_AS((void)parse_scenario(soft, "moves.yaml", "."), doctest::Contains("rigid"), InputError);
}

TEST_CASE(
    "sculpting: the bundled bracket's V-notch frees a wedge of exactly the volume the two cut planes bound, "
    "taken aside and deleted" *
    doctest::test_suite("slow")) {
  const fs::path root(SCALPEL_SOURCE_DIR);
  const Scenario scenario = load_scenario(root / "config/scenarios/bracket_sculpt.yaml");
  CHECK(scenario.tissue.rigid);
  REQUIRE(scenario.task);
  CHECK_FALSE(scenario.task->scored);
  ReplayOptions options;
  options.out_dir = temp_dir() / "bracket";
  const ReplayResult result = replay(scenario, *scenario.log, options);
  CHECK(result.invariants_ok);
  CHECK(result.report["warnings"].empty());
  CHECK_FALSE(result.report.contains("task"));  // unscored
  CHECK(result.report["mesh"]["final"]["components"] == 1);
  CHECK(result.report["mesh"]["initial"]["tetrahedra"] == 3661);
  // The planes x + y = 56 mm and x - y = 32 mm meet 6 mm inside the 10 mm base's end face x = 50 mm:
  // a triangle of 12 x 6 / 2 mm^2 through the base.
  const double wedge = 12.0 * 6.0 / 2.0 * 10.0;  // [mm^3]
  const auto& moves = result.report["piece_moves"];
  REQUIRE(moves.size() == 2);
  CHECK(moves[0]["done"].get<bool>());
  CHECK(moves[0]["rest_volume_mm3"].get<double>() == doctest::Approx(wedge).epsilon(1e-7));
  CHECK(moves[1]["kind"] == "delete");
  CHECK(moves[1]["done"].get<bool>());
  CHECK(moves[1]["rest_volume_mm3"].get<double>() == doctest::Approx(wedge).epsilon(1e-7));
  // What is left is the part less the wedge, closed and oriented (invariants_ok above).
  const double initial = result.report["mesh"]["initial"]["rest_volume"].get<double>() * 1e9;
  const double final_volume = result.report["mesh"]["final"]["rest_volume"].get<double>() * 1e9;
  CHECK(final_volume == doctest::Approx(initial - wedge).epsilon(1e-9));

  // The wedge deleted where it was cut: a blade held in the notch is in no tissue (the part's outer
  // surface the task measures depth by has lost the wedge's faces).
  Scenario in_place = scenario;
  in_place.moves = {in_place.moves[1]};
  in_place.moves[0].point = Vec3(0.048, 0.012, 0.005);
  Simulation sim(in_place);
  std::vector<ToolSample> samples = read_pose_log(in_place.log->string());
  for (const double z : {0.02, 0.005, 0.02}) {
    ToolSample s = samples.back();
    s.t += 0.1;
    s.position = Vec3(0.047, 0.012, z);
    s.orientation = Eigen::Quaterniond::Identity();  // the blade upright
    samples.push_back(s);
  }
  const std::size_t n = samples.size();
  run(sim, std::vector<ToolSample>(samples.begin(), samples.end() - 2));
  REQUIRE(sim.moves().size() == 1);
  CHECK(sim.moves()[0].refused == "");
  sim.on_sample(samples[n - 2]);
  CHECK_FALSE(sim.scorer().last().in_tissue);
}

TEST_CASE("an unscored task guides the log generator and keeps no score" * doctest::test_suite("slow")) {
  std::string text = scenario_text(write_linear_volume());
  const Scenario scored = parse_scenario(text, "volume.yaml", ".");
  CHECK(scored.task->scored);
  text += "  scored: false\n";
  const Scenario unscored = parse_scenario(text, "volume.yaml", ".");
  CHECK_FALSE(unscored.task->scored);
  Simulation sim(unscored);
  run(sim, generate_task_log(unscored));
  CHECK(sim.cutter().totals().edges_cut > 0);
  CHECK_FALSE(sim.task_score().has_value());
  CHECK_THROWS_WITH_AS((void)parse_scenario(text + "  pass: {score: 50}\n", "volume.yaml", "."),
                       doctest::Contains("no pass thresholds"), InputError);
}
