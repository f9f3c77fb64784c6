#include <doctest/doctest.h>

#include "devices/playback_device.hpp"

using namespace scalpel;

namespace {

// A log moving along x at 1 m/s for 1 s, sampled at 10 Hz.
std::vector<ToolSample> line() {
  std::vector<ToolSample> log;
  for (int k = 0; k <= 10; ++k) {
    ToolSample s;
    s.t = 0.1 * k;
    s.position = Eigen::Vector3d(0.1 * k, 0, 0);
    log.push_back(s);
  }
  return log;
}

}  // namespace

TEST_CASE("playback follows the log at its speed, stands still while paused, and restarts") {
  PlaybackDevice d(line());
  ToolSample s;
  REQUIRE(d.read(10.0, s) == DeviceStatus::Ok);  // the loop's clock starts anywhere
  CHECK(s.position.x() == doctest::Approx(0.0));
  CHECK(s.t == 10.0);  // samples carry the loop's time
  REQUIRE(d.read(10.25, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(0.25));

  d.set_speed(2.0);
  REQUIRE(d.read(10.35, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(0.45));
  d.set_speed(100.0);
  CHECK(d.speed() == PlaybackDevice::kMaxSpeed);
  d.set_speed(0.0);
  CHECK(d.speed() == PlaybackDevice::kMinSpeed);
  d.set_speed(1.0);

  d.set_paused(true);
  REQUIRE(d.read(11.0, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(0.45));
  d.set_paused(false);
  REQUIRE(d.read(11.1, s) == DeviceStatus::Ok);
  CHECK(s.position.x() == doctest::Approx(0.55));

  const std::uint64_t request = d.restart();
  CHECK(d.restarts() < request);  // applied by the next read
  REQUIRE(d.read(11.2, s) == DeviceStatus::Ok);
  CHECK(d.restarts() == request);
  CHECK(s.position.x() == doctest::Approx(0.0));

  // Past the log's end the pose stays at its last sample and the device says so.
  CHECK(d.read(13.0, s) == DeviceStatus::Ended);
  CHECK(s.position.x() == doctest::Approx(1.0));
  CHECK(d.position() >= d.duration());
}
