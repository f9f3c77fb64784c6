// The task's score (docs/formats.md, `task`): how much of the target path the incision covers within
// the tolerance, how far it strays, and whether its depth is in the accepted range. The report's
// `task` and the window's live score are this one computation.
#pragma once

#include <cstddef>
#include <vector>

#include "mesh/mesh.hpp"
#include "sim/scenario.hpp"

namespace scalpel {

struct TaskScore {
  double path_length = 0;  // [m] in the xy plane
  double tolerance = 0;    // [m]
  double coverage = 0;     // [-] fraction of path stations with a cut point within the tolerance
  std::size_t cut_points = 0;
  std::size_t outside = 0;              // cut points farther than the tolerance from the path
  double mean_deviation = 0;            // [m] lateral, over the cut points
  double max_deviation = 0;             // [m]
  double max_depth = 0;                 // [m] below the surface
  double depth_min = 0, depth_max = 0;  // [m] accepted
  bool depth_ok = false;
  double score = 0;  // [0, 100]
};

// `cuts`: the cut points (CutEngine::cut_points), `surface_z` the top of the uncut tissue [m].
[[nodiscard]] TaskScore score_task(const Task& task, const std::vector<Vec3>& cuts, double surface_z);

}  // namespace scalpel
