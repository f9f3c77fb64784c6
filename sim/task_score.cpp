#include "sim/task_score.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace scalpel {

namespace {

// Distance from p to the polyline in the xy plane [m].
double lateral_distance(const std::vector<Vec3>& path, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector2d a = path[i].head<2>(), b = path[i + 1].head<2>(), q = p.head<2>();
    const Eigen::Vector2d d = b - a;
    const double t = d.squaredNorm() > 0 ? std::clamp((q - a).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
    best = std::min(best, (a + t * d - q).norm());
  }
  return best;
}

}  // namespace

TaskScore score_task(const Task& task, const std::vector<Vec3>& cuts, double surface_z) {
  double length = 0;
  for (size_t i = 0; i + 1 < task.path.size(); ++i)
    length += (task.path[i + 1] - task.path[i]).head<2>().norm();
  // Coverage: path stations every tolerance/4 with a cut point within the tolerance.
  const double step = task.tolerance / 4;
  std::size_t stations = 0, covered = 0;
  for (size_t i = 0; i + 1 < task.path.size(); ++i) {
    const Vec3 a = task.path[i], b = task.path[i + 1];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).head<2>().norm() / step)));
    for (int k = 0; k < n; ++k) {
      const Vec3 p = a + (b - a) * (static_cast<double>(k) / n);
      ++stations;
      for (const Vec3& c : cuts)
        if ((c - p).head<2>().norm() <= task.tolerance) {
          ++covered;
          break;
        }
    }
  }
  double max_dev = 0, sum_dev = 0, max_depth = 0;
  std::size_t outside = 0;
  for (const Vec3& c : cuts) {
    const double d = lateral_distance(task.path, c);
    max_dev = std::max(max_dev, d);
    sum_dev += d;
    outside += d > task.tolerance ? 1 : 0;
    max_depth = std::max(max_depth, surface_z - c.z());
  }
  const double coverage = stations ? static_cast<double>(covered) / static_cast<double>(stations) : 0.0;
  const bool depth_ok = !cuts.empty() && max_depth >= task.depth_min && max_depth <= task.depth_max;
  const double mean_dev = cuts.empty() ? 0.0 : sum_dev / static_cast<double>(cuts.size());
  // 100 for a cut that covers the whole path, stays on it and reaches the right depth.
  const double score =
      100.0 * coverage * std::max(0.0, 1.0 - mean_dev / task.tolerance) * (depth_ok ? 1.0 : 0.5);
  TaskScore t;
  t.path_length = length;
  t.tolerance = task.tolerance;
  t.coverage = coverage;
  t.cut_points = cuts.size();
  t.outside = outside;
  t.mean_deviation = mean_dev;
  t.max_deviation = max_dev;
  t.max_depth = max_depth;
  t.depth_min = task.depth_min;
  t.depth_max = task.depth_max;
  t.depth_ok = depth_ok;
  t.score = score;
  return t;
}

}  // namespace scalpel
