// The task's score (docs/scoring.md): what an instructor reads after a session, and the window's
// live figures. TaskScorer follows the tool sample by sample (where the tip is, how deep below the
// tissue surface it cuts, how the blade is tilted, how the hand moves and what force it feels) and
// scores that, with what the cut left in the tissue, against the scenario's task: components from
// the surgical-skills literature, each with its value, unit, pass threshold and, where points were
// lost, a sentence that says why.
#pragma once

#include <cstddef>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "cutting/cut_engine.hpp"
#include "mesh/mesh.hpp"
#include "sim/scenario.hpp"
#include "sim/surface_probe.hpp"

namespace scalpel {

struct ScoreComponent {
  std::string name;  // "coverage", "deviation", ... (docs/scoring.md)
  std::string unit;  // of value and threshold: "%", "mm", "deg", "count", "ratio", "s", "mm^2"
  double value = 0;
  std::optional<double> threshold;  // none: no pass condition
  bool at_most = false;             // passes when value <= threshold (else value >= threshold)
  bool passed = true;
  double points = 0, points_max = 0;
  std::string why;  // why points were lost or the threshold missed; empty when neither
};

struct IncisionScore {
  std::vector<Vec3> path;              // [m] the target, rest coordinates
  double path_length = 0;              // [m]
  double tolerance = 0;                // [m]
  double coverage = 0;                 // [-] fraction of the path with a cut point within the tolerance
  std::size_t cut_points = 0;          // cut points nearest to this incision
  std::size_t cut_points_outside = 0;  // of those, farther than the tolerance from its path
  double deviation_mean = 0;           // [m] lateral, over its cut points
  double deviation_max = 0;            // [m]
  double frechet = 0;                  // [m] discrete Frechet distance, tip's path against the target
  // Depth in the tissue's own measure (ToolTracePoint::material_depth).
  double depth_max = 0;                          // [m] deepest cut below the tissue surface along it
  double depth_mean = 0;                         // [m] over the cut part of the path
  double depth_in_band = 0;                      // [-] fraction of the path cut within [depth_min, depth_max]
  double depth_min = 0, depth_max_accepted = 0;  // [m] the band
  double bevel_mean_deg = 0, bevel_max_deg = 0;  // blade plane against the surface normal
  int strokes = 0;
  int hesitations = 0;
};

struct TaskScore {
  double score = 0;  // [0, 100], the sum of the components' points
  bool passed = false;
  double pass_score = 0;  // the least score that passes (task.pass.score)
  std::vector<ScoreComponent> components;
  std::vector<IncisionScore> incisions;
  double targets_length = 0;   // [m]
  double time_in_tissue = 0;   // [s] with the tip under the tissue surface
  double path_in_tissue = 0;   // [m] the tip's path while under it
  double force_max = 0;        // [N] on the hand while cutting
  double force_mean = 0;       // [N]
  double cut_area = 0;         // [m^2] of the cut surface, rest configuration
  double collateral_area = 0;  // [m^2] of it farther than the tolerance from every target
  double protected_area = 0;   // [m^2] of it in protected regions
  [[nodiscard]] const ScoreComponent* component(const std::string& name) const;
};

// What the scorer saw at one tool sample, for the time series (docs/formats.md, frames.csv).
struct ToolTracePoint {
  double t = 0;             // [s]
  Vec3 tip = Vec3::Zero();  // [m] world
  bool in_tissue = false;   // the tip under the tissue surface
  double depth = 0;         // [m] below it (0 outside), current configuration
  // [m] of the tip's material point below the surface, both at rest: how far into the tissue's layers
  // the blade has gone, whatever the tissue's stretch and the blade's dimple (what the task scores).
  double material_depth = 0;
  double bevel_deg = 0;             // in the tissue
  int incision = -1;                // nearest target (-1: no task)
  double path_s = 0;                // [m] arc length of the nearest point on it
  double deviation = 0;             // [m] lateral, of the tip's rest position from it
  double speed = 0;                 // [m/s] of the tip
  double force = 0;                 // [N] on the hand
  bool has_material_depth = false;  // the tip was located in the tissue (else material_depth is 0)
  bool cutting = false;             // the tip under the surface and the sweep in the tissue (docs/scoring.md)
};

class TaskScorer {
 public:
  // `protected_ids`: the region ids of task.protected_regions.
  TaskScorer(const Task& task, std::set<int> protected_ids);

  // After the cutter stepped to `pose` for the sample taken at `t` with the hand's `force` [N];
  // `surface`: the surface above the blade's deepest point in the tissue (SurfaceProbe::
  // deepest_in_tissue, then nearest; none: the blade is not in the tissue); `rest_tip` that point
  // in rest coordinates where the cutter locates it, and `material_depth` its depth at rest.
  void on_sample(double t, const BladePose& pose, const CutStepStats& stats,
                 const std::optional<SurfaceHit>& surface, const std::optional<Vec3>& rest_tip,
                 std::optional<double> material_depth, double force);

  [[nodiscard]] TaskScore score(const CutEngine& cutter, const TetMesh& mesh) const;
  [[nodiscard]] const ToolTracePoint& last() const { return last_; }
  // [s] with the tip under the tissue surface so far.
  [[nodiscard]] double time_in_tissue() const { return time_in_tissue_; }
  [[nodiscard]] const Task& task() const { return task_; }

  // A pause of the tip slower than this for at least this long, in the tissue, is a hesitation.
  static constexpr double kHesitationSpeed = 1e-3;  // [m/s]
  static constexpr double kHesitationTime = 0.5;    // [s]
  // The tip out of the tissue for at least this long ends a stroke (a tremor at the surface does not).
  static constexpr double kStrokeGap = 0.05;  // [s]
  // The depth band's ends are inclusive by this much: a cut through the whole thickness, measured
  // to rounding, lies in a band that ends at the thickness.
  static constexpr double kDepthBandSlack = 1e-6;  // [m]

 private:
  struct Station {
    Vec3 p = Vec3::Zero();  // on the path, rest coordinates
    double s = 0;           // arc length
    double depth = -1;      // deepest cut there [m]; < 0: none
  };
  struct Target {
    std::vector<Station> stations;  // every tolerance / 4
    std::vector<Vec3> tip_path;     // the tip's rest positions while cutting, in its strokes
    double length = 0;
    double bevel_sum = 0, bevel_max = 0;
    std::size_t bevel_samples = 0;
    int strokes = 0, hesitations = 0;
  };
  struct Nearest {
    int incision = -1;
    double distance = 0;          // [m] lateral
    double s = 0;                 // [m] along it
    Vec3 tangent = Vec3::Zero();  // its direction there (xy, unit)
  };
  [[nodiscard]] Nearest nearest(const Vec3& p) const;
  void end_stroke();
  // The incision a stroke belongs to: the one most of its cutting samples were nearest; -1: none.
  [[nodiscard]] int stroke_incision() const;
  // Appends a stroke's tip path to a target's, thinned to about tolerance / 8.
  void append_path(std::vector<Vec3>& to, const std::vector<Vec3>& from, double tolerance) const;

  Task task_;
  std::set<int> protected_ids_;
  std::vector<Target> targets_;
  ToolTracePoint last_;
  bool has_last_ = false;
  // The stroke under way: cutting samples per incision, the time the tip left the tissue.
  bool in_stroke_ = false;
  bool stroke_cut_ = false;
  std::vector<std::size_t> stroke_samples_;
  std::vector<Vec3> stroke_path_;  // the stroke's cutting tip positions (rest), thinned
  double left_at_ = 0;
  double slow_since_ = -1;  // start of the current slow run in the tissue; < 0: none
  bool slow_counted_ = false;
  double time_in_tissue_ = 0, path_in_tissue_ = 0;
  double cutting_time_ = 0, force_in_band_time_ = 0, force_sum_ = 0, force_max_ = 0;
  std::size_t cutting_samples_ = 0;
};

}  // namespace scalpel
