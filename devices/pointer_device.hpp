// The mouse and keyboard of the window as a tool, in a z-up world (the skin is the xy plane): the
// cursor moves the tool in the horizontal plane (right: +x, down the screen: -y), the scroll wheel
// and two keys raise and lower it, four keys turn it (yaw about world z, pitch about the tool's x
// axis). The window thread publishes its input state; the haptic thread reads
// the newest one through a triple buffer. No force output.
#pragma once

#include <atomic>
#include <cstdint>

#include <Eigen/Geometry>

#include "base/triple_buffer.hpp"
#include "devices/device.hpp"

namespace scalpel {

struct PointerInput {
  double cursor_x = 0.0, cursor_y = 0.0;  // [px] window coordinates, y down
  double scroll = 0.0;                    // [notches] accumulated since the window opened
  std::uint32_t buttons = 0;              // mouse buttons, bit 0 = left (the tool's bit 0)
  std::uint32_t keys = 0;                 // PointerDevice::Key bits held down
  bool focused = false;                   // false: the window lost the pointer, the tool freezes
};

struct PointerMapping {
  double metres_per_pixel = 2e-4;                                   // [m/px]
  double metres_per_notch = 2e-3;                                   // [m] per scroll notch, upwards
  double key_speed = 0.05;                                          // [m/s] raise / lower keys
  double key_turn_rate = 1.0;                                       // [rad/s] turning keys
  Eigen::Vector3d home = Eigen::Vector3d::Zero();                   // [m] pose at the first input
  Eigen::Vector3d workspace_min = Eigen::Vector3d::Constant(-0.5);  // [m]
  Eigen::Vector3d workspace_max = Eigen::Vector3d::Constant(0.5);   // [m]
};

class PointerDevice final : public Device {
 public:
  enum Key : std::uint32_t { Raise = 1, Lower = 2, YawLeft = 4, YawRight = 8, PitchUp = 16, PitchDown = 32 };

  explicit PointerDevice(PointerMapping mapping = {});

  // Window thread only.
  void publish(const PointerInput& input) { input_.publish(input); }
  // Any thread: the tool goes back to its home pose at the next read (the cursor is anchored there).
  void rehome() { rehome_.store(true, std::memory_order_release); }

  DeviceStatus read(double t, ToolSample& out) noexcept override;
  [[nodiscard]] DeviceCounters counters() const override { return counters_.snapshot(); }

 private:
  const PointerMapping m_;
  TripleBuffer<PointerInput> input_;
  std::atomic<bool> rehome_{false};
  AtomicDeviceCounters counters_;
  // Haptic thread only.
  bool anchored_ = false;
  double anchor_x_ = 0, anchor_y_ = 0, anchor_scroll_ = 0;  // input where the tool is at home
  double lift_ = 0.0;                                       // [m] from the raise / lower keys
  double yaw_ = 0.0, pitch_ = 0.0;                          // [rad]
  double last_t_ = 0.0;
  bool has_last_t_ = false;
  ToolSample last_;
};

}  // namespace scalpel
