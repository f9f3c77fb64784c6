#include <doctest/doctest.h>

#include "devices/pointer_device.hpp"

using namespace scalpel;

TEST_CASE("the pointer device moves the tool with the cursor, wheel and keys") {
  PointerMapping m;
  m.metres_per_pixel = 1e-3;
  m.metres_per_notch = 0.01;
  m.key_speed = 0.1;
  PointerDevice d(m);
  ToolSample s;
  CHECK(d.read(0.0, s) == DeviceStatus::Disconnected);  // nothing published: no focus
  d.publish({.cursor_x = 100, .cursor_y = 50, .focused = true});
  REQUIRE(d.read(0.001, s) == DeviceStatus::Ok);
  CHECK(s.position.isZero());
  d.publish({.cursor_x = 120, .cursor_y = 40, .scroll = 2, .buttons = 1, .focused = true});
  REQUIRE(d.read(0.002, s) == DeviceStatus::Ok);
  CHECK(s.position.isApprox(Eigen::Vector3d(0.02, 0.01, 0.02)));
  CHECK(s.buttons == 1);
  d.publish({.cursor_x = 120, .cursor_y = 40, .scroll = 2, .keys = PointerDevice::Raise, .focused = true});
  for (int k = 3; k <= 12; ++k) (void)d.read(k * 1e-3, s);
  CHECK(s.position.z() == doctest::Approx(0.02 + 0.1 * 0.01));

  // Losing focus freezes the tool; on return it resumes where it froze.
  const Eigen::Vector3d frozen = s.position;
  d.publish({.cursor_x = 500, .cursor_y = 500, .focused = false});
  CHECK(d.read(0.013, s) == DeviceStatus::Disconnected);
  CHECK(s.position == frozen);
  d.publish({.cursor_x = 300, .cursor_y = 300, .focused = true});
  REQUIRE(d.read(0.014, s) == DeviceStatus::Ok);
  CHECK(s.position.isApprox(frozen));
}
