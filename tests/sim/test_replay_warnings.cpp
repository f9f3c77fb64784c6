// What a replay warns about (docs/formats.md, `warnings`): input or physics that makes its figures
// meaningless, said in the report and on the terminal instead of a silent exit 0; and
// simulation.duration, which ends the session where the scenario says.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "devices/pose_log.hpp"
#include "mesh/generators.hpp"
#include "mesh/io/mesh_io.hpp"
#include "sim/log_generator.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("scalpelsim_warn_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

fs::path write_log(const fs::path& dir, const std::vector<ToolSample>& samples, const PoseLogMetadata& meta) {
  const fs::path path = dir / "log.csv";
  PoseLogWriter writer(path.string(), meta);
  for (const ToolSample& s : samples) writer.write(s);
  writer.flush();
  return path;
}

std::vector<std::string> codes(const ReplayResult& r) {
  std::vector<std::string> out;
  for (const auto& w : r.report["warnings"]) out.push_back(w["code"].get<std::string>());
  return out;
}

bool has(const std::vector<std::string>& v, const std::string& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

Scenario bundled() {
  return load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml");
}

}  // namespace

TEST_CASE("replay warnings: the reference session has none, and two replays write the same report" *
          doctest::test_suite("slow")) {
  const Scenario s = bundled();
  const fs::path dir = fresh_dir("reference");
  const fs::path log = write_log(dir, generate_task_log(s), task_log_metadata(s));
  ReplayOptions options;
  options.out_dir = dir / "a";
  const ReplayResult a = replay(s, log, options);
  CHECK(a.report["warnings"].empty());
  CHECK(a.run.contains("timings"));
  CHECK_FALSE(a.report.contains("timings"));
  options.out_dir = dir / "b";
  const ReplayResult b = replay(s, log, options);
  CHECK(a.report.dump() == b.report.dump());  // report.json byte for byte; timings are in run.json
  const auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  CHECK(bytes(dir / "a/frames.csv") == bytes(dir / "b/frames.csv"));
  CHECK(bytes(dir / "a/report.json") == bytes(dir / "b/report.json"));
}

TEST_CASE("replay warnings: a blade that never went into the tissue" * doctest::test_suite("slow")) {
  const Scenario s = bundled();
  std::vector<ToolSample> samples = generate_task_log(s);
  for (ToolSample& x : samples) x.position.z() += 0.02;
  const fs::path dir = fresh_dir("above");
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r = replay(s, write_log(dir, samples, task_log_metadata(s)), options);
  CAPTURE(r.report["warnings"].dump());
  CHECK(has(codes(r), "blade_never_met_tissue"));
  CHECK_FALSE(r.report["task"]["passed"].get<bool>());
  CHECK(r.report["task"]["score"].get<double>() < 50.0);
}

TEST_CASE("replay warnings: a log recorded on another scenario" * doctest::test_suite("slow")) {
  const Scenario s = bundled();
  PoseLogMetadata meta = task_log_metadata(s);
  for (auto& [key, value] : meta)
    if (key == "scenario") value = "liver_resection";
  const fs::path dir = fresh_dir("other_scenario");
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r = replay(s, write_log(dir, generate_task_log(s), meta), options);
  REQUIRE(has(codes(r), "log_scenario"));
  CHECK(r.report["warnings"][0]["message"].get<std::string>().find("liver_resection") != std::string::npos);
}

TEST_CASE("replay warnings: a mesh written in millimetres, and a task outside it" *
          doctest::test_suite("slow")) {
  // The bundled patch's box, 40 x 30 x 8 "metres": millimetres read as metres.
  BoxSpec spec;
  spec.min = Vec3(-20, -15, -8);
  spec.max = Vec3(20, 15, 0);
  spec.cells = {4, 3, 2};
  const fs::path dir = fresh_dir("millimetres");
  write_vtu(make_box(spec), (dir / "patch_mm.vtu").string());
  const std::string text =
      "name: millimetres\n"
      "mesh: {file: patch_mm.vtu}\n"
      "materials:\n"
      "  region_0: {young: 1.0e5, poisson: 0.45}\n"
      "fixed:\n"
      "  - {side: bottom}\n"
      "task:\n"
      "  path: [[30, 0, 0], [35, 0, 0]]\n"
      "  depth: [0.0025, 0.003]\n";
  const Scenario s = parse_scenario(text, (dir / "mm.yaml").string(), dir);
  const Scenario reference = bundled();
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r =
      replay(s, write_log(dir, generate_task_log(reference), task_log_metadata(reference)), options);
  CAPTURE(r.report["warnings"].dump());
  const auto c = codes(r);
  CHECK(has(c, "mesh_scale"));
  CHECK(has(c, "task_outside_mesh"));
  CHECK(has(c, "log_scenario"));
  for (const auto& w : r.report["warnings"])
    if (w["code"] == "mesh_scale")
      CHECK(w["message"].get<std::string>().find("millimetres") != std::string::npos);
}

TEST_CASE("replay: simulation.duration ends the session there" * doctest::test_suite("slow")) {
  const Scenario full = bundled();
  Scenario s = full;
  s.simulation.duration = 1.0;
  const fs::path dir = fresh_dir("duration");
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r = replay(s, *full.log, options);
  CHECK(r.report["replay"]["frames"] == 60);
  // The blade had only come down by then: it never drew the line.
  CHECK(r.report["task"]["incisions"][0]["coverage"].get<double>() < 0.2);
}

TEST_CASE("replay warnings: soft tissue dragged far by a blade with a high resistance" *
          doctest::test_suite("slow")) {
  // 3 kPa tissue against 3000 N/m of blade edge: the blade drags it a quarter of a metre.
  Scenario s = bundled();
  for (RegionMaterial& m : s.materials) m.material.young = 3e3;
  s.tool.cutting_resistance = 3000;
  s.tool.contact = ToolContactKind::None;  // it cuts in at once: no press on the soft skin first
  s.simulation.duration = 1.0;
  const fs::path dir = fresh_dir("dragged");
  ReplayOptions options;
  options.out_dir = dir / "out";
  const ReplayResult r = replay(s, *s.log, options);
  CAPTURE(r.report["warnings"].dump());
  CHECK(has(codes(r), "tissue_displaced"));
}

TEST_CASE("replay: a ParaView time series of the mesh every N frames" * doctest::test_suite("slow")) {
  Scenario s = bundled();
  s.simulation.duration = 0.5;  // 30 frames
  const fs::path dir = fresh_dir("series");
  ReplayOptions options;
  options.out_dir = dir / "out";
  options.mesh_every = 12;
  (void)replay(s, *s.log, options);
  std::ifstream pvd(dir / "out/mesh.pvd");
  REQUIRE(pvd);
  const std::string text((std::istreambuf_iterator<char>(pvd)), std::istreambuf_iterator<char>());
  // Frames 12 and 24, and the last (30), with their times.
  CHECK(text.find("timestep=\"0.2\" part=\"0\" file=\"series/mesh_000012.vtu\"") != std::string::npos);
  CHECK(text.find("timestep=\"0.4\" part=\"0\" file=\"series/mesh_000024.vtu\"") != std::string::npos);
  CHECK(text.find("timestep=\"0.5\" part=\"0\" file=\"series/mesh_000030.vtu\"") != std::string::npos);
  for (const char* f : {"series/mesh_000012.vtu", "series/mesh_000024.vtu", "series/mesh_000030.vtu"}) {
    MeshFileInfo info;
    const TetMesh m = read_vtu((dir / "out" / f).string(), &info);
    CHECK(m.tet_count() > 0);
    CHECK(info.has_rest_positions);
  }
}
