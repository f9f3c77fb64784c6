#include <doctest/doctest.h>

#include "devices/hid_device.hpp"

using namespace scalpel;

namespace {

DeviceProfile absent_profile(Transport t) {
  std::string yaml = R"(name: absent
transport: )" + std::string(t == Transport::Hid ? "hid" : "usb") +
                     R"(
match: [{vendor_id: 0xfffe, product_id: 0xfffe}]
motion: absolute
workspace: {min: [-1, -1, -1], max: [1, 1, 1]}
input_reports:
  - length: 12
    fields:
      - {axis: x, offset: 0, type: f32le}
      - {axis: y, offset: 4, type: f32le}
      - {axis: z, offset: 8, type: f32le}
output_report:
  length: 6
  fields: [{axis: fx, offset: 0, type: i16le, scale: 1.0e-3}]
max_force: 2
max_force_rate: 100
)";
  if (t == Transport::Usb)
    yaml += "usb: {interface: 1, in_endpoint: 0x82, out_endpoint: 0x02, transfer: bulk}\n";
  return parse_device_profile(yaml, "absent.yaml");
}

}  // namespace

TEST_CASE("a usb profile describes its endpoints and unnumbered reports") {
  const DeviceProfile p = absent_profile(Transport::Usb);
  CHECK(p.transport == Transport::Usb);
  CHECK_FALSE(p.numbered_reports());
  CHECK(p.usb.interface == 1);
  CHECK(p.usb.in_endpoint == 0x82);
  CHECK(p.usb.out_endpoint == 0x02);
  CHECK(p.usb.bulk);
  CHECK(p.max_input_length() == 12);
}

TEST_CASE("the hidapi and libusb back ends see an absent device as unplugged") {
  for (Transport t : {Transport::Hid, Transport::Usb}) {
    const DeviceProfile p = absent_profile(t);
    std::unique_ptr<ReportDevice> d = open_device(p, {.serial = "none"});
    ToolSample s;
    CHECK(d->read(0.0, s) == DeviceStatus::Disconnected);
    d->maintain();
    CHECK(d->read(0.001, s) == DeviceStatus::Disconnected);
    d->write_force(Eigen::Vector3d(1, 0, 0));  // ignored while unplugged
    CHECK(is_valid(s));
  }
  // Enumeration lists only devices a profile matches: none of these exist.
  for (const FoundDevice& f :
       enumerate_devices({absent_profile(Transport::Hid), absent_profile(Transport::Usb)}))
    CHECK(f.profile >= 0);
}
