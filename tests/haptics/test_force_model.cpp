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

TEST_CASE("the body's force is the solved one at the frame's tool position and grows by its stiffness") {
  ForceModel m;
  m.sequence = 1;
  m.body_force = 0.5;
  m.body_normal = Eigen::Vector3d::UnitX();
  m.body_stiffness = 1000.0;
  m.body_position = Eigen::Vector3d(0.01, 0, 0);
  CHECK(m.body_force_at(Eigen::Vector3d(0.01, 0.02, 0)).isApprox(Eigen::Vector3d(0.5, 0, 0)));  // sideways
  CHECK(m.body_force_at(Eigen::Vector3d(0.009, 0, 0)).isApprox(Eigen::Vector3d(1.5, 0, 0)));    // pushed in
  CHECK(m.body_force_at(Eigen::Vector3d(0.0104, 0, 0)).isApprox(Eigen::Vector3d(0.1, 0, 0)));
  CHECK(m.body_force_at(Eigen::Vector3d(0.011, 0, 0)).isZero());  // drawn back: it never pulls
  m.body_stiffness = 0.0;
  CHECK(m.body_force_at(Eigen::Vector3d(0.011, 0, 0)).isApprox(Eigen::Vector3d(0.5, 0, 0)));  // held
  m.body_force = 0.0;
  CHECK(m.body_force_at(Eigen::Vector3d(0.009, 0, 0)).isZero());  // none
  // The renderer adds it.
  ForceRenderer r({.max_force = 10.0, .max_force_rate = 1e9}, kRate);
  m.body_force = 0.5;
  m.body_stiffness = 1000.0;
  CHECK(r.render(Eigen::Vector3d(0.009, 0, 0), &m, true).isApprox(Eigen::Vector3d(1.5, 0, 0)));
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

namespace {

// A hand holding the stylus against a stiff wall: the device's mass and the hand's spring to a point
// 5 mm inside the wall, no damping anywhere (the worst case of Colgate and Schenkel's condition),
// integrated between the 1 kHz cycles with 100 substeps and the force held over each cycle. Returns
// the lowest energy the hand had put into the environment at any cycle [J] (negative: the
// environment gave out more than it took in) and the largest force step [N].
struct HeldContact {
  double min_energy_in = 0.0;    // from the sent forces and the exact motion
  double max_force_step = 0.0;   // [N] between cycles
  double max_force = 0.0;        // [N]
  double final_amplitude = 0.0;  // [m] peak-to-peak of y over the last second
  double observed_energy = 0.0;  // the renderer's own E at the end
  double final_energy_in = 0.0;  // [J] at the end
};

HeldContact hold_contact(bool passivity, double seconds) {
  ForceLimits limits{.max_force = 8.0, .max_force_rate = 4000.0, .passivity_control = passivity};
  ForceRenderer r(limits, kRate);
  ForceModel m;
  m.sequence = 1;
  m.contact = true;
  m.contact_normal = Eigen::Vector3d::UnitY();
  m.contact_offset = 0.0;
  m.contact_stiffness = 20000.0;  // [N/m]: passive only with k T / 2 = 10 N s/m of the device's own damping
  const double mass = 0.05, hand = 200.0, set = -0.005;  // [kg], [N/m], [m]
  double y = 0.001, v = 0.0;                             // starts 1 mm above the wall
  HeldContact out;
  double energy_in = 0.0, lo = 1e9, hi = -1e9;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  const int cycles = static_cast<int>(seconds * kRate);
  for (int k = 0; k < cycles; ++k) {
    const Eigen::Vector3d f = r.render(Eigen::Vector3d(0, y, 0), &m, true);
    out.max_force_step = std::max(out.max_force_step, (f - last).norm());
    out.max_force = std::max(out.max_force, f.norm());
    last = f;
    const double y0 = y;
    constexpr int kSub = 100;
    const double h = 1.0 / kRate / kSub;
    for (int s = 0; s < kSub; ++s) {  // semi-implicit Euler: conserves the spring's energy closely
      v += h * (f.y() + hand * (set - y)) / mass;
      y += h * v;
    }
    energy_in -= f.y() * (y - y0);
    out.min_energy_in = std::min(out.min_energy_in, energy_in);
    if (k >= cycles - static_cast<int>(kRate)) {
      lo = std::min(lo, y);
      hi = std::max(hi, y);
    }
  }
  out.final_amplitude = hi - lo;
  out.observed_energy = r.observed_energy();
  out.final_energy_in = energy_in;
  return out;
}

}  // namespace

TEST_CASE("a contact held for 10 s at 1 kHz gains no energy, and the force stays continuous") {
  // Without the passivity controller the sampled wall is a source: the stylus chatters on it and
  // the hand gets back more than it put in. The test of the controller must be able to fail.
  const HeldContact raw = hold_contact(false, 10.0);
  CHECK(raw.final_energy_in < -1.0);
  CHECK(raw.final_amplitude > 1e-4);

  const HeldContact held = hold_contact(true, 10.0);
  MESSAGE("without the controller: " << raw.final_energy_in << " J put in over 10 s, chatter "
                                     << raw.final_amplitude << " m; with it: " << held.final_energy_in
                                     << " J, lowest " << held.min_energy_in << " J, chatter "
                                     << held.final_amplitude << " m");
  // Over the held contact the environment gives back no more than it took: the controller pays
  // back, within the 10 s, what the first impact's sampling gave out (the impact carries 1.1 mJ).
  CHECK(held.final_energy_in > -1e-5);
  CHECK(held.observed_energy > -1e-5);
  CHECK(held.min_energy_in > -5e-3);
  // The stylus comes to rest on the wall: it neither chatters nor is thrown off.
  CHECK(held.final_amplitude < 1e-5);
  // Within the device's limits: no step over max_force_rate / rate, no force over max_force.
  CHECK(held.max_force_step <= 4000.0 / kRate + 1e-12);
  CHECK(held.max_force <= 8.0 + 1e-12);
}
