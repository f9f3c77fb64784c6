// The device profile reader on the bytes as a profile. A profile it accepts then decodes reports of
// every layout (zeros, ones, a byte ramp, and one too short) and encodes forces up to far beyond
// max_force, as the device does with whatever the hardware sends and the loop asks for.
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "base/input_error.hpp"
#include "devices/device_profile.hpp"

namespace {

void decode_all(const scalpel::DeviceProfile& p) {
  for (const scalpel::ReportLayout& layout : p.input_reports)
    for (int fill = 0; fill < 3; ++fill) {
      std::vector<std::uint8_t> report(layout.length);
      for (std::size_t i = 0; i < report.size(); ++i)
        report[i] = fill == 0 ? 0 : fill == 1 ? 0xff : static_cast<std::uint8_t>(i * 37 + 11);
      if (layout.id) report[0] = *layout.id;
      scalpel::ReportValues v;
      (void)scalpel::parse_report(p, report, v);
      report.pop_back();
      (void)scalpel::parse_report(p, report, v);
    }
  constexpr double kHuge = std::numeric_limits<double>::max();
  const std::array<Eigen::Vector3d, 4> forces = {
      Eigen::Vector3d(0.5, -0.5, 1.0), Eigen::Vector3d::Constant(p.max_force),
      Eigen::Vector3d(kHuge, -kHuge, std::numeric_limits<double>::quiet_NaN()),
      Eigen::Vector3d::Constant(-p.max_force)};
  std::vector<std::uint8_t> out(p.output_report ? p.output_report->length : 1);
  // Joint angles for a linkage profile: at rest, and turned far (the arm's trigonometry).
  const std::array<Eigen::Vector3d, 2> joints = {Eigen::Vector3d::Zero(), Eigen::Vector3d(40.0, -3.0, 1e6)};
  for (const Eigen::Vector3d& q : joints)
    for (const Eigen::Vector3d& f : forces) (void)scalpel::encode_force(p, f, q, out);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const scalpel::DeviceProfile p =
        scalpel::parse_device_profile(std::string(reinterpret_cast<const char*>(data), size), "fuzz.yaml");
    decode_all(p);
  } catch (const scalpel::InputError&) {
    // a malformed profile, reported to the user: expected
  }
  return 0;
}
