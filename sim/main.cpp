// scalpelsim: the command-line program. Every command prints its own --help; the commands
// themselves are in sim/cli/.
#include <iostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "base/input_error.hpp"
#include "sim/cli/commands.hpp"
#include "sim/cli/common.hpp"
#include "sim/version.hpp"
#ifdef SCALPEL_HAVE_GUI
#include "viewer/gl.hpp"
#endif

using namespace scalpel;
using namespace scalpel::cli;

namespace {

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
  bool exports = false;
  replay_cmd->add_flag("--export", exports,
                       "Also write the final mesh as mesh.msh and its surface as surface.stl, .obj and .ply");
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
  make_log_cmd->add_option("--depth", motion.depth, "Tip depth below the surface [m] (default: the task's)")
      ->check(CLI::PositiveNumber);
  make_log_cmd
      ->add_option("--extend", motion.extend,
                   "Start and end each incision this far beyond its path's ends [m]")
      ->check(CLI::NonNegativeNumber);

  std::string make_volume_out;
  auto* make_volume_cmd = app.add_subcommand(
      "make-volume", "Write the layered seismic data set of the volume data scenario (NRRD)");
  make_volume_cmd->add_option("--out", make_volume_out, "NRRD file to write (.nrrd)")->required();

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
    if (*replay_cmd)
      return cmd_replay(scenario, log, out, no_progress, strict, mesh_every, exports, image_args);
    if (*validate_cmd) return cmd_validate(scenario, strict);
    if (*check_cmd) return cmd_check(check_file, out, junit);
    if (*report_cmd) return cmd_report(report_sessions, report_out);
    if (*inspect_cmd) return cmd_inspect(mesh_path, json);
    if (*states_cmd) return cmd_states(table_path, dot);
    if (*make_log_cmd) return cmd_make_log(scenario, make_log_out, motion);
    if (*make_volume_cmd) return cmd_make_volume(make_volume_out);
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
