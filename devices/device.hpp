// The device interface the haptic loop reads the tool from (docs/threads.md).
//
// Thread ownership: read() and write_force() belong to the haptic thread and never block, allocate or
// throw. maintain() belongs to one other (non-real-time) thread: it does the slow work, such as
// reopening a device after it was unplugged. counters() may be called from any thread.
#pragma once

#include <atomic>
#include <cstdint>

#include <Eigen/Core>

#include "devices/tool_sample.hpp"

namespace scalpel {

enum class DeviceStatus : std::uint8_t {
  Ok,            // the pose is current
  Disconnected,  // unplugged: the pose is frozen at the last good one, no force may be sent
  Fault,         // the device reports an error: the pose is held, no force may be sent
  Ended,         // a replay ran past its last sample: the pose is held at the last one
};

[[nodiscard]] const char* to_string(DeviceStatus s);

// Event counts of one device; a plain snapshot.
struct DeviceCounters {
  std::uint64_t reports = 0;            // input reports parsed and applied
  std::uint64_t short_reports = 0;      // shorter than their layout: skipped
  std::uint64_t malformed_reports = 0;  // unknown report id or a non-finite value: skipped
  std::uint64_t rejected_poses = 0;     // non-finite, non-unit or out-of-workspace pose: previous kept
  std::uint64_t disconnects = 0;
  std::uint64_t reconnects = 0;
};

// The same counts, written by the haptic thread and read by anyone (relaxed: they are statistics).
struct AtomicDeviceCounters {
  std::atomic<std::uint64_t> reports{0}, short_reports{0}, malformed_reports{0}, rejected_poses{0},
      disconnects{0}, reconnects{0};

  static void bump(std::atomic<std::uint64_t>& c) { c.fetch_add(1, std::memory_order_relaxed); }
  [[nodiscard]] DeviceCounters snapshot() const;
};

class Device {
 public:
  virtual ~Device() = default;

  // Haptic thread. Fills `out` with the tool pose at loop time t [s] (t, position, orientation,
  // buttons; force is left to the caller). When the status is not Ok the last good pose is given.
  virtual DeviceStatus read(double t, ToolSample& out) noexcept = 0;

  // Haptic thread. Sends a world-frame force [N] to a device with a force output; others ignore it.
  virtual void write_force(const Eigen::Vector3d& force) noexcept { (void)force; }

  // Maintenance thread (never the haptic thread): slow upkeep such as reopening after an unplug.
  virtual void maintain() {}

  // Largest force the device accepts [N] (0: no force output) and its largest rate of change [N/s].
  [[nodiscard]] virtual double max_force() const { return 0.0; }
  [[nodiscard]] virtual double max_force_rate() const { return 0.0; }

  [[nodiscard]] virtual DeviceCounters counters() const { return {}; }
};

}  // namespace scalpel
