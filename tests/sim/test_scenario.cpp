#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "base/input_error.hpp"
#include "mesh/topology.hpp"
#include "sim/scenario.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

// A valid scenario; the error tests change one line of it, so its line numbers matter.
const std::vector<std::string> kBase = {
    "name: test",                                        // 1
    "mesh:",                                             // 2
    "  generator: slab",                                 // 3
    "  size: [0.02, 0.01]",                              // 4
    "  cells: [4, 2]",                                   // 5
    "  layers:",                                         // 6
    "    - {name: top, thickness: 0.001, cells: 1}",     // 7
    "    - {name: bottom, thickness: 0.002, cells: 1}",  // 8
    "materials:",                                        // 9
    "  top:",                                            // 10
    "    young: 1.0e5",                                  // 11
    "    poisson: 0.45",                                 // 12
    "  bottom:",                                         // 13
    "    young: 1.0e4",                                  // 14
    "    poisson: 0.45",                                 // 15
    "fixed:",                                            // 16
    "  - {side: bottom}",                                // 17
    "task:",                                             // 18
    "  path: [[-0.005, 0, 0], [0.005, 0, 0]]",           // 19
    "  depth: [0.0005, 0.001]",                          // 20
};

// kBase with line `n` (1-based) replaced by `text` (which may hold several lines, or none).
std::string with_line(int n, const std::string& text) {
  std::string out;
  for (int i = 1; i <= static_cast<int>(kBase.size()); ++i) {
    const std::string& line = i == n ? text : kBase[static_cast<std::size_t>(i - 1)];
    if (i == n && text.empty()) continue;
    out += line + "\n";
  }
  return out;
}

// kBase without lines first..last (1-based, inclusive).
std::string without_lines(int first, int last) {
  std::string out;
  for (int i = 1; i <= static_cast<int>(kBase.size()); ++i)
    if (i < first || i > last) out += kBase[static_cast<std::size_t>(i - 1)] + "\n";
  return out;
}

std::string base_text() {
  return without_lines(0, 0);
}

fs::path temp_dir(const std::string& name) {
  const auto dir = fs::temp_directory_path() / ("scalpelsim_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void write_file(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
}

InputError scenario_error(const std::string& text) {
  try {
    (void)parse_scenario(text, "broken.yaml", "/scenarios");
  } catch (const InputError& e) {
    return e;
  }
  FAIL("no error raised for:\n" << text);
  return InputError("", 0, 0, "", "");
}

std::string bundled_scenario() {
  return std::string(SCALPEL_SOURCE_DIR) + "/config/scenarios/skin_incision.yaml";
}

}  // namespace

TEST_CASE("scenario: the bundled skin incision loads") {
  const Scenario s = load_scenario(bundled_scenario());
  CHECK(s.name == "skin_incision");
  CHECK_FALSE(s.description.empty());
  REQUIRE(s.mesh.kind == MeshKind::Slab);
  REQUIRE(s.mesh.slab.layers.size() == 3);
  CHECK(s.mesh.slab.layers[0].name == "epidermis");
  CHECK(s.mesh.slab.layers[1].name == "dermis");
  CHECK(s.mesh.slab.layers[2].name == "fat");

  const TetMesh mesh = build_generated_mesh(s);
  CHECK(mesh.tet_count() == 4950);
  const auto materials = resolve_materials(s, generated_region_ids(s), mesh);
  REQUIRE(materials.size() == 3);
  // Stiffer towards the surface; skin prestressed, fat not.
  CHECK(materials.at(0).young > materials.at(1).young);
  CHECK(materials.at(1).young > materials.at(2).young);
  CHECK(materials.at(0).prestress > 1.05);
  CHECK(materials.at(1).prestress > 1.05);
  CHECK(materials.at(2).prestress == 1.0);

  // Bottom and the four sides fixed; no node of the open top surface's interior.
  const auto fixed = select_fixed_nodes(s, mesh);
  CHECK(fixed.size() == 16 * 12 * 6 - 14 * 10 * 5);
  for (const NodeId n : fixed) {
    const Vec3& x = mesh.rest(n);
    const bool on_rim = std::abs(std::abs(x.x()) - 0.02) < 1e-12 || std::abs(std::abs(x.y()) - 0.015) < 1e-12;
    CHECK((on_rim || std::abs(x.z() + 0.008) < 1e-12));
  }

  REQUIRE(s.task.has_value());
  REQUIRE(s.task->incisions.size() == 1);
  const Incision& in = s.task->incisions.front();
  CHECK(in.path.size() == 2);
  CHECK((in.path[1] - in.path[0]).norm() == doctest::Approx(0.02));
  CHECK(in.depth_max <= 0.003);  // not into the fat
  CHECK(s.device.kind == DeviceKind::Mock);
  CHECK(s.device.rate == 1000.0);
  REQUIRE(s.log.has_value());
  CHECK(*s.log == (fs::path(SCALPEL_SOURCE_DIR) / "config/logs/skin_incision.csv").lexically_normal());
}

TEST_CASE("scenario: optional sections take their defaults") {
  const Scenario s = parse_scenario(base_text(), "base.yaml", "/somewhere");
  CHECK(s.file == "base.yaml");
  CHECK(s.tissue.model == TissueKind::Corotational);
  CHECK(s.tissue.rate == 60.0);
  CHECK(s.tissue.cg_tolerance == 1e-6);
  CHECK(s.tissue.cg_max_iterations == 200);
  CHECK(s.tissue.local_rings == 6);
  CHECK(s.tissue.threads == 2);
  CHECK(s.tissue.volume_springs);
  CHECK(s.tissue.gravity == Vec3(0, 0, -9.81));
  CHECK(s.simulation.visual_rate == 60.0);
  CHECK(s.simulation.cut_recursion_depth == 8);
  CHECK_FALSE(s.simulation.duration.has_value());
  CHECK(s.device.kind == DeviceKind::Mock);
  CHECK(s.device.rate == 1000.0);
  CHECK(s.device.queue_capacity == 4096);
  CHECK(s.device.mapping.scale == 1.0);
  CHECK(s.tool.blade_back == Vec3(0, 0, 0.02));
  CHECK(s.tool.blade_tip == Vec3::Zero());
  CHECK(s.tool.cutting_resistance == 350.0);
  CHECK(s.mesh.slab.split == CubeSplit::Six);
  REQUIRE(s.materials.size() == 2);
  CHECK(s.materials[0].region == "top");
  CHECK(s.materials[0].where.line == 10);
  CHECK(s.materials[0].material.density == Material{}.density);
  CHECK(s.materials[0].material.prestress == 1.0);
  CHECK(s.task->incisions.front().tolerance == 0.002);
  CHECK(s.task->pass.coverage == 0.95);
  CHECK(s.task->protected_regions.empty());
  CHECK_FALSE(s.log.has_value());
}

TEST_CASE("scenario: a task of several incisions, with protected regions and pass thresholds") {
  const std::string text =
      without_lines(18, 20) +
      "task:\n"
      "  incisions:\n"
      "    - {path: [[-0.005, 0, 0], [0.005, 0, 0]], tolerance: 0.001, depth: [0.0005, 0.001]}\n"
      "    - {path: [[0, -0.004, 0], [0, 0.004, 0]], depth: [0.0002, 0.0008]}\n"
      "  protected: [bottom]\n"
      "  pass: {score: 80, coverage: 0.9, strokes: 1, time: 12, force: [0.1, 3]}\n";
  const Scenario s = parse_scenario(text, "two.yaml", "/somewhere");
  REQUIRE(s.task);
  REQUIRE(s.task->incisions.size() == 2);
  CHECK(s.task->incisions[0].tolerance == 0.001);
  CHECK(s.task->incisions[1].tolerance == 0.002);  // the default
  CHECK(s.task->incisions[1].path[1] == Vec3(0, 0.004, 0));
  CHECK(s.task->incisions[1].depth_max == 0.0008);
  CHECK(s.task->protected_regions == std::vector<std::string>{"bottom"});
  CHECK(s.task->pass.score == 80);
  CHECK(s.task->pass.coverage == 0.9);
  CHECK(s.task->pass.strokes == 1);
  CHECK(s.task->pass.time == 12.0);
  CHECK(s.task->pass.force_min == 0.1);
  CHECK(s.task->pass.force_max == 3.0);
  CHECK(s.task->pass.depth_in_band == PassThresholds{}.depth_in_band);
}

TEST_CASE("scenario: every section parsed") {
  const std::string text = base_text() +
                           "tissue:\n"
                           "  model: mass_spring\n"
                           "  rate: 120\n"
                           "  solver: {tolerance: 1.0e-8, max_iterations: 50, local_rings: 2, threads: 1}\n"
                           "  gravity: [0, 0, 0]\n"
                           "  volume_springs: false\n"
                           "tool:\n"
                           "  name: blade15\n"
                           "  blade: {back: [0, 0.001, 0.01], tip: [0, 0, 0]}\n"
                           "  cutting_resistance: 200\n"
                           "device:\n"
                           "  kind: hid\n"
                           "  profile: novint_falcon\n"
                           "  rate: 2000\n"
                           "  queue_capacity: 256\n"
                           "  mapping: {scale: 0.5, offset: [0.01, 0, 0.02], rotation: {axis: [0, 0, 1], "
                           "angle_deg: 90}}\n"
                           "simulation: {visual_rate: 30, duration: 12.5, cut_recursion_depth: 3}\n"
                           "log: logs/run.csv\n";
  const Scenario s = parse_scenario(text, "full.yaml", "/data/scen");
  CHECK(s.tissue.model == TissueKind::MassSpring);
  CHECK(s.tissue.rate == 120.0);
  CHECK(s.tissue.cg_tolerance == 1e-8);
  CHECK(s.tissue.cg_max_iterations == 50);
  CHECK(s.tissue.local_rings == 2);
  CHECK(s.tissue.threads == 1);
  CHECK(s.tissue.gravity == Vec3::Zero());
  CHECK_FALSE(s.tissue.volume_springs);
  CHECK(s.tool.name == "blade15");
  CHECK(s.tool.blade_back == Vec3(0, 0.001, 0.01));
  CHECK(s.tool.cutting_resistance == 200.0);
  CHECK(s.device.kind == DeviceKind::Hid);
  CHECK(s.device.profile == "novint_falcon");
  CHECK(s.device.rate == 2000.0);
  CHECK(s.device.queue_capacity == 256);
  CHECK(s.device.mapping.scale == 0.5);
  CHECK(s.device.mapping.offset == Vec3(0.01, 0, 0.02));
  CHECK((s.device.mapping.rotation * Vec3::UnitX() - Vec3::UnitY()).norm() < 1e-15);
  CHECK(s.simulation.visual_rate == 30.0);
  CHECK(s.simulation.duration == 12.5);
  CHECK(s.simulation.cut_recursion_depth == 3);
  CHECK(*s.log == fs::path("/data/scen/logs/run.csv"));

  const Scenario q =
      parse_scenario(base_text() + "device: {mapping: {rotation: [0, 0, 0, 1]}}\n", "q.yaml", "/");
  CHECK(q.device.mapping.rotation.z() == 1.0);
}

TEST_CASE("scenario: each schema error names the file, line, column and key path") {
  struct Case {
    std::string what;
    std::string text;
    int line;
    int column;
    std::string field;
    std::string message_part;
  };
  const std::vector<Case> cases = {
      {"unknown top-level key", base_text() + "colour: red\n", 21, 1, "colour", "unknown key"},
      {"unknown nested key", with_line(12, "    poison: 0.45"), 12, 5, "materials.top.poison", "unknown key"},
      {"misspelt section", with_line(16, "fixd:"), 16, 1, "fixd", "unknown key"},
      {"number expected", with_line(11, "    young: soft"), 11, 12, "materials.top.young",
       "expected a number"},
      {"list expected", with_line(5, "  cells: 4"), 5, 10, "mesh.cells", "expected a list of 2 integers"},
      {"map expected", base_text() + "tool: 3\n", 21, 7, "tool", "expected a map"},
      {"empty value", with_line(11, "    young:"), 11, 5, "materials.top.young", "found nothing"},
      {"integer expected", with_line(5, "  cells: [4, 2.5]"), 5, 14, "mesh.cells[1]", "expected an integer"},
      {"poisson at 0.5", with_line(12, "    poisson: 0.5"), 12, 14, "materials.top.poisson", "out of range"},
      {"poisson at -1", with_line(15, "    poisson: -1"), 15, 14, "materials.bottom.poisson", "out of range"},
      {"negative young", with_line(14, "    young: -3"), 14, 12, "materials.bottom.young", "out of range"},
      {"zero density", with_line(15, "    poisson: 0.45\n    density: 0"), 16, 14, "materials.bottom.density",
       "out of range"},
      {"prestress too large", with_line(12, "    poisson: 0.45\n    prestress: 2.5"), 13, 16,
       "materials.top.prestress", "1 <= prestress < 2"},
      {"prestress below 1", with_line(12, "    poisson: 0.45\n    prestress: 0.9"), 13, 16,
       "materials.top.prestress", "out of range"},
      {"negative damping", with_line(12, "    poisson: 0.45\n    damping: {mass: -1}"), 13, 21,
       "materials.top.damping.mass", "out of range"},
      {"non-finite number", with_line(14, "    young: .inf"), 14, 12, "materials.bottom.young", "number"},
      {"a modulus beyond any material", with_line(14, "    young: 1.0e300"), 14, 12, "materials.bottom.young",
       "out of range"},
      {"gravity of 1e300", base_text() + "tissue: {gravity: [0, 0, -1.0e300]}\n", 21, 19, "tissue.gravity",
       "|gravity| <= 1000"},
      {"a visual rate of a microhertz", base_text() + "simulation: {visual_rate: 1.0e-6}\n", 21, 27,
       "simulation.visual_rate", "10 <= visual_rate <= 1000"},
      {"a session of 1e300 s", base_text() + "simulation: {duration: 1.0e300}\n", 21, 24,
       "simulation.duration", "out of range"},
      {"more tetrahedra than a replay can hold", with_line(5, "  cells: [1000, 1000]"), 5, 10, "mesh.cells",
       "more than the 2000000 a scenario may hold"},
      {"missing material key", with_line(11, ""), 10, 3, "materials.top.young", "missing required key"},
      {"missing name", with_line(1, ""), 1, 1, "name", "missing required key"},
      {"missing mesh source", with_line(3, ""), 2, 1, "mesh", "missing key 'generator'"},
      {"missing layers", without_lines(6, 8), 2, 1, "mesh.layers", "missing required key"},
      {"unknown generator", with_line(3, "  generator: sphere"), 3, 14, "mesh.generator",
       "unknown value 'sphere'"},
      {"bad split", with_line(5, "  cells: [4, 2]\n  split: 4"), 6, 10, "mesh.split", "5 or 6"},
      {"zero thickness", with_line(7, "    - {name: top, thickness: 0, cells: 1}"), 7, 30,
       "mesh.layers[0].thickness", "out of range"},
      {"size in millimetres", with_line(4, "  size: [20, 10]"), 4, 9, "mesh.size", "out of range"},
      {"duplicate layer", with_line(8, "    - {name: top, thickness: 0.002, cells: 1}"), 8, 14,
       "mesh.layers[1].name", "duplicate layer name"},
      {"duplicate key", with_line(15, "    poisson: 0.45\n    young: 3"), 16, 5, "materials.bottom.young",
       "duplicate key"},
      {"region not in the mesh", with_line(13, "  bone:"), 13, 3, "materials.bone", "no region of this name"},
      {"region without material", without_lines(13, 15), 9, 1, "materials",
       "no material for region 'bottom'"},
      {"task outside the mesh", with_line(19, "  path: [[-0.005, 0, 0], [0.05, 0, 0]]"), 19, 26,
       "task.path[1]", "outside the mesh"},
      {"task too short", with_line(19, "  path: [[0, 0, 0]]"), 19, 9, "task.path", "at least 2 points"},
      {"depth range reversed", with_line(20, "  depth: [0.001, 0.0005]"), 20, 10, "task.depth", "min < max"},
      {"protected region not in the mesh", with_line(20, "  depth: [0.0005, 0.001]\n  protected: [bone]"), 21,
       15, "task.protected[0]", "no region 'bone'"},
      {"pass fraction above one", with_line(20, "  depth: [0.0005, 0.001]\n  pass: {coverage: 1.5}"), 21, 20,
       "task.pass.coverage", "fraction"},
      {"incisions and a path", with_line(20, "  depth: [0.0005, 0.001]\n  incisions: []"), 21, 14,
       "task.incisions", "not both"},
      {"unknown side", with_line(17, "  - {side: left}"), 17, 12, "fixed[0].side", "unknown value 'left'"},
      {"empty selector", with_line(17, "  - {}"), 17, 5, "fixed[0]", "expected 'side' or 'box'"},
      {"unknown device", base_text() + "device: {kind: joystick}\n", 21, 16, "device.kind", "unknown value"},
      {"negative local rings", base_text() + "tissue: {solver: {local_rings: -1}}\n", 21, 32,
       "tissue.solver.local_rings", "out of range"},
      {"no tissue threads", base_text() + "tissue: {solver: {threads: 0}}\n", 21, 28, "tissue.solver.threads",
       "out of range"},
      {"haptic rate too low", base_text() + "device:\n  rate: 10\n", 22, 9, "device.rate", "100 <= rate"},
      {"negative recursion depth", base_text() + "simulation: {cut_recursion_depth: -1}\n", 21, 35,
       "simulation.cut_recursion_depth", "out of range"},
      {"fractional recursion depth", base_text() + "simulation: {cut_recursion_depth: 2.5}\n", 21, 35,
       "simulation.cut_recursion_depth", "expected an integer"},
      {"rotation not unit", base_text() + "device:\n  mapping: {rotation: [1, 0, 0, 0.1]}\n", 22, 23,
       "device.mapping.rotation", "norm"},
      {"volume springs without springs", base_text() + "tissue: {volume_springs: true}\n", 21, 10,
       "tissue.volume_springs", "mass_spring only"},
      {"blade of zero length", base_text() + "tool: {blade: {back: [0, 0, 0], tip: [0, 0, 0]}}\n", 21, 38,
       "tool.blade.tip", "blade length"},
      {"negative cutting resistance", base_text() + "tool: {cutting_resistance: -1}\n", 21, 28,
       "tool.cutting_resistance", "out of range"},
      {"unknown contact", base_text() + "tool: {contact: soft}\n", 21, 17, "tool.contact",
       "expected indent or none"},
      {"puncture force of zero", with_line(12, "    poisson: 0.45\n    puncture_force: 0"), 13, 21,
       "materials.top.puncture_force", "out of range"},
      {"mesh file and generator", with_line(3, "  generator: slab\n  file: a.msh"), 4, 3, "mesh.file",
       "not both"},
      {"bad YAML: unclosed bracket", with_line(4, "  size: [0.02, 0.01"), 5, 0, "", ""},
      {"bad YAML: bad indentation", with_line(12, "   poisson: 0.45"), 12, 0, "", ""},
      {"not a map", "- just\n- a list\n", 1, 1, "", "expected a map"},
  };
  for (const auto& c : cases) {
    CAPTURE(c.what);
    const InputError e = scenario_error(c.text);
    CAPTURE(std::string(e.what()));
    CHECK(e.file() == "broken.yaml");
    CHECK(e.line() == c.line);
    if (c.column > 0) CHECK(e.column() == c.column);
    CHECK(e.field() == c.field);
    CHECK(std::string(e.what()).find(c.message_part) != std::string::npos);
  }
}

TEST_CASE("scenario: the error message reads file:line:column: key: problem") {
  const InputError e = scenario_error(with_line(12, "    poisson: 0.5"));
  CHECK(std::string(e.what()) ==
        "broken.yaml:12:14: materials.top.poisson: 0.5 is out of range, expected -1 < "
        "poisson < 0.5");
}

TEST_CASE("scenario: files on disk") {
  const fs::path dir = temp_dir("scenario_files");
  SUBCASE("a missing scenario file") {
    CHECK_THROWS_AS((void)load_scenario(dir / "absent.yaml"), InputError);
  }
  SUBCASE("a folder, a device or a pipe is refused before it is read") {
    CHECK_THROWS_WITH_AS((void)load_scenario(dir), doctest::Contains("is a folder, expected a scenario file"),
                         InputError);
    CHECK_THROWS_WITH_AS((void)load_scenario("/dev/zero"), doctest::Contains("not a regular file"),
                         InputError);
  }
  SUBCASE("an empty scenario file") {
    write_file(dir / "empty.yaml", "# nothing here\n");
    CHECK_THROWS_WITH_AS((void)load_scenario(dir / "empty.yaml"), doctest::Contains("empty"), InputError);
  }
  SUBCASE("a broken file in the test data names itself and the line") {
    const std::string path = std::string(SCALPEL_TEST_DATA_DIR) + "/scenarios/bad_poisson.yaml";
    try {
      (void)load_scenario(path);
      FAIL("no error");
    } catch (const InputError& e) {
      CHECK(e.file() == path);
      CHECK(e.line() == 17);
      CHECK(e.field() == "materials.dermis.poisson");
    }
  }
  SUBCASE("a mesh file resolves against the scenario's folder") {
    fs::create_directories(dir / "meshes");
    write_file(dir / "meshes" / "liver.msh", "$MeshFormat\n");
    fs::create_directories(dir / "scen");
    const std::string text =
        "name: liver\nmesh: {file: ../meshes/liver.msh}\nmaterials:\n  liver: {young: 5.0e3, poisson: 0.45}\n"
        "  region_7: {young: 1.0e4, poisson: 0.4}\n";
    write_file(dir / "scen" / "liver.yaml", text);
    const Scenario s = load_scenario(dir / "scen" / "liver.yaml");
    CHECK(s.mesh.kind == MeshKind::File);
    CHECK(s.mesh.file == (dir / "meshes" / "liver.msh").lexically_normal());
    CHECK(generated_region_ids(s).empty());
    CHECK_THROWS_AS((void)build_generated_mesh(s), std::logic_error);

    // Names come from the mesh reader (e.g. Gmsh physical names) or the region_<id> form.
    const auto m = resolve_materials(s, {{"liver", 3}}, std::vector<int>{3, 7});
    REQUIRE(m.size() == 2);
    CHECK(m.at(3).young == 5.0e3);
    CHECK(m.at(7).poisson == 0.4);
    CHECK_THROWS_WITH_AS((void)resolve_materials(s, {}, std::vector<int>{3, 7}),
                         doctest::Contains("materials.liver"), InputError);
    CHECK_THROWS_WITH_AS((void)resolve_materials(s, {{"liver", 3}}, std::vector<int>{3, 7, 9}),
                         doctest::Contains("no material for region 'region_9'"), InputError);
    CHECK_THROWS_WITH_AS((void)resolve_materials(s, {{"liver", 7}}, std::vector<int>{7}),
                         doctest::Contains("already has a material"), InputError);

    write_file(dir / "scen" / "gone.yaml",
               "name: gone\nmesh: {file: nowhere.vtu}\nmaterials: {a: {young: 1, poisson: 0}}\n");
    CHECK_THROWS_WITH_AS((void)load_scenario(dir / "scen" / "gone.yaml"), doctest::Contains("mesh.file"),
                         InputError);
    write_file(dir / "scen" / "obj.yaml",
               "name: obj\nmesh: {file: ../meshes/liver.obj}\nmaterials: {a: {young: 1, poisson: 0}}\n");
    CHECK_THROWS_WITH_AS((void)load_scenario(dir / "scen" / "obj.yaml"),
                         doctest::Contains("unsupported mesh file"), InputError);
  }
  fs::remove_all(dir);
}

TEST_CASE("scenario: a box mesh with box and side selectors") {
  const std::string text =
      "name: block\n"
      "mesh: {generator: box, min: [0, 0, 0], max: [0.03, 0.02, 0.01], cells: [3, 2, 1], split: 5, region: "
      "liver}\n"
      "materials: {liver: {young: 3.0e3, poisson: 0.4}}\n"
      "fixed:\n"
      "  - {side: x_min}\n"
      "  - {box: {min: [0.029, -1, -1], max: [1, 1, 0.0001]}}\n";
  const Scenario s = parse_scenario(text, "block.yaml", "/");
  REQUIRE(s.mesh.kind == MeshKind::Box);
  CHECK(s.mesh.box.split == CubeSplit::Five);
  CHECK(generated_region_ids(s) == RegionIds{{"liver", 0}});
  const TetMesh mesh = build_generated_mesh(s);
  CHECK(mesh.tet_count() == 3 * 2 * 1 * 5);
  const auto fixed = select_fixed_nodes(s, mesh);
  // x_min face: 3 x 2 nodes; the box: the 3 bottom nodes at x = 0.03.
  CHECK(fixed.size() == 6 + 3);
  for (std::size_t i = 1; i < fixed.size(); ++i) CHECK(fixed[i - 1].index < fixed[i].index);

  const Scenario none = parse_scenario(
      text + "  - {box: {min: [0.001, 0.001, 0.001], max: [0.002, 0.002, 0.002]}}\n", "block.yaml", "/");
  try {
    (void)select_fixed_nodes(none, mesh);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(e.field() == "fixed[2]");
    CHECK(e.line() == 7);
  }
}
