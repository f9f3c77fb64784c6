// A device that speaks in raw reports described by a DeviceProfile, over a ReportTransport (hidapi,
// libusb, or a fake one in tests). Rate devices (a SpaceMouse) integrate their velocities into a
// pose; absolute devices (a stylus) report the pose itself; linkage devices (an arm with motors,
// WoodenHaptics) report joint angles, which give the position, and take motor currents for a force.
//
// Unplugging freezes the tool at its last good pose (status Disconnected, the simulation goes on);
// maintain() reopens the device and the tool resumes from where it froze: a rate device continues
// integrating from there, an absolute or linkage device is re-indexed (an offset moves its first pose after
// the re-plug onto the frozen one, as a clutch does), so re-plugging never makes the blade jump. Short and
// malformed reports are counted and skipped; a non-finite, non-unit or out-of-workspace pose is counted and
// rejected (the previous pose is kept; a rate device is clamped to its workspace).
#pragma once

#include <array>
#include <atomic>
#include <memory>

#include <Eigen/Geometry>

#include "devices/device.hpp"
#include "devices/device_profile.hpp"
#include "devices/report_transport.hpp"

namespace scalpel {

class ReportDevice final : public Device {
 public:
  ReportDevice(DeviceProfile profile, std::unique_ptr<ReportTransport> transport);
  ~ReportDevice() override;
  ReportDevice(const ReportDevice&) = delete;
  ReportDevice& operator=(const ReportDevice&) = delete;

  DeviceStatus read(double t, ToolSample& out) noexcept override;
  void write_force(const Eigen::Vector3d& force) noexcept override;
  // Reopens the transport after an unplug (or a failed first open).
  void maintain() override;

  [[nodiscard]] double max_force() const override {
    return profile_.output_report ? profile_.max_force : 0.0;
  }
  [[nodiscard]] double max_force_rate() const override { return profile_.max_force_rate; }
  [[nodiscard]] DeviceCounters counters() const override { return counters_.snapshot(); }
  [[nodiscard]] const DeviceProfile& profile() const { return profile_; }

  // Largest report a device may send [bytes].
  static constexpr std::size_t kMaxReport = 1024;
  // Reports applied per read() at most, so a flood cannot stall the haptic cycle.
  static constexpr int kMaxReportsPerRead = 64;
  // An absolute orientation whose norm is off by more than this is rejected, otherwise normalised.
  static constexpr double kUnitTolerance = 0.05;
  // Longest time step a rate device integrates over [s] (longer gaps are clamped to it).
  static constexpr double kMaxRateStep = 0.01;

 private:
  enum State : int { Connected, Disconnected, Reopened };

  void apply(const ReportValues& v) noexcept;
  void update_pose(double t) noexcept;
  // A linkage device's latest joint angles [rad].
  [[nodiscard]] Eigen::Vector3d joints() const noexcept {
    return {axis_[static_cast<std::size_t>(Axis::JA)], axis_[static_cast<std::size_t>(Axis::JB)],
            axis_[static_cast<std::size_t>(Axis::JC)]};
  }

  const DeviceProfile profile_;
  bool has_orientation_ = false;  // the profile has qw..qz axes
  std::unique_ptr<ReportTransport> transport_;
  // Owner of transport_: the haptic thread while Connected, maintain() otherwise (release/acquire).
  std::atomic<int> state_{Disconnected};
  AtomicDeviceCounters counters_;

  // Haptic thread only.
  std::array<double, kValueAxes> axis_{};  // latest value per Axis X..JC
  std::uint32_t buttons_ = 0;
  Eigen::Vector3d position_;  // [m] the tool pose given out
  Eigen::Quaterniond orientation_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d offset_position_ = Eigen::Vector3d::Zero();  // [m] re-indexing (absolute)
  Eigen::Quaterniond offset_orientation_ = Eigen::Quaterniond::Identity();
  bool has_pose_ = false;    // an absolute pose was accepted
  bool reindex_ = false;     // the next absolute pose re-indexes onto the frozen one
  bool fresh_ = false;       // a report arrived since the last pose update
  bool has_joints_ = false;  // a linkage device's joint angles arrived since the (re)connect
  double last_t_ = 0.0;
  bool has_last_t_ = false;
  std::array<std::uint8_t, kMaxReport> in_{};
  std::array<std::uint8_t, kMaxReport> out_{};
};

}  // namespace scalpel
