// Deterministic pose logs that perform a scenario's task: the scalpel comes down onto the start
// of the target path, enters the tissue tip first, draws the incision at a constant depth and lifts
// out. Used for the bundled demonstration log, for replay tests and for benchmarks.
#pragma once

#include <numbers>
#include <string>
#include <vector>

#include "devices/pose_log.hpp"
#include "devices/tool_sample.hpp"
#include "sim/scenario.hpp"

namespace scalpel {

// How the scalpel is moved. Each phase (plunge, cut, lift) follows a minimum-jerk profile
// s(u) = 10u^3 - 15u^4 + 6u^5 (Flash and Hogan 1985), so it starts and ends at rest; its peak speed
// is 1.875 times its mean speed.
struct IncisionMotion {
  double approach_height = 0.005;               // [m] tip height above the surface at start and end
  double tilt = 40.0 * std::numbers::pi / 180;  // [rad] blade from vertical, back above and behind the tip
  double cut_speed = 0.010;                     // [m/s] mean speed along the path
  double plunge_speed = 0.010;                  // [m/s] mean vertical speed entering and leaving
  double hold = 0.1;                            // [s] at rest before and after
  double depth = -1.0;                          // [m] tip depth; < 0: middle of the task's depth range
  double corner_radius = 0.002;                 // [m] arc length over which the heading turns at a corner
  // Hand tremor (paper section 5): a smooth oscillation of the tool position in all three directions
  // while the blade is in the tissue, three incommensurate sines around `tremble_frequency`.
  double tremble = 0.0;            // [m] peak-to-peak excursion per axis; 0: none
  double tremble_frequency = 9.0;  // [Hz] physiological tremor is 8-12 Hz
  // Pulling back and re-cutting (section 5.2): at each of these fractions of the path the blade
  // goes back along it by `pull_back` (a smooth bump on the arc length), then cuts forward again.
  double pull_back = 0.0;  // [m]; 0: none
  std::vector<double> pull_back_at{0.35, 0.7};
  // A second incision across the first (paper section 6): after the first has lifted out, the same
  // plunge, cut and lift along a straight path of this length, turned 90 degrees about the middle of
  // the first path's end points (counter-clockwise seen from above).
  double cross = 0.0;  // [m]; 0: none
  // Each incision starts and ends this far beyond its path's ends, along its first and last
  // segments: the blade comes down outside the tissue and cuts in through its side, so a cut deeper
  // than the tissue runs through it from side to side (volume data, sculpting).
  double extend = 0.0;  // [m]; 0: none
  // Aim at the task's line and depth where the settled tissue has carried them (the task is drawn on
  // the tissue at rest; prestressed skin thins and its surface sinks before the blade arrives), as a
  // surgeon follows the skin. Off: the path and depth as written, below the plane z of the path.
  bool follow_settled_tissue = true;
};

// The samples, at the scenario's haptic rate (device.rate). The skin surface is taken to face +z
// and the task path to lie on it. Positions are rounded to 0.1 um and quaternion components to
// 1e-9, which keeps the log compact; the samples are exactly what the log stores.
// InputError naming `task` when the scenario has none.
[[nodiscard]] std::vector<ToolSample> generate_task_log(const Scenario& scenario,
                                                        const IncisionMotion& motion = {});

// The metadata written with a generated log.
[[nodiscard]] PoseLogMetadata task_log_metadata(const Scenario& scenario, const IncisionMotion& motion = {});

// Writes generate_task_log(scenario, motion) to `out_path` (what `scalpelsim make-log` does).
void write_task_log(const Scenario& scenario, const std::string& out_path, const IncisionMotion& motion = {});

}  // namespace scalpel
