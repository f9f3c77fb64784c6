// The trainee's window (viewer/train_window.hpp) on a virtual display: a recorded incision played
// back in it, seen in the screenshot taken as it closes. The test starts its own Xvfb (Debian's
// xvfb package), so it needs no display of the machine's.
#include <doctest/doctest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <stb_image.h>

#include "devices/playback_device.hpp"
#include "devices/pose_log.hpp"
#include "sim/replay.hpp"
#include "sim/scenario.hpp"
#include "sim/session.hpp"
#include "sim/simulation.hpp"
#include "viewer/pictures.hpp"
#include "viewer/train_window.hpp"

using namespace scalpel;
namespace fs = std::filesystem;

namespace {

// An X server of its own for the test: Xvfb picks a free display and writes its number to a pipe.
class VirtualDisplay {
 public:
  VirtualDisplay() {
    int fds[2];
    REQUIRE(pipe(fds) == 0);
    pid_ = fork();
    REQUIRE(pid_ >= 0);
    if (pid_ == 0) {
      close(fds[0]);
      const int devnull = open("/dev/null", O_WRONLY);
      dup2(devnull, STDERR_FILENO);
      const std::string fd = std::to_string(fds[1]);
      execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "1024x640x24", "-nolisten", "tcp",
             static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    std::string number;
    char c;
    while (read(fds[0], &c, 1) == 1 && c != '\n') number += c;
    close(fds[0]);
    REQUIRE_MESSAGE(!number.empty(), "Xvfb did not start (install the xvfb package)");
    name_ = ":" + number;
    if (const char* old = std::getenv("DISPLAY")) old_ = old;
    setenv("DISPLAY", name_.c_str(), 1);
  }
  ~VirtualDisplay() {
    if (old_.empty())
      unsetenv("DISPLAY");
    else
      setenv("DISPLAY", old_.c_str(), 1);
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }
  VirtualDisplay(const VirtualDisplay&) = delete;
  VirtualDisplay& operator=(const VirtualDisplay&) = delete;

 private:
  pid_t pid_ = -1;
  std::string name_, old_;
};

// The bundled incision, cutting on touch: under ThreadSanitizer the live simulation falls far behind
// the played-back log, and the press before the cut (docs/contact.md) then decides how much of the
// incision a merged sweep cuts; this test is about the window.
Scenario bundled_incision() {
  Scenario s = load_scenario(fs::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml");
  s.tool.contact = ToolContactKind::None;
  return s;
}

// A folder of the system's temporary folder, emptied.
fs::path empty_folder(const char* name) {
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

bool is_wound(const unsigned char* p) {
  return p[0] > 40 && p[0] > 3 * p[1] && p[0] > 3 * p[2];
}

}  // namespace

TEST_CASE("the trainee's window shows a played-back incision opening, with its overlay, and records it" *
          doctest::test_suite("slow")) {
  VirtualDisplay display;
  const Scenario scenario = bundled_incision();
  const fs::path dir = empty_folder("scalpelsim_test_window");
  PlaybackDevice device(read_pose_log(scenario.log->string()));
  device.set_speed(4.0);
  SessionOptions so;
  so.record = dir / "session.csv";
  Session session(scenario, device, &device, so);
  TrainWindowOptions wo;
  wo.close_at_end = true;
  wo.close_after = 600.0;  // a hang fails
  wo.final_screenshot = dir / "window.png";
  const TrainWindowResult r = run_train_window(session, nullptr, &device, wo);
  REQUIRE_FALSE(session.failed());
  CHECK(r.render_seconds.size() >= 2);
  REQUIRE(r.screenshots.size() == 1);
  REQUIRE(fs::exists(wo.final_screenshot));

  int w = 0, h = 0, channels = 0;
  unsigned char* pixels = stbi_load(wo.final_screenshot.string().c_str(), &w, &h, &channels, 3);
  REQUIRE(pixels != nullptr);
  CHECK(w == wo.width);
  CHECK(h == wo.height);
  // The whole incision, opened: the window closed when the simulation had taken the log's last pose.
  CHECK(session.frame().status.playback_ended);
  REQUIRE(session.frame().status.task.component("coverage"));
  CHECK(session.frame().status.task.component("coverage")->value > 90);
  std::size_t wound = 0, panel = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const unsigned char* p = pixels + (static_cast<std::size_t>(y) * w + x) * 3;
      wound += is_wound(p) ? 1 : 0;
      // Dear ImGui's dark window background, top left: the overlay.
      if (x < 300 && y < 300 && p[0] < 25 && p[1] < 25 && p[2] < 25) ++panel;
    }
  stbi_image_free(pixels);
  MESSAGE("wound pixels " << wound << ", overlay pixels " << panel << ", session time "
                          << session.frame().status.time << " s");
  CHECK(session.frame().snapshot.wound_vertices > 0);
  CHECK(wound > 100);
  CHECK(panel > 10000);
  // The recording holds every sample the simulation took.
  REQUIRE(session.recordings().size() == 1);
  CHECK(read_pose_log(session.recordings()[0].string()).size() == session.simulation().samples());
}

// The three threads of `scalpelsim train --device mock` together: the haptic loop at 1 kHz on the
// real clock, the simulation at the visual rate, the window drawing what it publishes. Under
// ThreadSanitizer (scripts/test.sh tsan) this checks every hand-over between them in a live run.
TEST_CASE(
    "the window, the simulation and the haptic loop run together on the mock device: every sample "
    "sent is simulated and recorded, and the recording replays to the same mesh" *
    doctest::test_suite("slow")) {
  VirtualDisplay display;
  const Scenario scenario = bundled_incision();
  const fs::path dir = empty_folder("scalpelsim_test_window_threads");
  // The bundled incision's first 2 s, at real speed: the blade enters the skin and cuts along half
  // of the line. The window closes when the simulation has taken the last sample the loop sent.
  std::vector<ToolSample> log = read_pose_log(scenario.log->string());
  const double end = log.front().t + 2.0;
  std::erase_if(log, [&](const ToolSample& s) { return s.t > end; });
  PlaybackDevice device(log);
  SessionOptions so;
  so.record = dir / "live.csv";
  Session session(scenario, device, &device, so);
  session.update();
  const std::size_t uncut = session.frame().snapshot.tetrahedra;
  TrainWindowOptions wo;
  wo.close_at_end = true;
  wo.close_after = 600.0;  // a hang fails
  const TrainWindowResult r = run_train_window(session, nullptr, &device, wo);
  INFO(session.error());
  REQUIRE_FALSE(session.failed());
  session.update();  // the last frame the simulation published
  const SessionFrame& last = session.frame();
  REQUIRE(last.status.playback_ended);  // not closed by the time limit
  const Simulation& live = session.simulation();
  MESSAGE(live.samples() << " samples in " << live.tissue_steps().size() << " frames, "
                         << r.render_seconds.size() << " drawn");
  // The loop ran about 2000 cycles; a loaded machine makes it miss some, never most.
  CHECK(live.samples() > 500);
  CHECK(session.haptic_periods().size() + 1 >= live.samples());
  CHECK(last.snapshot.tetrahedra > uncut);
  CHECK(r.render_seconds.size() >= 2);

  // The recording holds every sample the simulation took, in order, and the frames it ran.
  REQUIRE(session.recordings().size() == 1);
  CHECK(last.status.recorded == live.samples());
  PoseLogReader reader(session.recordings()[0].string());
  std::size_t recorded = 0, backwards = 0;
  double t = -1.0;
  for (ToolSample s; reader.next(s); ++recorded) {
    backwards += s.t > t ? 0 : 1;
    t = s.t;
  }
  CHECK(recorded == live.samples());
  CHECK(backwards == 0);
  CHECK(reader.metadata("frames") == std::to_string(live.tissue_steps().size()));

  // Replayed headless, in one thread, it gives the live mesh bit for bit.
  std::vector<Vec3> positions;
  ReplayOptions ro;
  ro.out_dir = dir / "replay";
  ro.on_frame = [&](const Simulation& sim, std::size_t, bool final) {
    if (final) positions = sim.mesh().positions();
  };
  (void)replay(scenario, session.recordings()[0], ro);
  REQUIRE(positions.size() == live.mesh().positions().size());
  std::size_t differing = 0;
  for (std::size_t i = 0; i < positions.size(); ++i)
    differing += positions[i] != live.mesh().positions()[i] ? 1 : 0;
  CHECK(differing == 0);
}
