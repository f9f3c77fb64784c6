// A live session without a window (sim/session.hpp): the bundled incision played back at real
// speed through the haptic loop on the real clock and the simulation thread. Prints the haptic
// period and the simulation's frame time, p50, p99 and max: the headless figures to hold against
// `scalpelsim train --device mock --close-at-end`, which prints the same with its window open.
//
//   ./build/release/bench/bench_session [speed]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <thread>
#include <vector>

#include "devices/playback_device.hpp"
#include "devices/pose_log.hpp"
#include "sim/quantile.hpp"
#include "sim/scenario.hpp"
#include "sim/session.hpp"

using namespace scalpel;

namespace {}  // namespace

int main(int argc, char** argv) {
  const double speed = argc > 1 ? std::atof(argv[1]) : 1.0;
  const Scenario scenario =
      load_scenario(std::filesystem::path(SCALPEL_SOURCE_DIR) / "config/scenarios/skin_incision.yaml");
  PlaybackDevice device(read_pose_log(scenario.log->string()));
  device.set_speed(speed);
  Session session(scenario, device, &device, {});
  session.start();
  // Until the simulation has taken the log's last pose, as the window's --close-at-end.
  while (true) {
    if (session.update() && session.frame().status.playback_ended) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(16));
  }
  session.stop();
  const std::vector<double> periods = session.haptic_periods();
  const std::vector<double>& frames = session.frame_seconds();
  std::printf("headless session, playback at %gx: %.2f s of session time\n", device.speed(),
              session.frame().status.time);
  std::printf("  simulation frame p50 %.2f ms, p99 %.2f ms, max %.2f ms over %zu frames\n",
              1e3 * quantile(frames, 0.5), 1e3 * quantile(frames, 0.99), 1e3 * quantile(frames, 1.0),
              frames.size());
  std::printf("  haptic period p50 %.1f us, p99 %.1f us, max %.1f us over %zu cycles\n",
              1e6 * quantile(periods, 0.5), 1e6 * quantile(periods, 0.99), 1e6 * quantile(periods, 1.0),
              periods.size());
  return 0;
}
