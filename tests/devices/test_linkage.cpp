// A device with an arm (WoodenHaptics on the Polhem controller): joint angles from encoder counts,
// the tip's position from the angles, motor currents from a force, over the fake transport.
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

#include "base/input_error.hpp"
#include "devices/linkage.hpp"
#include "devices/report_device.hpp"
#include "tests/devices/fake_transport.hpp"

using namespace scalpel;

namespace {

const std::string kProfiles = std::string(SCALPEL_SOURCE_DIR) + "/config/devices";
const std::string kData = std::string(SCALPEL_TEST_DATA_DIR) + "/hid";

DeviceProfile woodenhaptics() {
  return load_device_profile(kProfiles + "/woodenhaptics.yaml");
}

// Reads one report through a device on the fake transport; the position it gives.
Eigen::Vector3d position_after(const std::vector<std::uint8_t>& report) {
  auto wire = std::make_shared<test::FakeWire>();
  ReportDevice device(woodenhaptics(), std::make_unique<test::FakeTransport>(wire));
  wire->inbox.push_back(report);
  ToolSample s;
  REQUIRE(device.read(0.001, s) == DeviceStatus::Ok);
  return s.position;
}

}  // namespace

TEST_CASE("linkage: the tip's position follows the arm's geometry") {
  const Linkage l = *woodenhaptics().linkage;
  const double pi = std::numbers::pi;
  // All joints at 0: the arm points up, the forearm hangs down beside it.
  const Eigen::Vector3d zero = l.position(Eigen::Vector3d::Zero());
  CHECK(zero.x() == doctest::Approx(-0.220));
  CHECK(zero.z() == doctest::Approx(0.205 - 0.245));
  // The base's turn moves the tip on a circle about z.
  const Eigen::Vector3d q(pi / 5, 0.4, 1.1);
  const Eigen::Vector3d p = l.position(q) + l.origin;
  const Eigen::Vector3d p0 = l.position(Eigen::Vector3d(0, 0.4, 1.1)) + l.origin;
  CHECK(p.head<2>().norm() == doctest::Approx(p0.x()));
  CHECK(std::atan2(p.y(), p.x()) == doctest::Approx(pi / 5));
  CHECK(p.z() == doctest::Approx(p0.z()));
}

TEST_CASE("linkage: the Jacobian is the derivative of the position, currents do the work of the force") {
  const Linkage l = *woodenhaptics().linkage;
  const Eigen::Vector3d q(0.3, 0.5, 1.2);
  const Eigen::Matrix3d j = l.jacobian(q);
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d dq = Eigen::Vector3d::Unit(k) * h;
    const Eigen::Vector3d numeric = (l.position(q + dq) - l.position(q - dq)) / (2 * h);
    CHECK((numeric - j.col(k)).norm() < 1e-8);
  }
  // Virtual work: the motors' torques over a small joint motion do the work the force does on the
  // tip's displacement. A motor turns dq / ratio for a joint turn dq.
  const Eigen::Vector3d f(0.8, -0.3, 1.5);
  const Eigen::Vector3d amps = l.currents(q, f);
  const Eigen::Vector3d dq(2e-7, -1e-7, 3e-7);
  double motor_work = 0;
  for (int k = 0; k < 3; ++k)
    motor_work += amps[k] * l.torque_constant[static_cast<std::size_t>(k)] * dq[k] /
                  l.ratio[static_cast<std::size_t>(k)];
  const double force_work = f.dot(l.position(q + dq) - l.position(q));
  CHECK(motor_work == doctest::Approx(force_work).epsilon(1e-5));
  // A force the motors cannot give: all three currents scale down together, so the joint torques
  // (and the force) keep their direction.
  const Eigen::Vector3d strong(0, 20, -50);
  const Eigen::Vector3d big = l.currents(q, strong);
  CHECK(big.cwiseAbs().maxCoeff() == doctest::Approx(l.max_current));
  Eigen::Vector3d tau;
  for (int k = 0; k < 3; ++k)
    tau[k] = big[k] * l.torque_constant[static_cast<std::size_t>(k)] / l.ratio[static_cast<std::size_t>(k)];
  const Eigen::Vector3d wanted = l.jacobian(q).transpose() * strong;
  CHECK(tau.normalized().dot(wanted.normalized()) == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(l.currents(q, Eigen::Vector3d(NAN, 0, 0)).isZero());
}

TEST_CASE("linkage: WoodenHaptics reports give the tip's position and take motor currents") {
  const auto r = test::load_reports(kData + "/woodenhaptics.txt");
  const Eigen::Vector3d level = position_after(r.at("forearm_level"));
  CHECK(level.x() == doctest::Approx(0.025));
  CHECK(level.y() == doctest::Approx(0.0));
  CHECK(level.z() == doctest::Approx(0.205));
  const Eigen::Vector3d turned = position_after(r.at("turned"));
  CHECK(turned.x() == doctest::Approx(0.0202924).epsilon(1e-5));
  CHECK(turned.y() == doctest::Approx(-0.0477971).epsilon(1e-5));
  CHECK(turned.z() == doctest::Approx(0.205));
  const Eigen::Vector3d general = position_after(r.at("general"));
  CHECK(general.x() == doctest::Approx(0.0886298).epsilon(1e-5));
  CHECK(general.y() == doctest::Approx(0.0613903).epsilon(1e-5));
  CHECK(general.z() == doctest::Approx(0.0550352).epsilon(1e-5));

  auto wire = std::make_shared<test::FakeWire>();
  ReportDevice device(woodenhaptics(), std::make_unique<test::FakeTransport>(wire));
  CHECK(device.max_force() == 2.5);
  ToolSample s;
  // Before the arm has said where it is, its motors get nothing.
  REQUIRE(device.read(0.0005, s) == DeviceStatus::Ok);
  device.write_force(Eigen::Vector3d(1.0, -0.5, 0.25));
  REQUIRE(wire->written.size() == 1);
  CHECK(wire->written[0] == std::vector<std::uint8_t>(14, 0));
  wire->written.clear();
  wire->inbox.push_back(r.at("general"));
  REQUIRE(device.read(0.001, s) == DeviceStatus::Ok);
  // The force at that pose, as currents.
  device.write_force(Eigen::Vector3d(1.0, -0.5, 0.25));
  REQUIRE(wire->written.size() == 1);
  CHECK(wire->written[0] == r.at("force_out"));
  // Outside the workspace and short reports are rejected; the pose stays. The motors' currents
  // still follow the arm where it is.
  wire->inbox.push_back(r.at("outside"));
  wire->inbox.push_back(r.at("short"));
  REQUIRE(device.read(0.002, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(0.0886298).epsilon(1e-5));
  CHECK(device.counters().rejected_poses == 1);
  device.write_force(Eigen::Vector3d(1.0, -0.5, 0.25));
  REQUIRE(wire->written.size() == 2);
  CHECK(wire->written[1] != r.at("force_out"));
}

TEST_CASE("linkage: profile errors name the key") {
  const std::string arm = R"(name: arm
transport: hid
match: [{vendor_id: 0x1234, product_id: 0x0006}]
motion: linkage
workspace: {min: [-1, -1, -1], max: [1, 1, 1]}
linkage: {lengths: [0.1, 0.2, 0.2], ratio: [0.1, 0.1, 0.1], torque_constant: [0.03, 0.03, 0.03], max_current: 2}
input_reports:
  - length: 6
    fields:
      - {axis: ja, offset: 0, type: i16le, scale: 1.0e-3}
      - {axis: jb, offset: 2, type: i16le, scale: 1.0e-3}
      - {axis: jc, offset: 4, type: i16le, scale: 1.0e-3}
)";
  CHECK(test::profile_error(arm) == "no error");
  std::string no_linkage = arm;
  no_linkage.erase(no_linkage.find("linkage: {"),
                   no_linkage.find("input_reports") - no_linkage.find("linkage: {"));
  CHECK(test::profile_error(no_linkage).find("linkage: missing") != std::string::npos);
  std::string zero_arm = arm;
  zero_arm.replace(zero_arm.find("[0.1, 0.2, 0.2]"), 15, "[0.1, 0.0, 0.2]");
  CHECK(test::profile_error(zero_arm).find("bad.yaml:6:") == 0);
  CHECK(test::profile_error(zero_arm).find("linkage.lengths: arm and forearm must be > 0") !=
        std::string::npos);
  std::string with_x = arm;
  with_x.replace(with_x.find("axis: jc"), 8, "axis: x");
  CHECK(test::profile_error(with_x).find("input_reports: a linkage device reads joint angles") !=
        std::string::npos);
  std::string no_jc = arm;
  no_jc.erase(no_jc.find("      - {axis: jc"));
  CHECK(test::profile_error(no_jc).find("input_reports: a linkage device needs all of ja, jb, jc") !=
        std::string::npos);
  const auto linkage_with = [&](const std::string& from, const std::string& to) {
    std::string t = arm;
    t.replace(t.find(from), from.size(), to);
    return test::profile_error(t);
  };
  CHECK(linkage_with("ratio: [0.1, 0.1, 0.1]", "ratio: [0.1, 0, 0.1]").find("linkage.ratio: must not be 0") !=
        std::string::npos);
  CHECK(linkage_with("ratio: [0.1, 0.1, 0.1]", "ratio: [0.1, -0.1, 0.1]")
            .find("linkage.ratio: the sign of joint b's ratio differs from that of its field's scale") !=
        std::string::npos);
  CHECK(linkage_with("[0.03, 0.03, 0.03]", "[0.03, 0.03, -0.03]")
            .find("linkage.torque_constant: must be > 0") != std::string::npos);
  CHECK(linkage_with("max_current: 2", "max_current: 0").find("linkage.max_current: must be > 0") !=
        std::string::npos);
  std::string force_out = arm + R"(output_report:
  length: 6
  fields: [{axis: fx, offset: 0, type: i16le}, {axis: fy, offset: 2, type: i16le}, {axis: fz, offset: 4, type: i16le}]
max_force: 3
max_force_rate: 100
)";
  CHECK(test::profile_error(force_out).find(
            "output_report.fields: a linkage device takes motor currents ia, ib, ic") != std::string::npos);
  std::string absolute = arm;
  absolute.replace(absolute.find("motion: linkage"), 15, "motion: absolute");
  CHECK(test::profile_error(absolute).find("joint angles ja, jb, jc are for motion: linkage") !=
        std::string::npos);
  std::string two_currents = arm + R"(output_report:
  length: 6
  fields: [{axis: ia, offset: 0, type: i16le}, {axis: ib, offset: 2, type: i16le}]
max_force: 3
max_force_rate: 100
)";
  CHECK(test::profile_error(two_currents)
            .find("output_report.fields: a linkage device needs all of ia, ib, ic") != std::string::npos);
  // An absolute stylus with a linkage section, or with motor currents.
  std::string stylus = absolute;
  for (const char* j : {"ja", "jb", "jc"})
    stylus.replace(stylus.find(std::string("axis: ") + j), 8, "axis: x");
  stylus.replace(stylus.find("axis: x, offset: 2"), 7, "axis: y");
  stylus.replace(stylus.find("axis: x, offset: 4"), 7, "axis: z");
  CHECK(test::profile_error(stylus).find("linkage: only for motion: linkage") != std::string::npos);
  std::string stylus_currents = stylus;
  stylus_currents.erase(stylus_currents.find("linkage: {"),
                        stylus_currents.find("input_reports") - stylus_currents.find("linkage: {"));
  CHECK(test::profile_error(stylus_currents) == "no error");
  stylus_currents += R"(output_report:
  length: 6
  fields: [{axis: ia, offset: 0, type: i16le}, {axis: ib, offset: 2, type: i16le}, {axis: ic, offset: 4, type: i16le}]
max_force: 3
max_force_rate: 100
)";
  CHECK(test::profile_error(stylus_currents)
            .find("output_report.fields: motor currents ia, ib, ic are for motion: linkage") !=
        std::string::npos);
}
