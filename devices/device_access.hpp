// Finding the device a profile names before a session starts, and saying why it cannot be opened:
// absent, or present but not readable by this user (docs/devices.md: the udev rule).
#pragma once

#include <string>
#include <vector>

#include "devices/device_profile.hpp"
#include "devices/hid_device.hpp"

namespace scalpel {

// "Generic absolute stylus (USB 1209:0001, serial X, path /dev/hidraw3)": what a session waits for.
[[nodiscard]] std::string wanted_device(const DeviceProfile& profile, const DeviceSelector& selector);

// The attached devices the profile and the selector match, in enumeration order.
[[nodiscard]] std::vector<FoundDevice> find_devices(const DeviceProfile& profile,
                                                    const DeviceSelector& selector);

// The device node a found device is opened through: its hidraw path, or /dev/bus/usb/BBB/DDD.
[[nodiscard]] std::string device_node(const FoundDevice& device);

// Empty when this user may read and write the device's node; else what stands in the way and how
// to fix it.
[[nodiscard]] std::string access_problem(const FoundDevice& device);

}  // namespace scalpel
