// scalpelsim: the command-line program. Every command prints its own --help.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <thread>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "base/input_error.hpp"
#include "cutting/cut_table.hpp"
#include "cutting/state_graph.hpp"
#include "devices/device_access.hpp"
#include "devices/device_profile.hpp"
#include "devices/hid_device.hpp"
#include "devices/mock_device.hpp"
#include "devices/pose_log.hpp"
#include "haptics/recorder.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/manifold.hpp"
#include "mesh/quality.hpp"
#include "mesh/validate.hpp"
#include "sim/check.hpp"
#include "sim/log_generator.hpp"
#include "sim/quantile.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "sim/version.hpp"
#ifdef SCALPEL_HAVE_GUI
#include "devices/playback_device.hpp"
#include "devices/pointer_device.hpp"
#include "sim/session.hpp"
#include "viewer/gl.hpp"
#include "viewer/pictures.hpp"
#include "viewer/train_window.hpp"
#endif

namespace fs = std::filesystem;
using namespace scalpel;

namespace {

// A bundled file: in an installed layout beside the executable (PREFIX/bin/scalpelsim and
// PREFIX/share/scalpelsim/...), else from the working directory upwards, else in the source tree
// the program was built from.
fs::path bundled(const fs::path& relative) {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share/scalpelsim" / relative;
    if (fs::exists(installed)) return installed;
  }
  for (fs::path dir = fs::current_path(); !dir.empty(); dir = dir.parent_path()) {
    if (fs::exists(dir / relative)) return dir / relative;
    if (dir == dir.parent_path()) break;
  }
  return fs::path(SCALPEL_SOURCE_DIR) / relative;
}

fs::path default_scenario() {
  return bundled("config/scenarios/skin_incision.yaml");
}

std::atomic<bool> g_stop{false};
extern "C" void on_interrupt(int) {
  g_stop.store(true);
}

void print_progress(double fraction) {
  constexpr int kWidth = 40;
  const int filled = static_cast<int>(fraction * kWidth);
  std::fprintf(stderr, "\r[%.*s%*s] %3d%%", filled, "########################################",
               kWidth - filled, "", static_cast<int>(fraction * 100));
  if (fraction >= 1.0) std::fprintf(stderr, "\n");
}

// Exit codes (README): 0 done, 1 mesh invariants broken, 2 bad input or usage, 3 any other error,
// 4 no graphics (built without the window, or no OpenGL 3.3 context), 5 warnings under --strict.
constexpr int kExitUsage = 2;
constexpr int kExitNoGraphics = 4;
constexpr int kExitStrict = 5;
constexpr int kExitExpectations = 6;      // `check`: a session did not show what its check file expects
constexpr int kExitSimulationFailed = 7;  // the run ended, but the tissue solve met NaN or infinity
constexpr int kExitNoDevice = 8;          // `record`: no device attached or accessible, nothing recorded

// An output folder the command will write, checked before anything runs: created if missing, and
// refused (bad input) when it is a file or not writable.
void check_output_dir(const fs::path& dir, const std::string& option) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir))
    throw InputError(option, 0, 0, option,
                     "'" + dir.string() + "' is not a folder that can be created" +
                         (ec ? " (" + ec.message() + ")" : std::string()));
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw InputError(option, 0, 0, option, "cannot write in '" + dir.string() + "': " + std::strerror(errno));
}

// An output file: its folder must exist and be writable, and it must not be a folder.
void check_output_file(const fs::path& file, const std::string& option) {
  if (fs::is_directory(file))
    throw InputError(option, 0, 0, option, "'" + file.string() + "' is a folder, expected a file");
  const fs::path dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
  if (!fs::is_directory(dir))
    throw InputError(option, 0, 0, option, "the folder '" + dir.string() + "' does not exist");
  if (::access(dir.c_str(), W_OK | X_OK) != 0 || (fs::exists(file) && ::access(file.c_str(), W_OK) != 0))
    throw InputError(option, 0, 0, option, "cannot write '" + file.string() + "': " + std::strerror(errno));
}

// A command that needs OpenGL in a build without it.
struct NoGraphics : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct ImageArgs {
  bool images = false;
  std::size_t every = 0;
  std::string size = "1200x900";
};

int cmd_replay(const std::string& scenario_arg, const std::string& log_arg, const std::string& out,
               bool no_progress, bool strict, std::size_t mesh_every, const ImageArgs& image_args) {
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

// A folder name from a session's name: letters, digits and '-', the rest '_'.
std::string slug(const std::string& name) {
  std::string out;
  for (const char c : name) out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
  return out;
}

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

int cmd_devices(const std::string& profiles_dir, bool all) {
  const auto profiles = load_device_profiles(profiles_dir);
  const auto found = enumerate_devices(profiles, all);
  if (found.empty()) std::cout << "no " << (all ? "" : "matching ") << "devices attached\n";
  for (const FoundDevice& d : found) {
    char ids[16];
    std::snprintf(ids, sizeof ids, "%04x:%04x", d.vendor_id, d.product_id);
    std::cout << ids << "  " << (d.manufacturer.empty() ? "?" : d.manufacturer) << " "
              << (d.product.empty() ? "?" : d.product) << "  serial " << (d.serial.empty() ? "-" : d.serial)
              << "  path " << d.path << "  profile "
              << (d.profile >= 0 ? profiles[static_cast<size_t>(d.profile)].name : "(none)") << "\n";
  }
  return 0;
}

struct RecordArgs {
  std::string scenario, device, profiles_dir, serial, path, replay_log, out;
  double duration = 0.0, wait = 0.0;
  bool unpaced = false;
};

// Waits until the device the profile and selector name is attached, with its status on the
// terminal; false when Ctrl-C or `wait_seconds` (0: no limit) ended the wait first.
bool wait_for_device(const DeviceProfile& profile, const DeviceSelector& selector, double wait_seconds) {
  const std::string wanted = wanted_device(profile, selector);
  const auto t0 = std::chrono::steady_clock::now();
  bool told = false;
  while (find_devices(profile, selector).empty()) {
    const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (g_stop.load() || (wait_seconds > 0.0 && waited >= wait_seconds)) {
      if (told) std::fprintf(stderr, "\n");
      std::cerr << "error: " << wanted << " is not attached (waited " << static_cast<int>(waited)
                << " s); `scalpelsim devices --all` lists what is\n";
      return false;
    }
    std::fprintf(stderr, "\rwaiting for %s: %d s (Ctrl-C stops)", wanted.c_str(), static_cast<int>(waited));
    told = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  if (told) std::fprintf(stderr, "\n");
  return true;
}

// A pose log for a device to play back, with a word on the terminal when reading takes a while
// and a warning when its last line is torn.
std::vector<ToolSample> read_log_for_playback(const std::string& path) {
  std::error_code ec;
  const auto bytes = fs::file_size(path, ec);
  const bool large = !ec && bytes > (16u << 20);
  if (large) std::cerr << "reading " << path << " (" << (bytes >> 20) << " MB)...\n";
  std::string torn;
  std::vector<ToolSample> samples = read_pose_log(path, &torn);
  if (large) std::cerr << "read " << samples.size() << " samples\n";
  if (!torn.empty()) std::cerr << "warning: " << torn << "\n";
  return samples;
}

int cmd_record(const RecordArgs& a) {
  const Scenario scenario = load_scenario(a.scenario);
  check_output_file(a.out, "--out");
  std::unique_ptr<Device> device;
  std::string device_name = a.device;
  RecordingOptions options;
  options.loop.rate = scenario.device.rate;
  options.queue_capacity = static_cast<std::size_t>(scenario.device.queue_capacity);
  options.duration = a.duration;
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  if (a.device == "mock") {
    if (a.replay_log.empty())
      throw InputError(a.scenario, 0, 0, "--replay", "the mock device needs --replay LOG");
    auto mock = std::make_unique<MockDevice>(read_log_for_playback(a.replay_log));
    // Paced: the log plays at its own rate on the real clock, like the hand that recorded it.
    options.virtual_clock = a.unpaced;
    if (!a.unpaced && a.duration <= 0.0) options.duration = mock->duration() + 1.0 / options.loop.rate;
    device = std::move(mock);
    device_name = "mock";
  } else {
    const std::string name = a.device.empty() ? scenario.device.profile : a.device;
    if (name.empty())
      throw InputError(a.scenario, 0, 0, "device.profile", "no device profile given (--device)");
    const fs::path file =
        fs::path(name).has_extension() ? fs::path(name) : fs::path(a.profiles_dir) / (name + ".yaml");
    const DeviceProfile profile = load_device_profile(file.string());
    const DeviceSelector selector{a.serial, a.path};
    if (!a.path.empty() && profile.transport == Transport::Hid && !fs::exists(a.path))
      throw InputError(
          "--path", 0, 0, "--path",
          "'" + a.path + "' does not exist; `scalpelsim devices --all` lists the devices' paths");
    if (!wait_for_device(profile, selector, a.wait)) return kExitNoDevice;
    for (const FoundDevice& d : find_devices(profile, selector))
      if (const std::string problem = access_problem(d); !problem.empty()) {
        std::cerr << "error: " << problem << "\n";
        return kExitNoDevice;
      }
    device = open_device(profile, selector);
    device_name = profile.name;
  }
  char rate[32];
  std::snprintf(rate, sizeof rate, "%g Hz", scenario.device.rate);
  PoseLogWriter writer(a.out, {{"device", device_name}, {"scenario", scenario.name}, {"rate", rate}}, true);
  if (!options.virtual_clock)
    std::cerr << "recording " << device_name << " to " << a.out
              << (a.device == "mock" ? " at the log's pace" : "") << "; Ctrl-C stops\n";
  ForceChannel forces;
  const RecordingResult r = record_session(
      *device, forces, options, [&](const ToolSample& s) { writer.write(s); }, [&] { writer.flush(); },
      g_stop);
  writer.sync();
  if (!r.warning.empty()) std::cerr << "warning: " << r.warning << "\n";
  std::cout << "recorded " << r.samples << " samples to " << a.out << " (" << r.flushes << " flushes, "
            << r.device.short_reports + r.device.malformed_reports << " bad reports skipped, "
            << r.device.rejected_poses << " poses rejected)\n";
  if (r.samples == 0 || r.loop.device_not_ok == r.loop.cycles) {
    std::cerr << "error: nothing was recorded: " << device_name
              << " gave no pose (it sent no report the profile decodes, or was unplugged)\n";
    return kExitNoDevice;
  }
  return 0;
}

struct TrainArgs {
  std::string scenario, device = "pointer", replay_log, record, serial, path, profiles_dir, size = "1024x640",
                        screenshot;
  double speed = 1.0, close_after = 0.0;
  bool transparent = false, wireframe = false, close_at_end = false;
};

int cmd_train(const TrainArgs& a) {
#ifndef SCALPEL_HAVE_GUI
  (void)a;
  throw NoGraphics("this scalpelsim was built without the window (SCALPEL_BUILD_GUI=OFF)");
#else
  const fs::path scenario_path = a.scenario.empty() ? default_scenario() : fs::path(a.scenario);
  Scenario scenario = load_scenario(scenario_path);
  TrainWindowOptions wo;
  if (std::sscanf(a.size.c_str(), "%dx%d", &wo.width, &wo.height) != 2 || wo.width < 64 || wo.height < 64)
    throw InputError("--size", 0, 0, "--size", "expected WIDTHxHEIGHT, at least 64 pixels each");
  std::unique_ptr<Device> device;
  PointerDevice* pointer = nullptr;
  PlaybackDevice* playback = nullptr;
  std::string device_name = a.device;
  if (a.device == "pointer") {
    // The mouse moves the tool in world coordinates: the scenario's device mapping is for its device.
    scenario.device.mapping = DeviceMapping{};
    PointerMapping m;
    m.metres_per_pixel = 1e-4;
    m.metres_per_notch = 0.25e-3;
    m.key_speed = 0.005;
    const ScenarioMesh sm = load_scenario_mesh(scenario);
    Vec3 lo = sm.mesh.rest_positions().front(), hi = lo;
    for (const Vec3& p : sm.mesh.rest_positions()) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    // The blade starts 3 mm above the skin, before the start of the target line when there is one.
    m.home = scenario.task ? Vec3(scenario.task->incisions.front().path.front() - Vec3(0.003, 0, 0))
                           : Vec3((lo + hi) / 2);
    m.home.z() = hi.z() + 0.003;
    m.workspace_min = lo - Vec3::Constant(0.03);
    m.workspace_max = hi + Vec3::Constant(0.03);
    auto p = std::make_unique<PointerDevice>(m);
    pointer = p.get();
    device = std::move(p);
  } else if (a.device == "mock") {
    fs::path log = a.replay_log;
    if (log.empty() && scenario.log) log = *scenario.log;
    if (log.empty())
      throw InputError(scenario_path.string(), 0, 0, "--replay", "--device mock needs --replay LOG");
    auto p = std::make_unique<PlaybackDevice>(read_log_for_playback(log.string()));
    p->set_speed(a.speed);
    playback = p.get();
    device = std::move(p);
    device_name = "playback of " + log.string();
  } else {
    const std::string name = a.device.empty() ? scenario.device.profile : a.device;
    const fs::path file =
        fs::path(name).has_extension() ? fs::path(name) : fs::path(a.profiles_dir) / (name + ".yaml");
    const DeviceProfile profile = load_device_profile(file.string());
    device = open_device(profile, {a.serial, a.path});
    device_name = profile.name;
  }
  SessionOptions so;
  so.record = a.record;
  so.device_name = device_name;
  so.wireframe_edges = a.wireframe;
  Session session(scenario, *device, playback, so);
  wo.title = "scalpelsim: " + scenario.name;
  wo.close_after = a.close_after;
  wo.close_at_end = a.close_at_end;
  wo.final_screenshot = a.screenshot;
  wo.transparent = a.transparent;
  wo.wireframe = a.wireframe;
  wo.stop = &g_stop;
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  const TrainWindowResult r = run_train_window(session, pointer, playback, wo);
  if (!session.haptic_warning().empty()) std::cerr << "warning: " << session.haptic_warning() << "\n";
  session.update();  // the last frame the session published
  const SessionFrame& last = session.frame();
  const std::vector<double> periods = session.haptic_periods();
  std::cout << "session on " << scenario_path.string() << ": " << last.status.time << " s\n";
  if (last.status.has_task)
    std::cout << "  task score " << last.status.task.score << " / 100, "
              << (last.status.task.passed ? "passed" : "not passed") << "\n";
  std::cout << "  render frame p50 " << 1e3 * quantile(r.render_seconds, 0.5) << " ms, p99 "
            << 1e3 * quantile(r.render_seconds, 0.99) << " ms over " << r.render_seconds.size() << " frames\n"
            << "  simulation frame p50 " << 1e3 * quantile(session.frame_seconds(), 0.5) << " ms, p99 "
            << 1e3 * quantile(session.frame_seconds(), 0.99) << " ms, max "
            << 1e3 * quantile(session.frame_seconds(), 1.0) << " ms over " << session.frame_seconds().size()
            << " frames\n"
            << "  haptic period p50 " << 1e6 * quantile(periods, 0.5) << " us, p99 "
            << 1e6 * quantile(periods, 0.99) << " us, max " << 1e6 * quantile(periods, 1.0) << " us\n";
  for (const auto& p : session.recordings()) std::cout << "  recorded " << p.string() << "\n";
  for (const auto& p : r.screenshots) std::cout << "  screenshot " << p.string() << "\n";
  if (session.failed()) {
    std::cerr << "error: the session stopped: " << session.error() << "\n";
    return 3;
  }
  return 0;
#endif
}

// Every usage error exits 2 (README) with what went wrong and where to look; CLI11's own codes
// differ by error.
int usage_error(const CLI::App& app, int argc, char** argv, const CLI::ParseError& e) {
  // A first word that is no command: CLI11 would only say that a subcommand is required.
  if (argc > 1 && argv[1][0] != '-' && app.get_subcommands().empty()) {
    std::string names;
    for (const CLI::App* sub : app.get_subcommands({}))
      names += (names.empty() ? "" : ", ") + sub->get_name();
    std::cerr << "error: '" << argv[1] << "' is not a command; the commands are " << names
              << " (scalpelsim --help)\n";
    return kExitUsage;
  }
  std::string where = "scalpelsim";
  for (const CLI::App* sub : app.get_subcommands()) where += " " + sub->get_name();
  std::cerr << "error: " << e.what() << "\nsee: " << where << " --help\n";
  return kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"scalpelsim: real-time progressive cutting of tetrahedral meshes"};
  app.set_version_flag("--version", std::string(version()) + " (" + build_description() + ")");
  app.require_subcommand(1);

  std::string scenario, log, out = "out", mesh_path, make_log_out;
  bool json = false, no_progress = false, strict = false;

  auto* replay_cmd =
      app.add_subcommand("replay", "Replay a pose log headless; writes report.json and mesh.vtu");
  replay_cmd->add_option("scenario", scenario,
                         "Scenario YAML (default: config/scenarios/skin_incision.yaml)");
  replay_cmd->add_option("log", log, "Pose log CSV (default: the scenario's `log`)");
  replay_cmd->add_option("--out", out, "Output folder")->capture_default_str();
  replay_cmd->add_flag("--no-progress", no_progress, "No progress bar on the terminal");
  replay_cmd->add_flag(
      "--strict", strict,
      "Exit 5 when the report holds warnings (implausible input or physics, docs/formats.md)");
  ImageArgs image_args;
  std::size_t mesh_every = 0;
  replay_cmd->add_flag("--images", image_args.images,
                       "Also write PNG pictures of the final state: top.png, oblique.png, section.png");
  replay_cmd->add_option("--image-every", image_args.every,
                         "And the oblique view every N frames, as frames/oblique_<frame>.png");
  replay_cmd->add_option("--mesh-every", mesh_every,
                         "A ParaView time series: the mesh every N frames in series/, listed in mesh.pvd");
  replay_cmd->add_option("--image-size", image_args.size, "Picture size, WIDTHxHEIGHT")
      ->capture_default_str();

  auto* validate_cmd = app.add_subcommand("validate", "Check a scenario and its mesh without running it");
  validate_cmd->add_option("scenario", scenario, "Scenario YAML")->required();
  validate_cmd->add_flag(
      "--strict", strict,
      "Exit 5 when the scenario draws warnings (a mesh in millimetres, a task outside it)");

  auto* inspect_cmd =
      app.add_subcommand("inspect", "Counts, volume, components, quality and invariants of a mesh file");
  inspect_cmd->add_option("mesh", mesh_path, "Mesh file: .msh (2.2/4.1 ASCII), .node/.ele, .vtu")->required();
  inspect_cmd->add_flag("--json", json, "Print JSON");

  std::string table_path;
  bool dot = false;
  auto* states_cmd = app.add_subcommand(
      "states", "List the cut state machine's reachable states, or draw it with Graphviz (--dot)");
  states_cmd->add_option("--table", table_path,
                         "State machine script (default: the bundled config/cutting/state_machine.cut)");
  states_cmd->add_flag("--dot", dot, "Print a Graphviz digraph: scalpelsim states --dot | dot -Tsvg");

  std::vector<std::string> report_sessions;
  std::string report_out = "report";
  auto* report_cmd = app.add_subcommand(
      "report",
      "Write the instructor's HTML pages from replay outputs: one per session, and a progress page");
  report_cmd
      ->add_option("sessions", report_sessions, "Replay output folders (--out of replay), in attempt order")
      ->required();
  report_cmd->add_option("--out", report_out, "Folder for the pages")->capture_default_str();
  std::string check_file, junit;
  auto* check_cmd = app.add_subcommand(
      "check", "Replay the sessions of a check file and test each against its expectations (CI)");
  check_cmd->add_option("file", check_file, "Check file (YAML): sessions and what each must show")
      ->required();
  check_cmd->add_option("--out", out, "Folder for the replays' outputs, one sub-folder a session")
      ->capture_default_str();
  check_cmd->add_option("--junit", junit, "Write the results as JUnit XML to this file");
  auto* make_log_cmd =
      app.add_subcommand("make-log", "Generate the pose log of a scenario's task (the bundled log)");
  make_log_cmd->add_option("scenario", scenario, "Scenario YAML with a task")->required();
  make_log_cmd->add_option("--out", make_log_out, "Pose log to write")->required();
  IncisionMotion motion;
  make_log_cmd->add_option("--tremble", motion.tremble, "Hand tremor, peak-to-peak per axis [m]")
      ->check(CLI::NonNegativeNumber);
  make_log_cmd->add_option("--pull-back", motion.pull_back, "Pull back and re-cut this far, twice [m]")
      ->check(CLI::NonNegativeNumber);
  make_log_cmd->add_flag(
      "!--as-written", motion.follow_settled_tissue,
      "Aim at the task's path and depth as written, not where the settled tissue carried them");
  make_log_cmd->add_option("--cross", motion.cross, "Then cut again across the middle, this long [m]")
      ->check(CLI::NonNegativeNumber);

  std::string profiles_dir = bundled("config/devices").string();
  bool all_devices = false;
  auto* devices_cmd = app.add_subcommand("devices", "List attached HID devices and the profile each matches");
  devices_cmd->add_option("--profiles", profiles_dir, "Folder of device profiles")->capture_default_str();
  devices_cmd->add_flag("--all", all_devices, "Also list devices no profile matches");

  RecordArgs rec;
  rec.profiles_dir = profiles_dir;
  auto* record_cmd = app.add_subcommand("record", "Record a session from a device to a pose log");
  record_cmd->add_option("scenario", rec.scenario, "Scenario YAML (rates, queue, device profile)")
      ->required();
  record_cmd->add_option(
      "--device", rec.device,
      "Device profile name or file (default: the scenario's device.profile); 'mock' replays --replay");
  record_cmd->add_option("--out", rec.out, "Pose log to write")->required();
  record_cmd->add_option("--duration", rec.duration, "Seconds to record (default: until Ctrl-C)");
  record_cmd->add_option("--serial", rec.serial, "Open the device with this serial number");
  record_cmd->add_option("--path", rec.path, "Open the device at this path");
  record_cmd->add_option("--replay", rec.replay_log, "With --device mock: the log the mock device replays");
  record_cmd->add_option("--profiles", rec.profiles_dir, "Folder of device profiles")->capture_default_str();
  record_cmd
      ->add_option("--wait", rec.wait,
                   "Seconds to wait for the device to be attached (default: until it is, or Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  record_cmd->add_flag("--unpaced", rec.unpaced,
                       "With --device mock: record as fast as possible instead of at the log's pace");

  TrainArgs tr;
  tr.profiles_dir = profiles_dir;
  auto* train_cmd = app.add_subcommand("train", "Cut the scenario's tissue live in a window");
  train_cmd->add_option("scenario", tr.scenario,
                        "Scenario YAML (default: config/scenarios/skin_incision.yaml)");
  train_cmd
      ->add_option("--device", tr.device,
                   "pointer (mouse and keys), mock (play back --replay), or a device profile name or file")
      ->capture_default_str();
  train_cmd->add_option("--replay", tr.replay_log,
                        "With --device mock: the log to play back (default: the scenario's)");
  train_cmd->add_option("--speed", tr.speed, "With --device mock: playback speed, 0.25 to 4")
      ->check(CLI::Range(0.25, 4.0));
  train_cmd->add_option("--record", tr.record,
                        "Record the session to this pose log (a reset starts LOG.2, ...)");
  train_cmd->add_option("--serial", tr.serial, "Open the device with this serial number");
  train_cmd->add_option("--path", tr.path, "Open the device at this path");
  train_cmd->add_option("--profiles", tr.profiles_dir, "Folder of device profiles")->capture_default_str();
  train_cmd->add_option("--size", tr.size, "Window size, WIDTHxHEIGHT")->capture_default_str();
  train_cmd->add_option("--close-after", tr.close_after, "Close the window after this many seconds")
      ->check(CLI::NonNegativeNumber);
  train_cmd->add_flag("--close-at-end", tr.close_at_end,
                      "With --device mock: close when the log has been played");
  train_cmd->add_option("--screenshot", tr.screenshot, "Write a screenshot (PNG) as the window closes");
  train_cmd->add_flag("--see-through", tr.transparent, "Start with the skin see-through");
  train_cmd->add_flag("--tetrahedra", tr.wireframe, "Start with the tetrahedra's edges drawn");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return usage_error(app, argc, argv, e);
  }
  try {
    if (*replay_cmd) return cmd_replay(scenario, log, out, no_progress, strict, mesh_every, image_args);
    if (*validate_cmd) return cmd_validate(scenario, strict);
    if (*check_cmd) return cmd_check(check_file, out, junit);
    if (*report_cmd) return cmd_report(report_sessions, report_out);
    if (*inspect_cmd) return cmd_inspect(mesh_path, json);
    if (*states_cmd) return cmd_states(table_path, dot);
    if (*make_log_cmd) return cmd_make_log(scenario, make_log_out, motion);
    if (*devices_cmd) return cmd_devices(profiles_dir, all_devices);
    if (*record_cmd) return cmd_record(rec);
    if (*train_cmd) return cmd_train(tr);
  } catch (const InputErrors& e) {
    for (const InputError& one : e.all()) std::cerr << "error: " << one.InputError::what() << "\n";
    std::cerr << e.all().size() << " errors\n";
    return kExitUsage;
  } catch (const InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kExitUsage;
  } catch (const NoGraphics& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kExitNoGraphics;
#ifdef SCALPEL_HAVE_GUI
  } catch (const RenderError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kExitNoGraphics;
#endif
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
