#include <doctest/doctest.h>

#include "haptics/force_model.hpp"

using namespace scalpel;

namespace {

constexpr double kRate = 1000.0;

ForceModel coupling(double k, const Eigen::Vector3d& xc) {
  ForceModel m;
  m.sequence = 1;
  m.coupling_stiffness = k;
  m.constrained_position = xc;
  return m;
}

}  // namespace

TEST_CASE("the virtual coupling pulls the tool towards its constrained position") {
  ForceRenderer r({.max_force = 10.0, .max_force_rate = 1e9}, kRate);
  const ForceModel m = coupling(200.0, Eigen::Vector3d(0.01, 0, 0));
  const Eigen::Vector3d f = r.render(Eigen::Vector3d::Zero(), &m, true);
  CHECK(f.isApprox(Eigen::Vector3d(2.0, 0, 0)));  // 200 N/m * 0.01 m
}

TEST_CASE("coupling damping opposes the tool's velocity relative to the constrained one") {
  ForceRenderer r({.max_force = 10.0, .max_force_rate = 1e9}, kRate);
  ForceModel m;
  m.sequence = 1;
  m.coupling_damping = 5.0;
  Eigen::Vector3d f;
  for (int k = 0; k < 200; ++k) {
    m.constrained_position = Eigen::Vector3d(0.1 * k / kRate, 0, 0);
    f = r.render(Eigen::Vector3d(0.1 * k / kRate, 0, 0), &m, true);  // 0.1 m/s
  }
  CHECK(r.velocity().x() == doctest::Approx(0.1));
  CHECK(f.x() == doctest::Approx(-0.5).epsilon(1e-3));  // b v, the constrained velocity left at 0
}

TEST_CASE("contact pushes out of the tissue plane only when below it") {
  ForceRenderer r({.max_force = 10.0, .max_force_rate = 1e9}, kRate);
  ForceModel m;
  m.sequence = 1;
  m.contact = true;
  m.contact_normal = Eigen::Vector3d::UnitY();
  m.contact_offset = 0.05;
  m.contact_stiffness = 500.0;
  CHECK(r.render(Eigen::Vector3d(0, 0.06, 0), &m, true).isZero());
  r.reset_motion();
  CHECK(r.render(Eigen::Vector3d(0, 0.048, 0), &m, true).isApprox(Eigen::Vector3d(0, 1.0, 0)));
}

TEST_CASE("cutting resistance opposes the blade's motion with its full magnitude") {
  ForceRenderer r({.max_force = 10.0, .max_force_rate = 1e9}, kRate);
  ForceModel m;
  m.sequence = 1;
  m.cutting_resistance = 1.5;
  Eigen::Vector3d f;
  for (int k = 0; k < 200; ++k) f = r.render(Eigen::Vector3d(0, 0, -0.05 * k / kRate), &m, true);
  CHECK(f.isApprox(Eigen::Vector3d(0, 0, 1.5), 1e-6));
  // Still: below the speed floor the resistance fades, it does not chatter.
  ForceRenderer still({.max_force = 10.0, .max_force_rate = 1e9}, kRate);
  CHECK(still.render(Eigen::Vector3d::Zero(), &m, true).isZero());
}

TEST_CASE("forces are clamped, rate-limited, and cut to zero when disabled") {
  ForceRenderer r({.max_force = 3.0, .max_force_rate = 1000.0}, kRate);
  const ForceModel m = coupling(1000.0, Eigen::Vector3d(0, 0, 1.0));  // asks for 1000 N
  Eigen::Vector3d f;
  for (int k = 1; k <= 2; ++k) {
    f = r.render(Eigen::Vector3d::Zero(), &m, true);
    CHECK(f.norm() == doctest::Approx(1.0 * k));  // 1000 N/s * 1 ms per cycle
  }
  for (int k = 0; k < 10; ++k) f = r.render(Eigen::Vector3d::Zero(), &m, true);
  CHECK(f.norm() == doctest::Approx(3.0));
  CHECK(r.render(Eigen::Vector3d::Zero(), &m, false).isZero());  // at once, not ramped
  CHECK(r.render(Eigen::Vector3d::Zero(), &m, true).norm() == doctest::Approx(1.0));
  CHECK(r.render(Eigen::Vector3d::Zero(), nullptr, true).isZero());
  // A device without force output renders nothing.
  ForceRenderer none({.max_force = 0.0, .max_force_rate = 0.0}, kRate);
  CHECK(none.render(Eigen::Vector3d::Zero(), &m, true).isZero());
}
