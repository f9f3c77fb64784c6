#include <doctest/doctest.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "devices/device_access.hpp"
#include "devices/device_profile.hpp"

using namespace scalpel;

namespace {

std::string hex(std::uint16_t id) {
  char s[8];
  std::snprintf(s, sizeof s, "%04x", id);
  return s;
}

}  // namespace

TEST_CASE("the udev rule gives access to every device a shipped profile matches") {
  std::ifstream in(std::string(SCALPEL_SOURCE_DIR) + "/config/udev/70-scalpelsim.rules");
  REQUIRE(in);
  std::vector<std::string> rules;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line.front() != '#') rules.push_back(line);
  const auto profiles = load_device_profiles(std::string(SCALPEL_SOURCE_DIR) + "/config/devices");
  REQUIRE_FALSE(profiles.empty());
  for (const DeviceProfile& p : profiles)
    for (const DeviceMatch& m : p.match) {
      CAPTURE(p.name);
      CAPTURE(hex(m.vendor_id) + ":" + hex(m.product_id));
      const std::string node = p.transport == Transport::Hid ? "KERNEL==\"hidraw*\"" : "SUBSYSTEM==\"usb\"";
      bool covered = false;
      for (const std::string& r : rules) {
        const bool vendor = r.find("ATTRS{idVendor}==\"" + hex(m.vendor_id) + "\"") != std::string::npos;
        const bool product = r.find("ATTRS{idProduct}") == std::string::npos ||
                             r.find("ATTRS{idProduct}==\"" + hex(m.product_id) + "\"") != std::string::npos;
        covered |= r.find(node) != std::string::npos && vendor && product &&
                   r.find("TAG+=\"uaccess\"") != std::string::npos;
      }
      CHECK(covered);
    }
}

TEST_CASE("a device is named by its profile, ids and selector, and found through its node") {
  DeviceProfile p;
  p.name = "Stylus";
  p.match = {{0x1209, 0x0001}, {0x256f, 0xc62e}};
  CHECK(wanted_device(p, {}) == "Stylus (USB 1209:0001 or 256f:c62e)");
  CHECK(wanted_device(p, {"A1", "/dev/hidraw3"}) ==
        "Stylus (USB 1209:0001 or 256f:c62e, serial A1, path /dev/hidraw3)");
  FoundDevice hid;
  hid.path = "/dev/hidraw3";
  CHECK(device_node(hid) == "/dev/hidraw3");
  FoundDevice usb;
  usb.transport = Transport::Usb;
  usb.path = "3:17";
  CHECK(device_node(usb) == "/dev/bus/usb/003/017");
  FoundDevice gone;
  gone.path = "/dev/hidraw-scalpelsim-none";
  CHECK(access_problem(gone).find("cannot open /dev/hidraw-scalpelsim-none") == 0);
}
