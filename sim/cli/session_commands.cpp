#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>

#include <nlohmann/json.hpp>

#include "base/input_error.hpp"
#include "cutting/cut_table.hpp"
#include "cutting/state_graph.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/manifold.hpp"
#include "mesh/overlap.hpp"
#include "mesh/quality.hpp"
#include "mesh/validate.hpp"
#include "mesh/volume.hpp"
#include "sim/check.hpp"
#include "sim/cli/commands.hpp"
#include "sim/cli/common.hpp"
#include "sim/log_generator.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#ifdef SCALPEL_HAVE_GUI
#include "viewer/pictures.hpp"
#endif

namespace scalpel::cli {

int cmd_replay(const std::string& scenario_arg, const std::string& log_arg, const std::string& out,
               bool no_progress, bool strict, std::size_t mesh_every, bool exports,
               const ImageArgs& image_args) {
  const fs::path scenario_path = scenario_arg.empty() ? default_scenario() : fs::path(scenario_arg);
  const Scenario scenario = load_scenario(scenario_path);
  check_output_dir(out, "--out");
  fs::path log_path = log_arg;
  if (log_path.empty()) {
    if (!scenario.log)
      throw InputError(scenario_path.string(), 0, 0, "log", "no pose log given and the scenario names none");
    log_path = *scenario.log;
  }
  ReplayOptions options;
  options.out_dir = out;
  options.mesh_every = mesh_every;
  options.exports = exports;
  if (!no_progress && isatty(STDERR_FILENO)) options.progress = print_progress;
#ifdef SCALPEL_HAVE_GUI
  std::unique_ptr<ReplayPictures> pictures;
  if (image_args.images || image_args.every > 0) {
    PictureOptions po;
    po.dir = fs::path(out);
    po.every = image_args.every;
    if (std::sscanf(image_args.size.c_str(), "%dx%d", &po.width, &po.height) != 2 || po.width < 16 ||
        po.height < 16 || po.width > 8192 || po.height > 8192)
      throw InputError("--image-size", 0, 0, "--image-size", "expected WIDTHxHEIGHT, 16 to 8192 pixels each");
    pictures = std::make_unique<ReplayPictures>(po);
    options.on_frame = [&](const Simulation& sim, std::size_t frame, bool last) {
      (*pictures)(sim, frame, last);
    };
  }
#else
  if (image_args.images || image_args.every > 0)
    throw NoGraphics("this scalpelsim was built without the window and pictures (SCALPEL_BUILD_GUI=OFF)");
#endif
  const ReplayResult r = replay(scenario, log_path, options);
  const auto& c = r.report["cutting"];
  std::cout << "replayed " << r.report["replay"]["samples"] << " samples of " << log_path.string() << " on "
            << scenario_path.string() << "\n"
            << "  edges cut " << c["edges_cut"] << ", tetrahedra "
            << r.report["mesh"]["initial"]["tetrahedra"] << " -> " << r.report["mesh"]["final"]["tetrahedra"]
            << ", cut surface " << c["cut_surface_area"].get<double>() * 1e6 << " mm^2\n";
  if (r.report.contains("task")) {
    const auto& task = r.report["task"];
    std::cout << "  task score " << task["score"].get<double>() << " / 100, "
              << (task["passed"].get<bool>() ? "passed" : "not passed") << "\n";
    for (const auto& part : task["components"])
      if (!part["why"].get<std::string>().empty())
        std::cout << "    " << part["name"].get<std::string>() << ": " << part["why"].get<std::string>()
                  << "\n";
  }
  for (const auto* warnings : {&r.report["warnings"], &r.run["warnings"]})
    for (const auto& w : *warnings)
      std::cerr << "warning: " << w["message"].get<std::string>() << " (" << w["code"].get<std::string>()
                << ")\n";
  std::cout << "  invariants " << (r.invariants_ok ? "hold" : "BROKEN") << "\n"
            << "  wrote " << (fs::path(out) / "report.json").string() << ", "
            << (fs::path(out) / "run.json").string() << ", " << (fs::path(out) / "frames.csv").string()
            << " and " << (fs::path(out) / "mesh.vtu").string() << "\n";
  if (exports) std::cout << "  wrote mesh.msh, surface.stl, surface.obj and surface.ply in " << out << "\n";
#ifdef SCALPEL_HAVE_GUI
  if (pictures) std::cout << "  wrote " << pictures->written().size() << " pictures in " << out << "\n";
#endif
  if (!r.invariants_ok) return 1;
  if (!r.failure.empty()) {
    std::cerr << "error: " << r.failure << "\n";
    return kExitSimulationFailed;
  }
  // The session's warnings are errors under --strict; the frame rate's depends on the machine.
  return strict && !r.report["warnings"].empty() ? kExitStrict : 0;
}

namespace {

// A folder name from a session's name: letters, digits and '-', the rest '_'.
std::string slug(const std::string& name) {
  std::string out;
  for (const char c : name) out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
  return out;
}

}  // namespace

int cmd_check(const std::string& check_path, const std::string& out, const std::string& junit) {
  const CheckFile file = load_check_file(check_path);
  check_output_dir(out, "--out");
  if (!junit.empty()) check_output_file(junit, "--junit");
  std::vector<CheckOutcome> outcomes;
  bool broken = false, bad_input = false, failed_run = false;
  for (std::size_t i = 0; i < file.sessions.size(); ++i) {
    const CheckSession& cs = file.sessions[i];
    CheckOutcome outcome;
    outcome.name = cs.name;
    const fs::path dir = fs::path(out) / (std::to_string(i + 1) + "_" + slug(cs.name));
    outcome.out_dir = dir.string();
    const auto start = std::chrono::steady_clock::now();
    try {
      const Scenario scenario = load_scenario(cs.scenario);
      if (!cs.log && !scenario.log)
        throw InputError(check_path, cs.line, 0, "log", "no log given and the scenario names none");
      ReplayOptions options;
      options.out_dir = dir;
      const ReplayResult r = replay(scenario, cs.log.value_or(scenario.log.value_or(fs::path())), options);
      broken = broken || !r.invariants_ok;
      outcome.failures = unmet_expectations(file, cs, r.report, r.invariants_ok);
      if (!r.failure.empty()) {
        failed_run = true;
        outcome.failures.push_back("the replay failed: " + r.failure);
      }
    } catch (const InputError& e) {
      // A session that cannot be replayed fails; the others still run.
      bad_input = true;
      outcome.failures.push_back(std::string("bad input: ") + e.what());
    } catch (const std::exception& e) {
      failed_run = true;
      outcome.failures.push_back(std::string("the replay failed: ") + e.what());
    }
    outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << (outcome.failures.empty() ? "PASS " : "FAIL ") << cs.name << "  (" << dir.string() << ")\n";
    for (const std::string& f : outcome.failures) std::cout << "     " << f << "\n";
    outcomes.push_back(std::move(outcome));
  }
  std::size_t met = 0;
  for (const CheckOutcome& o : outcomes) met += o.failures.empty() ? 1 : 0;
  std::cout << met << " of " << outcomes.size() << " sessions met their expectations\n";
  if (!junit.empty()) {
    std::ofstream x(junit);
    x << junit_xml(file, outcomes);
    if (!x) throw std::runtime_error("cannot write " + junit);
    std::cout << "wrote " << junit << "\n";
  }
  if (bad_input) return 2;
  if (failed_run) return 3;
  if (broken) return 1;
  return met == outcomes.size() ? 0 : kExitExpectations;
}

// The instructor's pages: scripts/report.py (Python 3 and matplotlib) over replay outputs.
// SCALPEL_PYTHON names the interpreter; else Debian's, where python3-matplotlib installs.
int cmd_report(const std::vector<std::string>& sessions, const std::string& out) {
  const fs::path script = bundled("scripts/report.py");
  if (!fs::exists(script)) throw std::runtime_error("the report script is missing: " + script.string());
  const char* env = std::getenv("SCALPEL_PYTHON");
  const std::string python =
      env && *env ? env : (fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3");
  std::vector<std::string> args = {python, script.string(), "--out", out};
  args.insert(args.end(), sessions.begin(), sessions.end());
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, python.c_str(), nullptr, nullptr, argv.data(), environ) != 0)
    throw std::runtime_error("cannot run " + python + " (install python3 and python3-matplotlib)");
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) throw std::runtime_error("waiting for " + python + " failed");
  // The script's exit codes are the program's: 0, 2 bad input, 3 matplotlib missing.
  return WIFEXITED(status) ? WEXITSTATUS(status) : 3;
}

int cmd_validate(const std::string& path, bool strict) {
  const Scenario scenario = load_scenario(path);
  const ScenarioMesh m = load_scenario_mesh(scenario);
  // Rigid tissue without materials needs none (Simulation gives its regions a default).
  if (!scenario.tissue.rigid || !scenario.materials.empty())
    (void)resolve_materials(scenario, m.regions, m.mesh);
  (void)select_fixed_nodes(scenario, m.mesh);
  const auto report = validate(m.mesh, {.reference_volume = m.mesh.total_rest_volume()});
  const MeshSummary s = summarize(m.mesh);
  std::cout << path << ": scenario '" << scenario.name << "', " << s.tets << " tetrahedra, " << s.nodes
            << " nodes, " << s.regions << " regions\n";
  if (!report.ok()) {
    std::cout << report.summary();
    return 1;
  }
  std::cout << "  mesh invariants hold\n";
  if (m.file_info.reoriented_tets > 0)
    std::cout << "  " << m.file_info.reoriented_tets << " tetrahedra of " << scenario.mesh.file.string()
              << " were given inverted and were re-oriented\n";
  if (m.file_info.skipped_elements > 0)
    std::cout << "  " << m.file_info.skipped_elements << " elements of " << scenario.mesh.file.string()
              << " that are not tetrahedra were left out\n";
  if (scenario.log && !fs::exists(*scenario.log))
    throw InputError(path, 0, 0, "log", "the pose log '" + scenario.log->string() + "' does not exist");
  const auto warnings = scenario_warnings(scenario, m.mesh);
  for (const InputWarning& w : warnings) std::cerr << "warning: " << w.message << " (" << w.code << ")\n";
  return strict && !warnings.empty() ? kExitStrict : 0;
}

// The reachable state machine of the bundled table, or of a script: a listing, or Graphviz.
int cmd_states(const std::string& table_path, bool dot) {
  const CutTable table = table_path.empty() ? default_cut_table() : load_cut_table(table_path);
  std::cout << (dot ? state_dot(table) : state_listing(table));
  return 0;
}

int cmd_inspect(const std::string& path, bool as_json) {
  MeshFileInfo info;
  const TetMesh mesh = read_mesh(path, &info);
  const MeshSummary s = summarize(mesh);
  // The invariants hold at rest (docs/invariants.md); a mesh scalpelsim wrote carries its rest
  // positions, and its deformed positions may turn a sliver over, which is counted apart.
  const auto report = validate(mesh, {.reference_volume = s.rest_volume});
  const ManifoldReport manifold = check_manifold(mesh);
  const OverlapReport overlaps = check_overlaps(mesh);
  std::size_t inverted_now = 0;
  if (info.has_rest_positions)
    for (const TetId t : mesh.tets()) {
      const auto v = mesh.tet_nodes(t);
      inverted_now += signed_volume(mesh.position(v[0]), mesh.position(v[1]), mesh.position(v[2]),
                                    mesh.position(v[3])) <= 0.0
                          ? 1
                          : 0;
    }
  std::map<int, std::size_t> tets_in;
  for (const TetId t : mesh.tets()) ++tets_in[mesh.region(t)];
  const auto region_name = [&info](int id) {
    for (const MeshRegion& r : info.regions)
      if (r.id == id && !r.name.empty()) return r.name;
    return std::string();
  };
  if (as_json) {
    nlohmann::ordered_json j;
    j["file"] = path;
    j["nodes"] = s.nodes;
    j["tetrahedra"] = s.tets;
    j["boundary_faces"] = s.boundary_faces;
    j["components"] = s.components;
    j["regions"] = s.regions;
    nlohmann::ordered_json regions = nlohmann::ordered_json::array();
    for (const auto& [id, n] : tets_in)
      regions.push_back({{"id", id}, {"name", region_name(id)}, {"tetrahedra", n}});
    j["region_list"] = regions;
    j["rest_volume"] = s.rest_volume;
    j["bounding_box"] = {{"min", {s.box_min.x(), s.box_min.y(), s.box_min.z()}},
                         {"max", {s.box_max.x(), s.box_max.y(), s.box_max.z()}}};
    j["quality"] = {
        {"min", s.quality_min}, {"mean", s.quality_mean}, {"max", s.quality_max}, {"slivers", s.slivers}};
    j["edge_length"] = {{"min", s.edge_min}, {"max", s.edge_max}};
    j["reoriented_tetrahedra"] = info.reoriented_tets;
    j["skipped_elements"] = info.skipped_elements;
    j["manifold"] = {{"ok", manifold.ok()},
                     {"pinched_vertices", manifold.pinched_vertices.size()},
                     {"pinched_edges", manifold.pinched_edges.size()}};
    j["overlapping_pairs"] = overlaps.pairs;
    j["unused_points"] = info.unused_points;
    j["rest_positions_from_file"] = info.has_rest_positions;
    j["inverted_in_current_positions"] = inverted_now;
    j["invariants"] = {{"oriented", report.passed[1]},
                       {"conforming", report.passed[2]},
                       {"watertight", report.passed[3]},
                       {"volume", report.passed[4]}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::cout << path << "\n"
              << "  nodes " << s.nodes << ", tetrahedra " << s.tets << ", boundary faces " << s.boundary_faces
              << (info.unused_points ? ", unused points " + std::to_string(info.unused_points) : "") << "\n"
              << "  components " << s.components << ", regions " << s.regions << ", volume " << s.rest_volume
              << " m^3\n";
    for (const auto& [id, n] : tets_in) {
      const std::string name = region_name(id);
      std::cout << "    region " << id << (name.empty() ? "" : " '" + name + "'") << ": " << n
                << " tetrahedra\n";
    }
    std::cout << "  bounding box [" << s.box_min.x() << ", " << s.box_max.x() << "] x [" << s.box_min.y()
              << ", " << s.box_max.y() << "] x [" << s.box_min.z() << ", " << s.box_max.z() << "] m"
              << (info.has_rest_positions ? " (at rest, from the file's rest_position)" : "") << "\n"
              << "  quality (6 sqrt2 V / l_rms^3) min " << s.quality_min << ", mean " << s.quality_mean
              << ", max " << s.quality_max << ", slivers (< 0.1) " << s.slivers << "\n"
              << "  edge length min " << s.edge_min << " m, max " << s.edge_max << " m\n";
    if (info.has_rest_positions)
      std::cout << "  inverted in the current (deformed) positions: " << inverted_now << " tetrahedra\n";
    if (info.reoriented_tets > 0)
      std::cout << "  " << info.reoriented_tets << " tetrahedra were given inverted and were re-oriented\n";
    if (info.skipped_elements > 0)
      std::cout << "  " << info.skipped_elements << " elements that are not tetrahedra were left out\n";
    std::cout << "  manifold: " << (manifold.ok() ? "yes" : "NO, " + manifold.summary(mesh)) << "\n";
    std::cout << "  overlapping tetrahedra: " << (overlaps.ok() ? "none" : "YES, " + overlaps.summary(mesh))
              << "\n";
    std::cout << "  invariants: " << (report.ok() ? "all hold" : "BROKEN") << "\n";
    if (!report.ok()) std::cout << report.summary();
  }
  // Exit 1 for broken invariants only: a cut mesh may be pinched along the front of a crack (README,
  // "Not yet"), which `validate` refuses in a mesh given as input.
  return report.ok() ? 0 : 1;
}

int cmd_make_log(const std::string& scenario_path, const std::string& out, const IncisionMotion& motion) {
  const Scenario scenario = load_scenario(scenario_path);
  check_output_file(out, "--out");
  write_task_log(scenario, out, motion);
  std::cout << "wrote " << out << "\n";
  return 0;
}

int cmd_make_volume(const std::string& out) {
  check_output_file(out, "--out");
  write_nrrd_volume(strata_volume(), out);
  std::cout << "wrote " << out << "\n";
  return 0;
}

}  // namespace scalpel::cli
