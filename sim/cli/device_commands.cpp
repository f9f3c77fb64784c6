#include <chrono>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <thread>

#include "base/input_error.hpp"
#include "devices/device_access.hpp"
#include "devices/device_profile.hpp"
#include "devices/hid_device.hpp"
#include "devices/mock_device.hpp"
#include "devices/pose_log.hpp"
#include "haptics/recorder.hpp"
#include "sim/cli/commands.hpp"
#include "sim/cli/common.hpp"
#include "sim/quantile.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#ifdef SCALPEL_HAVE_GUI
#include "devices/playback_device.hpp"
#include "devices/pointer_device.hpp"
#include "sim/session.hpp"
#include "viewer/gl.hpp"
#include "viewer/train_window.hpp"
#endif

namespace scalpel::cli {

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

namespace {

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

// A pose log for a device to play back, with a word on the terminal when reading takes a while,
// a warning when it was recorded on another scenario than `scenario` (a replay reports the same,
// docs/formats.md) and one when its last line is torn.
std::vector<ToolSample> read_log_for_playback(const std::string& path, const std::string& scenario) {
  std::error_code ec;
  const auto bytes = fs::file_size(path, ec);
  const bool large = !ec && bytes > (16u << 20);
  if (large) std::cerr << "reading " << path << " (" << (bytes >> 20) << " MB)...\n";
  PoseLogReader reader(path);
  if (const auto recorded_on = reader.metadata("scenario"); recorded_on && *recorded_on != scenario)
    std::cerr << "warning: " << path << " was recorded on scenario '" << *recorded_on << "', played on '"
              << scenario << "'\n";
  std::vector<ToolSample> samples;
  for (ToolSample s; reader.next(s);) samples.push_back(s);
  if (large) std::cerr << "read " << samples.size() << " samples\n";
  if (!reader.torn_warning().empty()) std::cerr << "warning: " << reader.torn_warning() << "\n";
  return samples;
}

}  // namespace

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
    auto mock = std::make_unique<MockDevice>(read_log_for_playback(a.replay_log, scenario.name));
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
    auto p = std::make_unique<PlaybackDevice>(read_log_for_playback(log.string(), scenario.name));
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

}  // namespace scalpel::cli
