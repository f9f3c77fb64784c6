#include "devices/device.hpp"

namespace scalpel {

const char* to_string(DeviceStatus s) {
  switch (s) {
    case DeviceStatus::Ok:
      return "ok";
    case DeviceStatus::Disconnected:
      return "disconnected";
    case DeviceStatus::Fault:
      return "fault";
    case DeviceStatus::Ended:
      return "ended";
  }
  return "unknown";
}

DeviceCounters AtomicDeviceCounters::snapshot() const {
  constexpr auto r = std::memory_order_relaxed;
  return {reports.load(r),        short_reports.load(r), malformed_reports.load(r),
          rejected_poses.load(r), disconnects.load(r),   reconnects.load(r)};
}

}  // namespace scalpel
