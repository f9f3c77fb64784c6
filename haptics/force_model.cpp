#include "haptics/force_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace scalpel {

ForceRenderer::ForceRenderer(ForceLimits limits, double rate) : limits_(limits), dt_(1.0 / rate) {
  const double tau = 1.0 / (2.0 * std::numbers::pi * kVelocityCutoff);  // [s]
  alpha_ = dt_ / (dt_ + tau);
}

Eigen::Vector3d ForceRenderer::render(const Eigen::Vector3d& x, const ForceModel* model,
                                      bool enabled) noexcept {
  Eigen::Vector3d dx = Eigen::Vector3d::Zero();  // since the last cycle [m]
  if (has_x_) {
    dx = x - x_prev_;
    v_ += alpha_ * (dx / dt_ - v_);
  } else {
    v_.setZero();
  }
  x_prev_ = x;
  has_x_ = true;
  // The last force was held while the tool moved by dx: the work the hand did on the environment.
  energy_ -= f_.dot(dx);

  if (!enabled || model == nullptr || limits_.max_force <= 0.0) {
    f_.setZero();
    return f_;
  }
  Eigen::Vector3d f = model->environment_force(x, v_);
  // The passivity controller: a damper that dissipates the energy the environment has generated,
  // over the next cycle at the velocity of the last one (not the filtered one: its lag would turn
  // the damper into a source in a fast oscillation). Below the speed floor the damper would need an
  // unbounded coefficient, and a damper held over a cycle is itself unstable above about 2 m / T
  // (m the mass at the stylus): its coefficient is capped at kMaxPassivityDamping.
  if (limits_.passivity_control && energy_ < 0.0) {
    const Eigen::Vector3d v = dx / dt_;
    const double v2 = std::max(v.squaredNorm(), kCutSpeedFloor * kCutSpeedFloor);
    f -= std::min(-energy_ / (dt_ * v2), kMaxPassivityDamping) * v;
    ++damped_cycles_;
  }
  if (!f.allFinite()) f.setZero();

  const double n = f.norm();
  if (n > limits_.max_force) f *= limits_.max_force / n;
  // Rate limit: move from the last force towards the target by at most max_force_rate * dt.
  const Eigen::Vector3d step = f - f_;
  const double max_step = limits_.max_force_rate * dt_;
  const double s = step.norm();
  f_ = s > max_step ? Eigen::Vector3d(f_ + step * (max_step / s)) : f;
  return f_;
}

}  // namespace scalpel
