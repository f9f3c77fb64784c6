#include "devices/pointer_device.hpp"

#include <algorithm>
#include <cmath>

namespace scalpel {

PointerDevice::PointerDevice(PointerMapping mapping) : m_(mapping) {
  last_.position = m_.home;
}

DeviceStatus PointerDevice::read(double t, ToolSample& out) noexcept {
  if (input_.update()) AtomicDeviceCounters::bump(counters_.reports);
  const PointerInput& in = input_.read();
  if (rehome_.exchange(false, std::memory_order_acq_rel)) {
    last_.position = m_.home;
    last_.orientation = Eigen::Quaterniond::Identity();
    lift_ = yaw_ = pitch_ = 0.0;
    anchored_ = false;
  }
  const double dt = has_last_t_ ? std::clamp(t - last_t_, 0.0, 0.01) : 0.0;
  last_t_ = t;
  has_last_t_ = true;
  if (!in.focused) {
    anchored_ = false;
    out = last_;
    out.t = t;
    return DeviceStatus::Disconnected;
  }
  if (!anchored_) {
    // Anchor the cursor where the tool is, so the tool resumes where it froze.
    const Eigen::Vector3d d = last_.position - m_.home;
    anchor_x_ = in.cursor_x - d.x() / m_.metres_per_pixel;
    anchor_y_ = in.cursor_y + d.y() / m_.metres_per_pixel;
    anchor_scroll_ = in.scroll;
    lift_ = d.z();
    anchored_ = true;
  }
  const auto held = [&](Key k) { return (in.keys & k) ? 1.0 : 0.0; };
  lift_ += (held(Raise) - held(Lower)) * m_.key_speed * dt;
  yaw_ += (held(YawLeft) - held(YawRight)) * m_.key_turn_rate * dt;
  pitch_ += (held(PitchUp) - held(PitchDown)) * m_.key_turn_rate * dt;
  // Screen x -> world x, screen y (down) -> world -y, up is world z.
  Eigen::Vector3d p = m_.home + Eigen::Vector3d((in.cursor_x - anchor_x_) * m_.metres_per_pixel,
                                                -(in.cursor_y - anchor_y_) * m_.metres_per_pixel,
                                                lift_ + (in.scroll - anchor_scroll_) * m_.metres_per_notch);
  ToolSample s = last_;
  s.t = t;
  s.buttons = in.buttons;
  if (!p.allFinite()) {
    AtomicDeviceCounters::bump(counters_.rejected_poses);
  } else {
    s.position = p.cwiseMax(m_.workspace_min).cwiseMin(m_.workspace_max);
    s.orientation = Eigen::AngleAxisd(yaw_, Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(pitch_, Eigen::Vector3d::UnitX());
  }
  last_ = s;
  out = s;
  return DeviceStatus::Ok;
}

}  // namespace scalpel
