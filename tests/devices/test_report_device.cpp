#include <doctest/doctest.h>

#include <cstring>
#include <limits>

#include "devices/report_device.hpp"
#include "tests/devices/fake_transport.hpp"

using namespace scalpel;

namespace {

const std::string kProfiles = std::string(SCALPEL_SOURCE_DIR) + "/config/devices";
const std::string kData = std::string(SCALPEL_TEST_DATA_DIR) + "/hid";

// An absolute device with float fields, for non-finite values.
const char* kFloatStylus = R"(name: float stylus
transport: hid
match: [{vendor_id: 0x1234, product_id: 0x5678}]
motion: absolute
workspace: {min: [-1, -1, -1], max: [1, 1, 1]}
input_reports:
  - id: 1
    length: 14
    fields:
      - {axis: x, offset: 1, type: f32le}
      - {axis: y, offset: 5, type: f32le}
      - {axis: z, offset: 9, type: f32le}
      - {axis: buttons, offset: 13, type: u8}
)";

std::vector<std::uint8_t> float_report(float x, float y, float z, std::uint8_t buttons = 0) {
  std::vector<std::uint8_t> r(14, 0);
  r[0] = 1;
  std::memcpy(r.data() + 1, &x, 4);
  std::memcpy(r.data() + 5, &y, 4);
  std::memcpy(r.data() + 9, &z, 4);
  r[13] = buttons;
  return r;
}

struct Rig {
  std::shared_ptr<test::FakeWire> wire = std::make_shared<test::FakeWire>();
  ReportDevice device;
  explicit Rig(DeviceProfile p) : device(std::move(p), std::make_unique<test::FakeTransport>(wire)) {}
};

}  // namespace

TEST_CASE("a rate device integrates its velocities into a pose") {
  Rig rig(load_device_profile(kProfiles + "/spacemouse_legacy.yaml"));
  const auto r = test::load_reports(kData + "/spacemouse_legacy.txt");
  ToolSample s;
  REQUIRE(rig.device.read(0.0, s) == DeviceStatus::Ok);
  CHECK(s.position.isApprox(Eigen::Vector3d(0, 0.1, 0)));  // home
  rig.wire->inbox.push_back(r.at("translation"));
  for (int k = 1; k <= 100; ++k) REQUIRE(rig.device.read(k * 1e-3, s) == DeviceStatus::Ok);
  // 0.1 s at (0.07, -0.004, -0.02) m/s.
  CHECK(s.position.x() == doctest::Approx(0.007));
  CHECK(s.position.y() == doctest::Approx(0.1 - 0.0004));
  CHECK(s.position.z() == doctest::Approx(-0.002));
  CHECK(s.t == doctest::Approx(0.1));
  rig.wire->inbox.push_back(r.at("rotation"));
  rig.wire->inbox.push_back(r.at("buttons"));
  for (int k = 101; k <= 200; ++k) REQUIRE(rig.device.read(k * 1e-3, s) == DeviceStatus::Ok);
  // 0.1 s at -0.4 rad/s about world x.
  CHECK(s.orientation.angularDistance(
            Eigen::Quaterniond(Eigen::AngleAxisd(-0.04, Eigen::Vector3d::UnitX()))) < 1e-9);
  CHECK(s.buttons == 2);
  CHECK(rig.device.counters().reports == 3);
}

TEST_CASE("a rate device stays in its workspace") {
  Rig rig(load_device_profile(kProfiles + "/spacemouse_legacy.yaml"));
  rig.wire->inbox.push_back(test::load_reports(kData + "/spacemouse_legacy.txt").at("translation"));
  ToolSample s;
  for (int k = 0; k <= 10000; ++k) (void)rig.device.read(k * 1e-3, s);
  CHECK(s.position.x() == doctest::Approx(0.25));
}

TEST_CASE("short and malformed reports are counted and skipped") {
  Rig rig(load_device_profile(kProfiles + "/spacemouse_legacy.yaml"));
  const auto r = test::load_reports(kData + "/spacemouse_legacy.txt");
  rig.wire->inbox.push_back(r.at("short"));
  rig.wire->inbox.push_back(r.at("unknown_id"));
  rig.wire->inbox.push_back(r.at("buttons"));
  ToolSample s;
  CHECK(rig.device.read(0.0, s) == DeviceStatus::Ok);
  CHECK(s.buttons == 2);
  const DeviceCounters c = rig.device.counters();
  CHECK(c.short_reports == 1);
  CHECK(c.malformed_reports == 1);
  CHECK(c.reports == 1);
  CHECK(s.position.isApprox(Eigen::Vector3d(0, 0.1, 0)));
}

TEST_CASE("NaN, non-unit and out-of-workspace poses are rejected") {
  SUBCASE("float stylus with NaN") {
    Rig rig(parse_device_profile(kFloatStylus, "mem.yaml"));
    ToolSample s;
    rig.wire->inbox.push_back(float_report(0.1f, 0.2f, 0.3f, 1));
    REQUIRE(rig.device.read(0.0, s) == DeviceStatus::Ok);
    CHECK(s.position.isApprox(Eigen::Vector3d(0.1, 0.2, 0.3), 1e-6));
    const float nan = std::numeric_limits<float>::quiet_NaN();
    rig.wire->inbox.push_back(float_report(nan, 0.0f, 0.0f, 0));
    rig.wire->inbox.push_back(float_report(0.0f, std::numeric_limits<float>::infinity(), 0.0f, 0));
    REQUIRE(rig.device.read(0.001, s) == DeviceStatus::Ok);
    CHECK(s.position.isApprox(Eigen::Vector3d(0.1, 0.2, 0.3), 1e-6));  // kept
    CHECK(s.buttons == 1);
    CHECK(rig.device.counters().malformed_reports == 2);
    CHECK(is_valid(s));
  }
  SUBCASE("stylus outside its workspace or without an orientation") {
    Rig rig(load_device_profile(kProfiles + "/generic_stylus.yaml"));
    const auto r = test::load_reports(kData + "/generic_stylus.txt");
    ToolSample s;
    rig.wire->inbox.push_back(r.at("pose"));
    REQUIRE(rig.device.read(0.0, s) == DeviceStatus::Ok);
    const ToolSample good = s;
    CHECK(good.position.isApprox(Eigen::Vector3d(0.1, -0.05, 0.00025)));
    CHECK(good.orientation.angularDistance(
              Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()))) < 1e-4);
    rig.wire->inbox.push_back(r.at("outside"));
    REQUIRE(rig.device.read(0.001, s) == DeviceStatus::Ok);
    CHECK(s.position == good.position);
    rig.wire->inbox.push_back(r.at("no_orientation"));
    REQUIRE(rig.device.read(0.002, s) == DeviceStatus::Ok);
    CHECK(s.position == good.position);
    CHECK(s.orientation.coeffs() == good.orientation.coeffs());
    CHECK(rig.device.counters().rejected_poses == 2);
  }
}

TEST_CASE("unplugging freezes the tool and re-plugging resumes it without a jump") {
  Rig rig(parse_device_profile(kFloatStylus, "mem.yaml"));
  ToolSample s;
  rig.wire->inbox.push_back(float_report(0.1f, 0.2f, 0.3f));
  REQUIRE(rig.device.read(0.0, s) == DeviceStatus::Ok);
  const Eigen::Vector3d frozen = s.position;

  rig.wire->plugged = false;
  CHECK(rig.device.read(0.001, s) == DeviceStatus::Disconnected);
  CHECK(s.position == frozen);
  rig.device.maintain();  // still absent
  CHECK(rig.device.read(0.002, s) == DeviceStatus::Disconnected);
  CHECK(s.position == frozen);
  CHECK(rig.device.counters().disconnects == 1);

  // The stylus was moved while unplugged; after the re-plug the tool continues from the frozen pose.
  rig.wire->plugged = true;
  rig.device.maintain();
  CHECK(rig.wire->opens == 2);
  rig.wire->inbox.push_back(float_report(0.5f, 0.5f, 0.5f));
  REQUIRE(rig.device.read(0.003, s) == DeviceStatus::Ok);
  CHECK(s.position.isApprox(frozen, 1e-12));
  rig.wire->inbox.push_back(float_report(0.51f, 0.5f, 0.5f));
  REQUIRE(rig.device.read(0.004, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(frozen.x() + 0.01).epsilon(1e-6));
  CHECK(rig.device.counters().reconnects == 1);
}

TEST_CASE("a rate device resumes integrating from its frozen pose") {
  Rig rig(load_device_profile(kProfiles + "/spacemouse_legacy.yaml"));
  const auto r = test::load_reports(kData + "/spacemouse_legacy.txt");
  ToolSample s;
  rig.wire->inbox.push_back(r.at("translation"));
  for (int k = 0; k <= 10; ++k) (void)rig.device.read(k * 1e-3, s);
  const Eigen::Vector3d frozen = s.position;
  rig.wire->plugged = false;
  for (int k = 11; k <= 500; ++k) CHECK(rig.device.read(k * 1e-3, s) == DeviceStatus::Disconnected);
  CHECK(s.position == frozen);
  rig.wire->plugged = true;
  rig.device.maintain();
  REQUIRE(rig.device.read(0.501, s) == DeviceStatus::Ok);
  CHECK(s.position == frozen);  // the stale rate is forgotten
  rig.wire->inbox.push_back(r.at("translation"));
  REQUIRE(rig.device.read(0.502, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(frozen.x() + 0.07e-3));
}

TEST_CASE("forces go to the output report only while connected") {
  Rig rig(load_device_profile(kProfiles + "/generic_stylus.yaml"));
  CHECK(rig.device.max_force() == 3.3);
  rig.device.write_force(Eigen::Vector3d(1.0, -0.5, 0.25));
  REQUIRE(rig.wire->written.size() == 1);
  CHECK(rig.wire->written[0] == test::load_reports(kData + "/generic_stylus.txt").at("force_out"));
  rig.wire->plugged = false;
  ToolSample s;
  (void)rig.device.read(0.0, s);
  rig.device.write_force(Eigen::Vector3d(1.0, 0, 0));
  CHECK(rig.wire->written.size() == 1);
}

TEST_CASE("a device absent at start connects when it appears") {
  auto wire = std::make_shared<test::FakeWire>();
  wire->plugged = false;
  ReportDevice d(parse_device_profile(kFloatStylus, "mem.yaml"), std::make_unique<test::FakeTransport>(wire));
  ToolSample s;
  CHECK(d.read(0.0, s) == DeviceStatus::Disconnected);
  wire->plugged = true;
  d.maintain();
  wire->inbox.push_back(float_report(0.1f, 0.2f, 0.3f));
  CHECK(d.read(0.001, s) == DeviceStatus::Ok);
  CHECK(s.position.isApprox(Eigen::Vector3d(0.1, 0.2, 0.3), 1e-6));  // no re-indexing on a first connect
}
