#include "devices/device_access.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace scalpel {

namespace {

std::string hex_ids(std::uint16_t vendor, std::uint16_t product) {
  char ids[16];
  std::snprintf(ids, sizeof ids, "%04x:%04x", vendor, product);
  return ids;
}

}  // namespace

std::string wanted_device(const DeviceProfile& profile, const DeviceSelector& selector) {
  std::string ids;
  for (const DeviceMatch& m : profile.match)
    ids += (ids.empty() ? "" : " or ") + hex_ids(m.vendor_id, m.product_id);
  std::string out = profile.name + " (USB " + ids;
  if (!selector.serial.empty()) out += ", serial " + selector.serial;
  if (!selector.path.empty()) out += ", path " + selector.path;
  return out + ")";
}

std::vector<FoundDevice> find_devices(const DeviceProfile& profile, const DeviceSelector& selector) {
  std::vector<FoundDevice> out;
  for (FoundDevice& d : enumerate_devices({profile})) {
    if (d.transport != profile.transport) continue;
    if (!selector.serial.empty() && d.serial != selector.serial) continue;
    if (!selector.path.empty() && d.path != selector.path) continue;
    out.push_back(std::move(d));
  }
  return out;
}

std::string device_node(const FoundDevice& device) {
  if (device.transport == Transport::Hid) return device.path;
  // libusb names a device "bus:address"; its node is /dev/bus/usb/BBB/DDD.
  unsigned bus = 0, address = 0;
  if (std::sscanf(device.path.c_str(), "%u:%u", &bus, &address) != 2) return device.path;
  char node[64];
  std::snprintf(node, sizeof node, "/dev/bus/usb/%03u/%03u", bus, address);
  return node;
}

std::string access_problem(const FoundDevice& device) {
  const std::string node = device_node(device);
  if (node.empty() || node.front() != '/') return {};  // not a device node this check knows
  if (::access(node.c_str(), R_OK | W_OK) == 0) return {};
  const int error = errno;
  std::string out = "cannot open " + node + " for " + hex_ids(device.vendor_id, device.product_id) + ": " +
                    std::strerror(error);
  struct stat st {};
  if (::stat(node.c_str(), &st) == 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    out += std::string(" (mode ") + mode + ", owner uid " + std::to_string(st.st_uid) + ")";
  }
  if (error == EACCES || error == EPERM)
    out +=
        ". Give your user access with the udev rule shipped in config/udev/70-scalpelsim.rules: "
        "sudo cp config/udev/70-scalpelsim.rules /etc/udev/rules.d/ && sudo udevadm control --reload && "
        "sudo udevadm trigger, then plug the device in again (or run as root)";
  return out;
}

}  // namespace scalpel
