#include <doctest/doctest.h>

#include <limits>
#include <stdexcept>

#include "devices/mock_device.hpp"

using namespace scalpel;

namespace {

ToolSample sample(double t, double x, std::uint32_t buttons = 0) {
  ToolSample s;
  s.t = t;
  s.position = Eigen::Vector3d(x, 0.0, 0.0);
  s.buttons = buttons;
  return s;
}

}  // namespace

TEST_CASE("the mock device interpolates a log at the loop's time") {
  std::vector<ToolSample> log = {sample(1.0, 0.0, 1), sample(1.01, 0.01, 3), sample(1.02, 0.03, 0)};
  log[1].orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()));
  MockDevice d(log);
  CHECK(d.duration() == doctest::Approx(0.02));
  ToolSample s;
  REQUIRE(d.read(0.0, s) == DeviceStatus::Ok);
  CHECK(s.t == 1.0);
  CHECK(s.buttons == 1);
  REQUIRE(d.read(0.005, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(0.005));
  CHECK(s.orientation.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()))) <
        1e-12);
  CHECK(s.buttons == 1);  // of the earlier sample
  REQUIRE(d.read(0.015, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(0.02));
  CHECK(s.buttons == 3);
  CHECK(d.read(0.05, s) == DeviceStatus::Ended);
  CHECK(s.position.x() == 0.03);
  // Going back in time is allowed (a replay restarted).
  REQUIRE(d.read(0.0, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == 0.0);
}

TEST_CASE("the mock device gives samples exactly at their own times") {
  std::vector<ToolSample> log;
  for (int k = 0; k < 50; ++k) log.push_back(sample(k / 1000.0, 0.1 * std::sin(k * 0.37)));
  MockDevice d(log);
  ToolSample s;
  for (int k = 0; k < 50; ++k) {
    REQUIRE(d.read(static_cast<double>(k) / 1000.0, s) == DeviceStatus::Ok);
    CHECK(s.t == log[k].t);
    CHECK(s.position == log[k].position);
  }
}

TEST_CASE("verbatim playback gives every sample unchanged") {
  const std::vector<ToolSample> log = {sample(0.0003, 0.1), sample(0.0017, 0.2), sample(0.0021, 0.3)};
  MockDevice d(log, MockDevice::Playback::Verbatim);
  ToolSample s;
  for (const ToolSample& expected : log) {
    REQUIRE(d.read(123.0, s) == DeviceStatus::Ok);
    CHECK(s.t == expected.t);
    CHECK(s.position == expected.position);
  }
  CHECK(d.read(0.0, s) == DeviceStatus::Ended);
}

TEST_CASE("the mock device rejects NaN poses and bad logs") {
  std::vector<ToolSample> log = {sample(0.0, 0.1), sample(0.001, std::numeric_limits<double>::quiet_NaN()),
                                 sample(0.002, 0.3)};
  MockDevice d(log, MockDevice::Playback::Verbatim);
  ToolSample s;
  (void)d.read(0.0, s);
  CHECK(d.read(0.001, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == 0.1);  // the NaN pose is replaced by the last good one
  CHECK(s.t == 0.001);
  CHECK(d.counters().rejected_poses == 1);
  (void)d.read(0.002, s);
  CHECK(s.position.x() == 0.3);

  CHECK_THROWS_AS(MockDevice({}), std::invalid_argument);
  CHECK_THROWS_AS(MockDevice({sample(0.0, 0.0), sample(0.0, 0.1)}), std::invalid_argument);
}
