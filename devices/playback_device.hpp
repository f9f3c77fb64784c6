// A recorded session played back at real speed in the window, with pause, restart and a speed of
// 0.25x to 4x: the pose is the log's (MockDevice, interpolating) at a playback time that advances
// with the loop's clock times the speed, and stands still while paused. Samples carry the loop's
// time, so the simulation sees a device moving in real time. The window thread sets the controls;
// the haptic thread reads them, lock-free.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "devices/device.hpp"
#include "devices/mock_device.hpp"

namespace scalpel {

class PlaybackDevice final : public Device {
 public:
  static constexpr double kMinSpeed = 0.25, kMaxSpeed = 4.0;

  // Throws std::invalid_argument as MockDevice does.
  explicit PlaybackDevice(std::vector<ToolSample> samples);

  // Any thread.
  void set_speed(double speed);  // clamped to [kMinSpeed, kMaxSpeed]
  [[nodiscard]] double speed() const { return speed_.load(std::memory_order_relaxed); }
  void set_paused(bool paused) { paused_.store(paused, std::memory_order_relaxed); }
  [[nodiscard]] bool paused() const { return paused_.load(std::memory_order_relaxed); }
  // Back to the log's start. Returns the request's number; restarts() counts the requests the
  // haptic thread has applied, so a caller can tell when samples from before it stop coming.
  std::uint64_t restart() { return restart_requests_.fetch_add(1, std::memory_order_release) + 1; }
  [[nodiscard]] std::uint64_t restarts() const { return restarts_applied_.load(std::memory_order_acquire); }
  [[nodiscard]] double position() const { return position_.load(std::memory_order_relaxed); }  // [s]
  [[nodiscard]] double duration() const { return log_.duration(); }                            // [s]

  DeviceStatus read(double t, ToolSample& out) noexcept override;
  [[nodiscard]] DeviceCounters counters() const override { return log_.counters(); }

 private:
  MockDevice log_;
  std::atomic<double> speed_{1.0};
  std::atomic<bool> paused_{false};
  std::atomic<std::uint64_t> restart_requests_{0}, restarts_applied_{0};
  std::atomic<double> position_{0.0};
  // Haptic thread only.
  double last_t_ = 0.0;
  bool has_last_t_ = false;
};

}  // namespace scalpel
