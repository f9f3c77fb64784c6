// HID report decoding: a ReportDevice on one of the bundled profiles (config/devices/, in file-name
// order) reads reports, unplugs, re-plugs and writes forces as the bytes say, as the haptic loop
// drives it. Every pose it gives must be finite with a unit orientation.
//
// The bytes: the profile's index, then commands, each a byte whose value modulo 5 says what it is:
//   0  a report: a length byte, then that many bytes (as the device sent them, the id first)
//   1  a haptic cycle, two bytes later (little-endian microseconds)
//   2  a haptic cycle 1 ms later
//   3  unplug, or plug back in; the maintenance thread's call follows
//   4  a force to render: three little-endian int16, in 1/32767 of the profile's max_force
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <span>
#include <vector>

#include "devices/device_profile.hpp"
#include "devices/report_device.hpp"

namespace {

struct Wire {
  std::deque<std::vector<std::uint8_t>> inbox;
  bool plugged = true;
};

class Transport final : public scalpel::ReportTransport {
 public:
  explicit Transport(Wire& wire) : wire_(wire) {}
  bool open() override { return wire_.plugged; }
  void close() override {}
  int read(std::span<std::uint8_t> buf) noexcept override {
    if (!wire_.plugged) return -1;
    if (wire_.inbox.empty()) return 0;
    const std::vector<std::uint8_t>& r = wire_.inbox.front();
    const std::size_t n = std::min(r.size(), buf.size());
    if (n > 0) std::memcpy(buf.data(), r.data(), n);
    wire_.inbox.pop_front();
    return static_cast<int>(n);
  }
  bool write(std::span<const std::uint8_t>) noexcept override { return wire_.plugged; }

 private:
  Wire& wire_;
};

const std::vector<scalpel::DeviceProfile>& profiles() {
  static const std::vector<scalpel::DeviceProfile> p =
      scalpel::load_device_profiles(SCALPEL_SOURCE_DIR "/config/devices");
  return p;
}

// The input from the front; zeros past its end.
struct Bytes {
  std::span<const std::uint8_t> data;
  std::size_t at = 0;
  bool done() const { return at >= data.size(); }
  std::uint8_t byte() { return done() ? 0 : data[at++]; }
  int uint16() {
    const int lo = byte();
    return lo | (byte() << 8);
  }
  int int16() { return static_cast<std::int16_t>(uint16()); }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in{{data, size}};
  const auto& all = profiles();
  const scalpel::DeviceProfile& profile = all[in.byte() % all.size()];
  Wire wire;
  scalpel::ReportDevice device(profile, std::make_unique<Transport>(wire));
  double t = 0.0;
  const auto cycle = [&](double dt) {
    t += dt;
    scalpel::ToolSample s;
    (void)device.read(t, s);
    const double norm = s.orientation.norm();
    if (!s.position.allFinite() || !std::isfinite(norm) || std::abs(norm - 1.0) > 1e-9) {
      std::fprintf(stderr, "hid: a pose that is not finite or not a rotation at t = %g\n", t);
      std::abort();
    }
  };
  while (!in.done()) {
    switch (in.byte() % 5) {
      case 0: {
        std::vector<std::uint8_t> report(in.byte());
        for (auto& b : report) b = in.byte();
        wire.inbox.push_back(std::move(report));
        break;
      }
      case 1:
        cycle(in.uint16() * 1e-6);
        break;
      case 2:
        cycle(1e-3);
        break;
      case 3:
        wire.plugged = !wire.plugged;
        device.maintain();
        break;
      case 4: {
        Eigen::Vector3d f;
        for (int k = 0; k < 3; ++k) f[k] = in.int16() / 32767.0 * profile.max_force;
        device.write_force(f);
        break;
      }
    }
  }
  return 0;
}
