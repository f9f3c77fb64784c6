// A device replaying recorded tool samples (a pose log), on the real or the virtual clock: the
// haptic loop gives the time, the device does not sleep.
//
// Interpolate: the pose at log time samples[0].t + t, linear in position and spherical-linear
// (slerp) in orientation, buttons of the earlier sample; a time that falls on a sample gives that
// sample exactly, so a log recorded on the virtual clock at the loop rate replays bit for bit.
// Verbatim: every read gives the next sample unchanged (its own t), whatever the loop time: an exact
// replay of a log with any timing, one sample per haptic cycle.
#pragma once

#include <cstddef>
#include <vector>

#include "devices/device.hpp"

namespace scalpel {

class MockDevice final : public Device {
 public:
  enum class Playback : std::uint8_t { Interpolate, Verbatim };

  // Throws std::invalid_argument when `samples` is empty or its times are not strictly increasing.
  explicit MockDevice(std::vector<ToolSample> samples, Playback playback = Playback::Interpolate);

  DeviceStatus read(double t, ToolSample& out) noexcept override;
  [[nodiscard]] DeviceCounters counters() const override { return counters_.snapshot(); }

  [[nodiscard]] double duration() const { return samples_.back().t - samples_.front().t; }  // [s]
  [[nodiscard]] const std::vector<ToolSample>& samples() const { return samples_; }

 private:
  const std::vector<ToolSample> samples_;
  const Playback playback_;
  std::size_t cursor_ = 0;  // haptic thread: index of the sample at or before the last time read
  ToolSample last_;         // haptic thread: the last good pose given out
  AtomicDeviceCounters counters_;
};

}  // namespace scalpel
