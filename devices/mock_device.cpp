#include "devices/mock_device.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace scalpel {

MockDevice::MockDevice(std::vector<ToolSample> samples, Playback playback)
    : samples_(std::move(samples)), playback_(playback) {
  if (samples_.empty()) throw std::invalid_argument("MockDevice: no samples");
  for (std::size_t i = 1; i < samples_.size(); ++i)
    if (!(samples_[i].t > samples_[i - 1].t))
      throw std::invalid_argument("MockDevice: sample " + std::to_string(i) + " does not follow in time");
  last_ = samples_.front();
  last_.force.setZero();
}

DeviceStatus MockDevice::read(double t, ToolSample& out) noexcept {
  ToolSample s;
  DeviceStatus status = DeviceStatus::Ok;
  if (playback_ == Playback::Verbatim) {
    if (cursor_ >= samples_.size()) {
      s = samples_.back();
      status = DeviceStatus::Ended;
    } else {
      s = samples_[cursor_++];
    }
  } else {
    const double log_t = samples_.front().t + t;
    if (cursor_ >= samples_.size() || samples_[cursor_].t > log_t) cursor_ = 0;  // time went back
    while (cursor_ + 1 < samples_.size() && samples_[cursor_ + 1].t <= log_t) ++cursor_;
    const ToolSample& a = samples_[cursor_];
    if (log_t <= a.t || cursor_ + 1 == samples_.size()) {
      s = a;
      if (cursor_ + 1 == samples_.size() && log_t > a.t) status = DeviceStatus::Ended;
    } else {
      const ToolSample& b = samples_[cursor_ + 1];
      const double alpha = (log_t - a.t) / (b.t - a.t);
      s = a;
      s.position = a.position + alpha * (b.position - a.position);
      s.orientation = a.orientation.slerp(alpha, b.orientation);
    }
    s.t = std::max(log_t, samples_.front().t);
  }
  s.force.setZero();
  if (is_valid(s)) {
    last_ = s;
    AtomicDeviceCounters::bump(counters_.reports);
  } else {
    AtomicDeviceCounters::bump(counters_.rejected_poses);
    const double keep_t = s.t;
    s = last_;
    s.t = keep_t;
  }
  out = s;
  return status;
}

}  // namespace scalpel
