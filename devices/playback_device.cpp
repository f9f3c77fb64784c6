#include "devices/playback_device.hpp"

#include <algorithm>
#include <utility>

namespace scalpel {

PlaybackDevice::PlaybackDevice(std::vector<ToolSample> samples) : log_(std::move(samples)) {}

void PlaybackDevice::set_speed(double speed) {
  speed_.store(std::clamp(speed, kMinSpeed, kMaxSpeed), std::memory_order_relaxed);
}

DeviceStatus PlaybackDevice::read(double t, ToolSample& out) noexcept {
  double position = position_.load(std::memory_order_relaxed);
  const std::uint64_t requested = restart_requests_.load(std::memory_order_acquire);
  if (requested != restarts_applied_.load(std::memory_order_relaxed)) {
    position = 0.0;
    restarts_applied_.store(requested, std::memory_order_release);
  } else if (has_last_t_ && !paused()) {
    position += std::max(0.0, t - last_t_) * speed();
  }
  last_t_ = t;
  has_last_t_ = true;
  position_.store(position, std::memory_order_relaxed);
  const DeviceStatus status = log_.read(position, out);
  out.t = t;
  return status;
}

}  // namespace scalpel
