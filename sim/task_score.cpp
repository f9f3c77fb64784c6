#include "sim/task_score.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

namespace scalpel {

namespace {

// The nearest point of a polyline in the xy plane: lateral distance and arc length there [m].
struct PathPoint {
  double distance = std::numeric_limits<double>::infinity();
  double s = 0;
  Vec3 tangent = Vec3::Zero();
};
PathPoint nearest_on(const std::vector<Vec3>& path, const Vec3& p) {
  PathPoint best;
  double s0 = 0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector2d a = path[i].head<2>(), b = path[i + 1].head<2>(), q = p.head<2>();
    const Eigen::Vector2d d = b - a;
    const double len = d.norm();
    const double t = len > 0 ? std::clamp((q - a).dot(d) / (len * len), 0.0, 1.0) : 0.0;
    const double dist = (a + t * d - q).norm();
    if (dist < best.distance)
      best = {dist, s0 + t * len, len > 0 ? Vec3(d.x() / len, d.y() / len, 0.0) : Vec3::Zero()};
    s0 += len;
  }
  return best;
}

// Discrete Frechet distance between two point sequences in the xy plane (Eiter and Mannila 1994).
double frechet(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  if (a.empty() || b.empty()) return std::numeric_limits<double>::infinity();
  std::vector<double> prev(b.size()), row(b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (std::size_t j = 0; j < b.size(); ++j) {
      const double d = (a[i] - b[j]).head<2>().norm();
      double reach;
      if (i == 0 && j == 0)
        reach = d;
      else if (i == 0)
        reach = std::max(row[j - 1], d);
      else if (j == 0)
        reach = std::max(prev[0], d);
      else
        reach = std::max(std::min({prev[j], prev[j - 1], row[j - 1]}), d);
      row[j] = reach;
    }
    std::swap(prev, row);
  }
  return prev.back();
}

std::string format(const char* fmt, double a, double b = 0, double c = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}

// Distance in the xy plane from p to the triangle (a, b, c) seen from above; a vertical triangle
// (a crack face of a vertical cut) is seen as a segment.
double distance_xy(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                   const Eigen::Vector2d& c) {
  const auto cross = [](const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
    return u.x() * v.y() - u.y() * v.x();
  };
  const double d1 = cross(b - a, p - a), d2 = cross(c - b, p - b), d3 = cross(a - c, p - c);
  const bool has_neg = d1 < 0 || d2 < 0 || d3<0, has_pos = d1> 0 || d2 > 0 || d3 > 0;
  if (!(has_neg && has_pos) && std::abs(cross(b - a, c - a)) > 0.0) return 0.0;
  const auto to_segment = [&p](const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
    const Eigen::Vector2d e = v - u;
    const double len2 = e.squaredNorm();
    const double t = len2 > 0.0 ? std::clamp((p - u).dot(e) / len2, 0.0, 1.0) : 0.0;
    return (u + t * e - p).norm();
  };
  return std::min({to_segment(a, b), to_segment(b, c), to_segment(c, a)});
}

double clamp01(double x) {
  return std::clamp(x, 0.0, 1.0);
}

}  // namespace

const ScoreComponent* TaskScore::component(const std::string& name) const {
  for (const ScoreComponent& c : components)
    if (c.name == name) return &c;
  return nullptr;
}

TaskScorer::TaskScorer(const Task& task, std::set<int> protected_ids)
    : task_(task), protected_ids_(std::move(protected_ids)) {
  for (const Incision& in : task_.incisions) {
    Target t;
    const double step = in.tolerance / 4;
    double s = 0;
    for (std::size_t i = 0; i + 1 < in.path.size(); ++i) {
      const Vec3 a = in.path[i], b = in.path[i + 1];
      const double len = (b - a).head<2>().norm();
      const int n = std::max(1, static_cast<int>(std::ceil(len / step)));
      for (int k = 0; k < n; ++k) {
        const double u = static_cast<double>(k) / n;
        t.stations.push_back({a + (b - a) * u, s + u * len, -1.0});
      }
      s += len;
    }
    t.stations.push_back({in.path.back(), s, -1.0});
    t.length = s;
    targets_.push_back(std::move(t));
  }
  stroke_samples_.assign(targets_.size(), 0);
}

TaskScorer::Nearest TaskScorer::nearest(const Vec3& p) const {
  Nearest best;
  double best_rel = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < task_.incisions.size(); ++i) {
    const PathPoint q = nearest_on(task_.incisions[i].path, p);
    const double rel = q.distance / task_.incisions[i].tolerance;
    if (rel < best_rel) {
      best_rel = rel;
      best = {static_cast<int>(i), q.distance, q.s, q.tangent};
    }
  }
  return best;
}

int TaskScorer::stroke_incision() const {
  if (!in_stroke_ || !stroke_cut_) return -1;
  const auto it = std::max_element(stroke_samples_.begin(), stroke_samples_.end());
  if (it == stroke_samples_.end() || *it == 0) return -1;
  return static_cast<int>(it - stroke_samples_.begin());
}

void TaskScorer::append_path(std::vector<Vec3>& to, const std::vector<Vec3>& from, double tolerance) const {
  for (const Vec3& p : from)
    if (to.empty() || (p - to.back()).head<2>().norm() >= tolerance / 8) to.push_back(p);
}

void TaskScorer::end_stroke() {
  if (const int k = stroke_incision(); k >= 0) {
    Target& t = targets_[static_cast<std::size_t>(k)];
    ++t.strokes;
    append_path(t.tip_path, stroke_path_, task_.incisions[static_cast<std::size_t>(k)].tolerance);
  }
  in_stroke_ = false;
  stroke_cut_ = false;
  std::fill(stroke_samples_.begin(), stroke_samples_.end(), 0);
  stroke_path_.clear();
}

void TaskScorer::on_sample(double t, const BladePose& pose, const CutStepStats& stats,
                           const std::optional<SurfaceHit>& surface, const std::optional<Vec3>& rest_tip,
                           std::optional<double> material_depth, double force) {
  ToolTracePoint p;
  p.t = t;
  p.tip = pose.tip;
  p.force = force;
  p.in_tissue = surface && surface->depth > 0.0;
  const double dt = has_last_ ? t - last_.t : 0.0;
  const double moved = has_last_ ? (pose.tip - last_.tip).norm() : 0.0;
  p.speed = dt > 0.0 ? moved / dt : 0.0;
  // Cutting: the tip under the surface and the sweep in the tissue (new cut data or not).
  p.cutting = p.in_tissue && (stats.edges_cut + stats.face_pierces > 0 || stats.tets_touched > 0);
  const Vec3 where = rest_tip.value_or(pose.tip);
  const Nearest near = nearest(where);
  p.incision = near.incision;
  p.path_s = near.s;
  p.deviation = near.incision >= 0 ? near.distance : 0.0;
  if (p.in_tissue) {
    p.depth = surface->depth;
    p.material_depth = material_depth.value_or(0.0);
    p.has_material_depth = material_depth.has_value();
    // The bevel (skiving angle): the blade's plane, spanned by its axis and its sharp edge's
    // direction (else its motion), tilted away from the surface normal. Leaning forward or back
    // along the incision keeps the plane and is not a bevel.
    Vec3 along = pose.cutting_direction;
    if (along.squaredNorm() == 0.0 && has_last_) along = pose.tip - last_.tip;
    const Vec3 plane_normal = (pose.back - pose.tip).cross(along);
    if (plane_normal.squaredNorm() > 0.0)
      p.bevel_deg = std::asin(std::min(1.0, std::abs(plane_normal.normalized().dot(surface->normal)))) *
                    180.0 / std::numbers::pi;
  }

  if (p.in_tissue) {
    if (!in_stroke_) in_stroke_ = true;
    left_at_ = -1;
    time_in_tissue_ += dt;
    path_in_tissue_ += moved;
    // Hesitation: a slow run in the tissue, counted once when it reaches kHesitationTime.
    if (p.speed < kHesitationSpeed) {
      if (slow_since_ < 0) {
        slow_since_ = t;
        slow_counted_ = false;
      }
      if (!slow_counted_ && t - slow_since_ >= kHesitationTime && near.incision >= 0) {
        ++targets_[static_cast<std::size_t>(near.incision)].hesitations;
        slow_counted_ = true;
      }
    } else {
      slow_since_ = -1;
    }
  } else {
    slow_since_ = -1;
    if (in_stroke_) {
      if (left_at_ < 0) left_at_ = t;
      if (t - left_at_ >= kStrokeGap) end_stroke();
    }
  }

  const Vec3 step = has_last_ ? Vec3(pose.tip - last_.tip) : Vec3::Zero();
  // Forward: the way the sharp side faces; a blade without one (no `tool.blade.edge`) along the
  // nearest target.
  const Vec3 forward = pose.cutting_direction.squaredNorm() > 0 ? pose.cutting_direction : near.tangent;
  const bool advancing = step.dot(forward) > 0.0 || step.dot(pose.tip - pose.back) > 0.0;
  if (p.cutting) {
    // Force on the hand against the band, over the time spent.
    ++cutting_samples_;
    cutting_time_ += dt;
    force_sum_ += force;
    force_max_ = std::max(force_max_, force);
    if (force >= task_.pass.force_min && force <= task_.pass.force_max) force_in_band_time_ += dt;
    if (stats.edges_cut + stats.face_pierces > 0) stroke_cut_ = true;
    // The tip's place along the targets only where it was located in the tissue (else `where` is
    // its world position, and no depth was measured).
    if (near.incision >= 0 && p.has_material_depth) {
      const auto k = static_cast<std::size_t>(near.incision);
      Target& target = targets_[k];
      ++stroke_samples_[k];
      target.bevel_sum += p.bevel_deg;
      target.bevel_max = std::max(target.bevel_max, p.bevel_deg);
      ++target.bevel_samples;
      const double tol = task_.incisions[k].tolerance;
      if (stroke_path_.empty() || (where - stroke_path_.back()).head<2>().norm() >= tol / 8)
        stroke_path_.push_back(where);
      // Depth at the stations the tip is over (within the tolerance), in the tissue's own measure,
      // while the tip advances into the tissue: forward (its sharp side leading) or down along the
      // blade. Lifting out or pulling back cuts nothing new, though it may drag the tissue along.
      for (Target& other : targets_)
        for (Station& st : other.stations)
          if (advancing && (st.p - where).head<2>().norm() <= tol)
            st.depth = std::max(st.depth, p.material_depth);
    }
  }
  last_ = p;
  has_last_ = true;
}

TaskScore TaskScorer::score(const CutEngine& cutter, const TetMesh& mesh) const {
  TaskScore out;
  const PassThresholds& pass = task_.pass;
  // A stroke under way counts.
  std::vector<int> strokes;
  std::vector<std::vector<Vec3>> tip_paths;
  for (const Target& t : targets_) {
    strokes.push_back(t.strokes);
    tip_paths.push_back(t.tip_path);
  }
  if (const int k = stroke_incision(); k >= 0) {
    const auto i = static_cast<std::size_t>(k);
    ++strokes[i];
    append_path(tip_paths[i], stroke_path_, task_.incisions[i].tolerance);
  }

  // Cut points (rest) by their nearest target: lateral deviation. Coverage: the cut surface (its
  // crack faces at rest, seen from above) within the tolerance of a station; the cut points alone
  // would leave stations between two of them uncovered on a mesh coarser than the tolerance.
  const std::vector<Vec3> cuts = cutter.cut_points();
  std::vector<std::array<Eigen::Vector2d, 3>> surface;
  for (const auto& f : cutter.cut_surface_faces())
    surface.push_back({mesh.rest(f[0]).head<2>(), mesh.rest(f[1]).head<2>(), mesh.rest(f[2]).head<2>()});
  std::vector<std::vector<Vec3>> near_cuts(targets_.size());
  for (const Vec3& c : cuts) {
    const Nearest n = nearest(c);
    if (n.incision >= 0) near_cuts[static_cast<std::size_t>(n.incision)].push_back(c);
  }
  double stations = 0, covered = 0, in_band = 0, rel_dev_sum = 0, worst_frechet_rel = 0, bevel_sum = 0;
  std::size_t dev_points = 0, bevel_samples = 0;
  int extra_strokes = 0, most_strokes = 0, hesitations = 0;
  for (std::size_t k = 0; k < targets_.size(); ++k) {
    const Incision& in = task_.incisions[k];
    const Target& t = targets_[k];
    IncisionScore s;
    s.path = in.path;
    s.path_length = t.length;
    s.tolerance = in.tolerance;
    s.depth_min = in.depth_min;
    s.depth_max_accepted = in.depth_max;
    std::size_t cov = 0, band = 0, deep = 0;
    double depth_sum = 0;
    for (const Station& st : t.stations) {
      const Eigen::Vector2d p = st.p.head<2>();
      bool hit = false;
      for (const auto& f : surface)
        if (distance_xy(p, f[0], f[1], f[2]) <= in.tolerance) {
          hit = true;
          break;
        }
      cov += hit ? 1 : 0;
      if (st.depth >= 0) {
        ++deep;
        depth_sum += st.depth;
        s.depth_max = std::max(s.depth_max, st.depth);
        band +=
            hit && st.depth >= in.depth_min - kDepthBandSlack && st.depth <= in.depth_max + kDepthBandSlack
                ? 1
                : 0;
      }
    }
    const double n = static_cast<double>(t.stations.size());
    s.coverage = static_cast<double>(cov) / n;
    s.depth_in_band = static_cast<double>(band) / n;
    s.depth_mean = deep ? depth_sum / static_cast<double>(deep) : 0.0;
    for (const Vec3& c : near_cuts[k]) {
      const double d = nearest_on(in.path, c).distance;
      s.deviation_mean += d;
      s.deviation_max = std::max(s.deviation_max, d);
      s.cut_points_outside += d > in.tolerance ? 1 : 0;
      rel_dev_sum += d / in.tolerance;
    }
    s.cut_points = near_cuts[k].size();
    if (s.cut_points) s.deviation_mean /= static_cast<double>(s.cut_points);
    dev_points += s.cut_points;
    std::vector<Vec3> target;
    for (const Station& st : t.stations) target.push_back(st.p);
    s.frechet = tip_paths[k].empty() ? t.length : frechet(tip_paths[k], target);
    worst_frechet_rel = std::max(worst_frechet_rel, s.frechet / in.tolerance);
    s.bevel_mean_deg = t.bevel_samples ? t.bevel_sum / static_cast<double>(t.bevel_samples) : 0.0;
    s.bevel_max_deg = t.bevel_max;
    bevel_sum += t.bevel_sum;
    bevel_samples += t.bevel_samples;
    s.strokes = strokes[k];
    s.hesitations = t.hesitations;
    extra_strokes += std::max(0, s.strokes - 1);
    most_strokes = std::max(most_strokes, s.strokes);
    hesitations += s.hesitations;
    // By length: an incision with a finer tolerance has more stations per millimetre.
    stations += t.length;
    covered += s.coverage * t.length;
    in_band += s.depth_in_band * t.length;
    out.targets_length += t.length;
    out.incisions.push_back(s);
  }

  // The cut surface in rest coordinates: outside every target's band, in protected regions.
  for (const auto& f : cutter.cut_surface_faces()) {
    const Vec3 a = mesh.rest(f[0]), b = mesh.rest(f[1]), c = mesh.rest(f[2]);
    const double area = 0.5 * (b - a).cross(c - a).norm();
    out.cut_area += area;
    const Vec3 centre = (a + b + c) / 3;
    const Nearest n = nearest(centre);
    if (n.incision < 0 || n.distance > task_.incisions[static_cast<std::size_t>(n.incision)].tolerance)
      out.collateral_area += area;
    if (!protected_ids_.empty()) {
      for (const std::uint32_t slot : mesh.node_tets(f[0])) {
        const TetId tet = mesh.tet_handle(slot);
        const auto nodes = mesh.tet_nodes(tet);
        if (std::find(nodes.begin(), nodes.end(), f[1]) == nodes.end() ||
            std::find(nodes.begin(), nodes.end(), f[2]) == nodes.end())
          continue;
        if (protected_ids_.contains(mesh.region(tet))) out.protected_area += area;
        break;
      }
    }
  }
  out.time_in_tissue = time_in_tissue_;
  out.path_in_tissue = path_in_tissue_;
  out.force_max = force_max_;
  out.force_mean = cutting_samples_ ? force_sum_ / static_cast<double>(cutting_samples_) : 0.0;

  // The components (docs/scoring.md).
  const auto add = [&out](ScoreComponent c) { out.components.push_back(std::move(c)); };
  const double coverage = stations > 0 ? covered / stations : 0.0;
  {
    ScoreComponent c{"coverage", "%", 100 * coverage, 100 * pass.coverage, false, true, 0, 25, ""};
    c.points = 25 * coverage;
    c.passed = coverage >= pass.coverage;
    if (coverage < 1.0)
      c.why = format("%.0f %% of the target's length (%.1f mm) was left uncut.", 100 * (1 - coverage),
                     1e3 * (1 - coverage) * out.targets_length);
    add(c);
  }
  {
    const double rel = dev_points ? rel_dev_sum / static_cast<double>(dev_points) : 1.0;
    double mean = 0, tol = 0;
    for (const IncisionScore& s : out.incisions) {
      mean += s.deviation_mean * static_cast<double>(s.cut_points) /
              std::max<double>(1.0, static_cast<double>(dev_points));
      tol = std::max(tol, s.tolerance);
    }
    ScoreComponent c{"deviation", "mm", 1e3 * mean, 1e3 * tol / 2, true, true, 0, 15, ""};
    c.points = 15 * clamp01(1 - rel);
    c.passed = dev_points > 0 && rel <= 0.5;
    if (dev_points == 0)
      c.why = "Nothing was cut.";
    else if (15 - c.points >= 0.005)  // a loss the points show, to two decimals
      c.why = format(
          "The cut lies %.2f mm from the line on average; points fall to zero at the tolerance (%.1f mm).",
          1e3 * mean, 1e3 * tol);
    add(c);
  }
  {
    double worst = 0, tol = 0;
    for (const IncisionScore& s : out.incisions)
      if (s.frechet / s.tolerance >= worst) {
        worst = s.frechet / s.tolerance;
        tol = s.tolerance;
      }
    ScoreComponent c{"shape", "mm", 1e3 * worst * tol, 1e3 * tol, true, true, 0, 5, ""};
    // Full points within half the tolerance, none at the tolerance.
    c.points = 5 * clamp01(2 - 2 * worst_frechet_rel);
    c.passed = worst_frechet_rel <= 1.0;
    if (worst_frechet_rel > 0.5)
      c.why = format(
          "Followed end to end, the tip's path strays up to %.2f mm from the line (Frechet distance): "
          "a detour, a missing end or a pull-back.",
          1e3 * worst * tol);
    add(c);
  }
  {
    const double f = stations > 0 ? in_band / stations : 0.0;
    double lo = 0, hi = 0, deepest = 0;
    for (const IncisionScore& s : out.incisions) {
      lo = s.depth_min;
      hi = s.depth_max_accepted;
      deepest = std::max(deepest, s.depth_max);
    }
    ScoreComponent c{"depth", "%", 100 * f, 100 * pass.depth_in_band, false, true, 0, 20, ""};
    c.points = 20 * f;
    c.passed = f >= pass.depth_in_band;
    if (f < 1.0)
      c.why = format("%.0f %% of the target's length was not cut within %.1f-%.1f mm of the surface",
                     100 * (1 - f), 1e3 * lo, 1e3 * hi) +
              format(" (deepest %.2f mm).", 1e3 * deepest);
    add(c);
  }
  {
    const double mean = bevel_samples ? bevel_sum / static_cast<double>(bevel_samples) : 0.0;
    ScoreComponent c{"bevel", "deg", mean, pass.bevel_deg, true, true, 0, 10, ""};
    // Linear to none at twice the threshold.
    c.points = 10 * clamp01(1 - mean / (2 * pass.bevel_deg));
    c.passed = mean <= pass.bevel_deg;
    if (mean > pass.bevel_deg / 2)
      c.why = format(
          "The blade was tilted %.1f deg sideways from the surface normal on average: a bevelled "
          "(skived) wound edge.",
          mean);
    else if (mean >= 0.05)
      c.why = format("The blade leaned %.1f deg sideways on average; points fall to zero at %.0f deg.", mean,
                     2 * pass.bevel_deg);
    add(c);
  }
  {
    ScoreComponent c{"strokes",
                     "count",
                     static_cast<double>(most_strokes),
                     static_cast<double>(pass.strokes),
                     true,
                     true,
                     0,
                     7,
                     ""};
    c.points = 7 * std::max(0.0, 1 - 0.5 * extra_strokes);
    c.passed = most_strokes >= 1 && most_strokes <= pass.strokes;
    if (most_strokes == 0)
      c.why = "The blade never cut the tissue.";
    else if (extra_strokes > 0)
      c.why =
          format(extra_strokes == 1 ? "%.0f re-entry: the blade left an incision and came back to it; it "
                                      "leaves a ragged wound edge."
                                    : "%.0f re-entries: the blade left an incision and came back to it; each "
                                      "leaves a ragged wound edge.",
                 extra_strokes);
    add(c);
  }
  {
    ScoreComponent c{
        "hesitations", "count", static_cast<double>(hesitations), std::nullopt, true, true, 0, 3, ""};
    c.points = 3 * std::max(0.0, 1 - hesitations / 3.0);
    if (hesitations > 0)
      c.why = format("The blade stood still in the tissue %.0f time(s) for %.1f s or longer.", hesitations,
                     kHesitationTime);
    add(c);
  }
  {
    const double r = out.targets_length > 0 ? path_in_tissue_ / out.targets_length : 0.0;
    ScoreComponent c{"economy", "ratio", r, pass.economy, true, true, 0, 5, ""};
    // Full points up to halfway between 1 and the threshold, none at twice its excess.
    const double full = 0.5 * (1 + pass.economy), zero = 2 * pass.economy - 1;
    c.points = 5 * (zero > full ? clamp01((zero - r) / (zero - full)) : (r <= full ? 1.0 : 0.0));
    c.passed = r <= pass.economy;
    if (r > full) c.why = format("The tip travelled %.1f times the target's length in the tissue.", r);
    add(c);
  }
  {
    ScoreComponent c{"time", "s", time_in_tissue_, pass.time, true, true, 0, 0, ""};
    c.passed = !pass.time || time_in_tissue_ <= *pass.time;
    if (!c.passed)
      c.why =
          format("The blade was in the tissue %.1f s, over the %.1f s allowed.", time_in_tissue_, *pass.time);
    add(c);
  }
  {
    const double f = cutting_time_ > 0 ? force_in_band_time_ / cutting_time_ : 0.0;
    ScoreComponent c{"force", "%", 100 * f, 100 * pass.force_in_band, false, true, 0, 5, ""};
    c.points = 5 * f;
    c.passed = cutting_time_ > 0 && f >= pass.force_in_band;
    if (cutting_time_ > 0 && f < 1.0)
      c.why = format("The force on the hand was outside %.1f-%.1f N for %.0f %% of the cutting time",
                     pass.force_min, pass.force_max, 100 * (1 - f)) +
              format(" (up to %.2f N).", force_max_);
    add(c);
  }
  {
    const double f = out.cut_area > 0 ? out.collateral_area / out.cut_area : 0.0;
    ScoreComponent c{"collateral", "%", 100 * f, 100 * pass.collateral, true, true, 0, 5, ""};
    // Linear to none at twice the threshold; with none allowed, all or nothing.
    const double share = pass.collateral > 0 ? clamp01(1 - f / (2 * pass.collateral)) : (f == 0 ? 1.0 : 0.0);
    c.points = out.protected_area > 0 ? 0.0 : 5 * share;
    c.passed = f <= pass.collateral;
    if (f > 0)
      c.why = format("%.1f %% of the cut surface (%.1f mm²) lies outside the tolerance band of every target.",
                     100 * f, 1e6 * out.collateral_area);
    if (out.protected_area > 0)
      c.why +=
          std::string(c.why.empty() ? "" : " ") + "No points: the blade cut into tissue the task protects.";
    add(c);
  }
  if (!task_.protected_regions.empty()) {
    ScoreComponent c{"protected", "mm^2", 1e6 * out.protected_area, 0.0, true, true, 0, 0, ""};
    c.passed = out.protected_area == 0.0;
    if (!c.passed)
      c.why = format("The blade cut %.2f mm² into tissue the task protects; collateral loses all its points.",
                     1e6 * out.protected_area);
    add(c);
  }
  // A session that never cut earns nothing for how it did not cut.
  if (cutting_samples_ == 0)
    for (ScoreComponent& c : out.components)
      if (c.points > 0) {
        c.points = 0;
        c.why = "Nothing was cut.";
      }
  bool all = true;
  for (const ScoreComponent& c : out.components) {
    out.score += c.points;
    all = all && c.passed;
  }
  out.pass_score = pass.score;
  out.passed = all && out.score >= pass.score;
  return out;
}

}  // namespace scalpel
