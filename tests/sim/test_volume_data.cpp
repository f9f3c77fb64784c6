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
    if (s.t >= next) {
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
    "rest position") {
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

TEST_CASE("rigid tissue does not move: cut or not, every node stays at its rest position") {
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
    "the bundled seismic data set is what make-volume writes, and its replay writes the field with the mesh" *
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
  std::ifstream in(options.out_dir / "mesh.vtu");
  std::stringstream text;
  text << in.rdbuf();
  CHECK(text.str().find("Name=\"amplitude\"") != std::string::npos);
}
