#include "sim/log_generator.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

#include "base/input_error.hpp"
#include "haptics/force_model.hpp"
#include "sim/simulation.hpp"

namespace scalpel {

namespace {

// Minimum-jerk position profile on u in [0, 1] (Flash and Hogan 1985).
double min_jerk(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * u * (10.0 + u * (-15.0 + 6.0 * u));
}

double smoothstep(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * (3.0 - 2.0 * u);
}

// Angle difference wrapped to (-pi, pi].
double wrap(double a) {
  while (a > std::numbers::pi) a -= 2 * std::numbers::pi;
  while (a <= -std::numbers::pi) a += 2 * std::numbers::pi;
  return a;
}

// x rounded to a multiple of 1 / scale; dividing the integer by the exact power of ten gives the
// double nearest the decimal, which prints short.
double round_to(double x, double scale) {
  const double r = std::round(x * scale) / scale;
  return r == 0.0 ? 0.0 : r;  // no "-0" in the log
}

// The target path parametrised by arc length, with the heading (direction in the xy plane)
// turning smoothly over +-radius around each corner.
class Path {
 public:
  Path(const std::vector<Vec3>& points, double corner_radius) : p_(points) {
    s_.push_back(0.0);
    for (std::size_t i = 1; i < p_.size(); ++i) {
      const Vec3 d = p_[i] - p_[i - 1];
      s_.push_back(s_.back() + d.norm());
      heading_.push_back(std::atan2(d.y(), d.x()));
    }
    for (std::size_t v = 0; v < p_.size(); ++v) {
      double r = 0.0;
      if (v > 0 && v + 1 < p_.size())
        r = std::min({corner_radius, 0.25 * (s_[v] - s_[v - 1]), 0.25 * (s_[v + 1] - s_[v])});
      radius_.push_back(r);
    }
  }

  [[nodiscard]] double length() const { return s_.back(); }

  [[nodiscard]] Vec3 point(double s) const {
    const std::size_t j = segment(s);
    const double u = (s - s_[j]) / (s_[j + 1] - s_[j]);
    return p_[j] + std::clamp(u, 0.0, 1.0) * (p_[j + 1] - p_[j]);
  }

  // [rad] in the xy plane.
  [[nodiscard]] double heading(double s) const {
    const std::size_t j = segment(s);
    for (const std::size_t v : {j, j + 1}) {
      const double r = radius_[v];
      if (r > 0.0 && std::abs(s - s_[v]) < r)
        return heading_[v - 1] + wrap(heading_[v] - heading_[v - 1]) * smoothstep((s - s_[v] + r) / (2 * r));
    }
    return heading_[j];
  }

 private:
  [[nodiscard]] std::size_t segment(double s) const {
    const auto it = std::upper_bound(s_.begin(), s_.end(), s);
    const std::size_t j = it == s_.begin() ? 0 : static_cast<std::size_t>(it - s_.begin()) - 1;
    return std::min(j, s_.size() - 2);
  }

  std::vector<Vec3> p_;
  std::vector<double> s_;        // arc length at each point
  std::vector<double> heading_;  // per segment
  std::vector<double> radius_;   // blend radius per point
};

// Where the tissue has carried the points the blade aims at. The task is drawn on the tissue at rest,
// but prestressed tissue settles before the blade arrives (stretched skin thins, the surface sinks):
// the hand follows the line and depth where they lie then. The tissue is stepped, without the
// tool, up to `settle` [s]; the aim point at arc length s is the material point `depth` below the
// path, and the offset its displacement, sampled every kOffsetSpacing and interpolated.
class SettledOffsets {
 public:
  static constexpr double kOffsetSpacing = 0.5e-3;  // [m]

  SettledOffsets(const Simulation& sim, const Path& path, double depth) {
    const TetMesh& mesh = sim.mesh();
    const int n = std::max(1, static_cast<int>(std::ceil(path.length() / kOffsetSpacing)));
    for (int k = 0; k <= n; ++k) {
      const Vec3 aim = path.point(path.length() * k / n) - depth * Vec3::UnitZ();
      offsets_.push_back(displacement(mesh, aim));
    }
    step_ = path.length() / n;
  }
  [[nodiscard]] Vec3 at(double s) const {
    const double u = std::clamp(s / step_, 0.0, static_cast<double>(offsets_.size() - 1));
    const auto i = std::min(static_cast<std::size_t>(u), offsets_.size() - 2);
    const double f = u - static_cast<double>(i);
    return (1 - f) * offsets_[i] + f * offsets_[i + 1];
  }

 private:
  // The displacement of the material point at rest position p (zero outside the tissue).
  static Vec3 displacement(const TetMesh& mesh, const Vec3& p) {
    for (const TetId t : mesh.tets()) {
      const auto v = mesh.tet_nodes(t);
      const std::array<Vec3, 4> x{mesh.rest(v[0]), mesh.rest(v[1]), mesh.rest(v[2]), mesh.rest(v[3])};
      const double whole = signed_volume(x[0], x[1], x[2], x[3]);
      if (!(whole > 0.0)) continue;
      const std::array<double, 4> w{
          signed_volume(p, x[1], x[2], x[3]) / whole, signed_volume(x[0], p, x[2], x[3]) / whole,
          signed_volume(x[0], x[1], p, x[3]) / whole, signed_volume(x[0], x[1], x[2], p) / whole};
      if (std::any_of(w.begin(), w.end(), [](double wi) { return wi < -1e-9; })) continue;
      Vec3 d = Vec3::Zero();
      for (int i = 0; i < 4; ++i) d += w[i] * (mesh.position(v[i]) - x[i]);
      return d;
    }
    return Vec3::Zero();
  }

  std::vector<Vec3> offsets_;
  double step_ = 1.0;
};

double cut_depth(const Incision& incision, const IncisionMotion& m) {
  return m.depth >= 0.0 ? m.depth : 0.5 * (incision.depth_min + incision.depth_max);
}

const Task& task_of(const Scenario& s) {
  if (!s.task) throw InputError(s.file.string(), 0, 0, "task", "the scenario has no task to perform");
  return *s.task;
}

// One incision along `path`, starting at time `t0` [s] and sample index `k0`: appends its samples
// to `out`; returns the index of the next sample.
long long append_incision(const Scenario& scenario, const Path& path, double depth,
                          const SettledOffsets* settled, const IncisionMotion& m, double t0, long long k0,
                          std::vector<ToolSample>& out) {
  const Vec3 up = Vec3::UnitZ();
  const Vec3 blade_axis = (scenario.tool.blade_back - scenario.tool.blade_tip).normalized();  // tool frame

  // Phase boundaries [s] from t0: hold, plunge, cut, lift, hold.
  const double t_plunge = m.hold;
  const double d_plunge = (m.approach_height + depth) / m.plunge_speed;
  const double t_cut = t_plunge + d_plunge;
  const double d_cut = path.length() / m.cut_speed;
  const double t_lift = t_cut + d_cut;
  const double t_hold = t_lift + d_plunge;
  const double t_end = t_hold + m.hold;

  const double rate = scenario.device.rate;
  const auto last = static_cast<long long>(std::ceil((t0 + t_end) * rate));
  out.reserve(static_cast<std::size_t>(last) + 1);
  for (long long k = k0; k <= last; ++k) {
    const double t = static_cast<double>(k) / rate - t0;
    double s = 0.0;       // arc length along the path
    double height = 0.0;  // tip height above the path [m]
    if (t < t_cut) {
      height = m.approach_height - (m.approach_height + depth) * min_jerk((t - t_plunge) / d_plunge);
    } else if (t < t_lift) {
      const double u = (t - t_cut) / d_cut;
      s = path.length() * min_jerk(u);
      // Pull-backs: a sin^2 bump of height pull_back over a tenth of the cut, steep enough that the
      // blade runs backwards for a while, then forward over the same path again.
      for (const double at : m.pull_back_at) {
        const double w = (u - at) / 0.1;
        if (m.pull_back > 0.0 && std::abs(w) < 0.5)
          s -= m.pull_back * std::pow(std::cos(std::numbers::pi * w), 2);
      }
      s = std::clamp(s, 0.0, path.length());
      height = -depth;
    } else {
      s = path.length();
      height = -depth + (m.approach_height + depth) * min_jerk((t - t_lift) / d_plunge);
    }
    const double theta = path.heading(s);
    // The blade leans back: its back point is above and behind the tip (docs/state_machine.md). Set up
    // for a heading along +x, then turned about the vertical to the heading, so the tool's own x
    // axis (where a scenario puts the blade's sharp side) faces forward on any path.
    const Vec3 axis_world = std::cos(m.tilt) * up - std::sin(m.tilt) * Vec3::UnitX();
    Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(blade_axis, axis_world).normalized();
    q = Eigen::Quaterniond(Eigen::AngleAxisd(theta, up)) * q;
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    q = Eigen::Quaterniond(round_to(q.w(), 1e9), round_to(q.x(), 1e9), round_to(q.y(), 1e9),
                           round_to(q.z(), 1e9));
    Vec3 tip = path.point(s) + height * up;
    if (settled) tip += settled->at(s);
    if (m.tremble > 0.0 && t > t_plunge && t < t_hold) {
      // Fades in and out over the plunge and the lift, so the tool rests at both ends.
      const double fade =
          std::min(min_jerk((t - t_plunge) / d_plunge), 1.0 - min_jerk((t - t_lift) / d_plunge));
      const double w = 2 * std::numbers::pi * m.tremble_frequency * t;
      tip += 0.5 * m.tremble * fade *
             Vec3(std::sin(w + 0.3), std::sin(1.13 * w + 1.9), std::sin(0.87 * w + 4.1));
    }
    const Vec3 origin = tip - q * scenario.tool.blade_tip;

    ToolSample sample;
    sample.t = static_cast<double>(k) / rate;
    sample.position = Vec3(round_to(origin.x(), 1e7), round_to(origin.y(), 1e7), round_to(origin.z(), 1e7));
    sample.orientation = q;
    out.push_back(sample);
  }
  return last + 1;
}

}  // namespace

std::vector<ToolSample> generate_task_log(const Scenario& scenario, const IncisionMotion& m) {
  const Task& task = task_of(scenario);
  std::vector<ToolSample> out;
  // With follow_settled_tissue, the tissue as the blade meets it: the simulation takes the samples
  // made so far, frame by frame, up to the end of the next incision's plunge.
  std::unique_ptr<Simulation> sim;
  if (m.follow_settled_tissue) sim = std::make_unique<Simulation>(scenario);
  ForceChannel forces;
  std::size_t fed = 0;
  long long frame = 0;
  const double frame_time = 1.0 / scenario.simulation.visual_rate;
  const auto offsets = [&](const Path& path, double depth, double t0) -> std::unique_ptr<SettledOffsets> {
    if (!sim) return nullptr;
    const double until = t0 + m.hold + (m.approach_height + depth) / m.plunge_speed;
    while (static_cast<double>(frame + 1) * frame_time <= until + 1e-12) {
      const double end = static_cast<double>(++frame) * frame_time;
      for (; fed < out.size() && out[fed].t < end; ++fed) sim->on_sample(out[fed]);
      sim->end_frame(end, forces);
    }
    return std::make_unique<SettledOffsets>(*sim, path, depth);
  };
  const auto append = [&](const Path& path, double depth) {
    const long long next = out.empty() ? 0 : std::llround(out.back().t * scenario.device.rate) + 1;
    const double t0 = static_cast<double>(next) / scenario.device.rate;
    append_incision(scenario, path, depth, offsets(path, depth, t0).get(), m, t0, next, out);
  };
  // The incisions in the task's order, each after the one before has lifted out.
  for (const Incision& incision : task.incisions) {
    std::vector<Vec3> points = incision.path;
    if (m.extend > 0.0 && points.size() >= 2) {
      points.front() += m.extend * (points[0] - points[1]).normalized();
      points.back() += m.extend * (points[points.size() - 1] - points[points.size() - 2]).normalized();
    }
    append(Path(points, m.corner_radius), cut_depth(incision, m));
  }
  if (m.cross > 0.0) {
    const Incision& first = task.incisions.front();
    const Vec3 a = first.path.front(), b = first.path.back();
    const Vec3 middle = 0.5 * (a + b);
    Vec3 across(-(b - a).y(), (b - a).x(), 0.0);
    across = across.squaredNorm() > 0 ? Vec3(across.normalized()) : Vec3::UnitY();
    append(Path({middle - 0.5 * m.cross * across, middle + 0.5 * m.cross * across}, m.corner_radius),
           cut_depth(first, m));
  }
  return out;
}

PoseLogMetadata task_log_metadata(const Scenario& scenario, const IncisionMotion& m) {
  const Task& task = task_of(scenario);
  std::ostringstream motion;
  motion << "tilt " << m.tilt * 180.0 / std::numbers::pi << " deg, depth "
         << cut_depth(task.incisions.front(), m) << " m, mean cut speed " << m.cut_speed << " m/s";
  if (task.incisions.size() > 1) motion << ", " << task.incisions.size() << " incisions";
  if (m.tremble > 0.0) motion << ", tremble " << m.tremble << " m at " << m.tremble_frequency << " Hz";
  if (m.pull_back > 0.0) motion << ", pull-back " << m.pull_back << " m";
  if (m.cross > 0.0) motion << ", then a " << m.cross << " m incision across the middle";
  if (m.extend > 0.0)
    motion << ", from " << m.extend << " m before each path to " << m.extend << " m beyond it";
  std::ostringstream rate;
  rate << scenario.device.rate << " Hz";
  return {{"generator", "scalpelsim make-log"},
          {"scenario", scenario.name},
          {"device", "mock"},
          {"rate", rate.str()},
          {"motion", motion.str()},
          {"units", "t [s], x y z [m], quaternion tool->world (w, x, y, z)"}};
}

void write_task_log(const Scenario& scenario, const std::string& out_path, const IncisionMotion& motion) {
  const auto samples = generate_task_log(scenario, motion);
  PoseLogWriter writer(out_path, task_log_metadata(scenario, motion));
  for (const auto& s : samples) writer.write(s);
  writer.flush();
}

}  // namespace scalpel
