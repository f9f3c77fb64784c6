#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "sim/indentation.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "tests/sim/press_patch.hpp"

using namespace scalpel;

namespace {

// The press patch (press_patch.hpp); the epidermis gives way at `puncture` [N].
Scenario scenario(double puncture, const std::string& blade) {
  return test::press_patch(puncture, "  blade: " + blade);
}

// Tip first, the sharp edge facing +x.
const char* kUpright = "{back: [0, 0, 0.006], tip: [0, 0, 0], edge: [1, 0, 0]}";
// Lying flat on the skin: the blade along x, its edge facing +y, its flat facing down.
const char* kFlat = "{back: [-0.003, 0, 0], tip: [0.003, 0, 0], edge: [0, 1, 0]}";

// Moves the tool from above the patch at (x, y) straight down to `depth` below z = 0 at 20 mm/s,
// holds it for `hold` [s], then lifts it back out; a frame every 16 samples, as the replay does.
struct Press {
  Simulation sim;
  ForceChannel forces;
  ToolSample s;
  double t = 0;
  std::size_t frames = 0;
  explicit Press(const Scenario& sc) : sim(sc) {
    s.position = Vec3(0.0011, 0.0007, 0.004);  // off the grid's lines
    sim.on_sample(s);
    frame();
  }
  void frame() {
    sim.end_frame(t += 1.0 / 60, forces);
    ++frames;
  }
  void sample(const Vec3& p) {
    s.t += 0.001;
    s.position = p;
    sim.on_sample(s);
    if (++samples % 16 == 0) frame();
  }
  void move_to(double z, double seconds) {
    const double z0 = s.position.z();
    const int n = static_cast<int>(seconds * 1000);
    for (int k = 1; k <= n; ++k) sample(Vec3(s.position.x(), s.position.y(), z0 + (z - z0) * k / n));
  }
  std::size_t samples = 0;
};

}  // namespace

TEST_CASE(
    "the blade presses the skin in and cuts only when the force under its tip passes the puncture force") {
  SUBCASE("below the threshold: the skin indents and is not cut") {
    Press p(scenario(50.0, kUpright));
    p.move_to(-0.0015, 0.2);
    p.move_to(-0.0015, 0.2);
    const Indentation& press = *p.sim.indentation();
    CHECK(press.phase() == Indentation::Phase::Pressing);
    CHECK(press.presses() == 1);
    CHECK(press.punctures().empty());
    CHECK(p.sim.cutter().totals().tets_created == 0);
    // The skin went down with the tip: the stuck nodes are where the tip moved them, and the
    // tissue pushes back along the surface's normal.
    CHECK(press.depth() > 0.001);
    CHECK(press.normal_force() > 0.1);
    CHECK(press.normal().z() > 0.99);
    for (const NodeId n : press.stuck()) CHECK(p.sim.mesh().position(n).z() < -0.001);
    // Lifted back out: the press ends without a cut, and the skin comes back.
    p.move_to(0.004, 0.3);
    p.move_to(0.004, 0.5);
    CHECK(press.phase() == Indentation::Phase::Free);
    CHECK(press.lifted() == 1);
    CHECK(press.stuck().empty());
    CHECK(p.sim.cutter().totals().tets_created == 0);
    double top = -1;  // the skin is not lifted with the blade
    for (const NodeId n : p.sim.mesh().nodes()) top = std::max(top, p.sim.mesh().position(n).z());
    CHECK(top < 1e-4);
  }
  SUBCASE("above it: the skin gives way, with the depth and force reported, and the blade cuts") {
    Press p(scenario(0.5, kUpright));
    p.move_to(-0.0015, 0.2);
    p.move_to(-0.0015, 0.1);
    const Indentation& press = *p.sim.indentation();
    REQUIRE(press.punctures().size() == 1);
    const PunctureEvent& e = press.punctures().front();
    CHECK(e.force >= 0.5);
    CHECK(e.threshold == 0.5);
    CHECK(e.region == 0);
    CHECK(e.sharp == doctest::Approx(e.force).epsilon(0.05));  // pressed tip first: nearly all on the tip
    CHECK(e.depth > 0);
    CHECK(e.depth < 0.0015);
    CHECK(e.t > e.touched);
    CHECK(press.phase() == Indentation::Phase::Cutting);
    CHECK(press.stuck().empty());
    CHECK(p.sim.cutter().totals().tets_created > 0);  // a stab: its tip pierces
    // Out again: the next touch would be a new press.
    p.move_to(0.004, 0.3);
    p.move_to(0.004, 0.1);
    CHECK(press.phase() == Indentation::Phase::Free);
  }
}

TEST_CASE("a blade pressed flat first never cuts, however hard") {
  Press p(scenario(0.2, kFlat));
  p.move_to(-0.002, 0.3);
  p.move_to(-0.002, 0.2);
  const Indentation& press = *p.sim.indentation();
  CHECK(press.presses() == 1);
  CHECK(press.max_normal_force() > 1.0);  // five times the puncture force
  CHECK(press.punctures().empty());
  CHECK(p.sim.cutter().totals().tets_created == 0);
}

TEST_CASE("the load on the blade's sharp parts: all of it tip or edge first, none flat or spine first") {
  const Vec3 up(0.1, 0, 2.0);    // [N] the skin pushing the blade back up (a little sideways)
  const Vec3 down(0, 0, -1e-3);  // [m] the blade's push
  const BladePose upright{.back = Vec3(0, 0, 0.01), .tip = Vec3::Zero(), .cutting_direction = Vec3::UnitX()};
  CHECK(sharp_load(upright, up, down) == doctest::Approx(2.0));
  const BladePose edge_down{
      .back = Vec3(-0.01, 0, 0), .tip = Vec3::Zero(), .cutting_direction = -Vec3::UnitZ()};
  CHECK(sharp_load(edge_down, up, down) == doctest::Approx(2.0));
  const BladePose spine_down{
      .back = Vec3(-0.01, 0, 0), .tip = Vec3::Zero(), .cutting_direction = Vec3::UnitZ()};
  CHECK(sharp_load(spine_down, up, down) == 0.0);
  const BladePose flat{.back = Vec3(-0.01, 0, 0), .tip = Vec3::Zero(), .cutting_direction = Vec3::UnitY()};
  CHECK(sharp_load(flat, up, down) == doctest::Approx(0.0).epsilon(1e-12));
  const BladePose leaning{
      .back = Vec3(-0.01, 0, 0.01), .tip = Vec3::Zero(), .cutting_direction = Vec3::UnitY()};
  CHECK(sharp_load(leaning, up, down) == doctest::Approx(2.0 * std::sqrt(0.5)));
  // Drawn edge first (+x) through skin that holds it back: the pull on the edge counts.
  CHECK(sharp_load(upright, Vec3(-1.0, 0, 0.2), Vec3(1e-3, 0, 0)) == doctest::Approx(1.0));
  // Without an edge direction the flats are not known: every push meets a sharp part.
  const BladePose symmetric{.back = Vec3(-0.01, 0, 0), .tip = Vec3::Zero()};
  CHECK(sharp_load(symmetric, up, down) == doctest::Approx(2.0));
  // No push yet: no load.
  CHECK(sharp_load(upright, up, Vec3::Zero()) == 0.0);
}

TEST_CASE(
    "while pressing, the force model is the pressed surface: the solved force at the tool, the measured "
    "stiffness") {
  Press p(scenario(50.0, kUpright));
  p.move_to(-0.001, 0.15);
  p.move_to(-0.001, 0.2);  // settled
  const Indentation& press = *p.sim.indentation();
  REQUIRE(press.phase() == Indentation::Phase::Pressing);
  REQUIRE(p.forces.update());
  const ForceModel m = p.forces.read();
  CHECK(m.contact);
  CHECK(m.contact_normal.isApprox(press.normal()));
  CHECK(m.contact_stiffness == doctest::Approx(press.normal_force() / press.depth()));
  // Rendered where the tool is, without limits, the model gives the solved normal force.
  ForceRenderer r({.max_force = 100, .max_force_rate = 1e9, .passivity_control = false}, 1000.0);
  const Eigen::Vector3d f = r.render(p.s.position, &m, true);
  CHECK(f.dot(press.normal()) == doctest::Approx(press.normal_force()).epsilon(1e-9));
  // Held still, the next frames agree with it: the local model's error is small against the force.
  REQUIRE(!p.sim.press_model_errors().empty());
  CHECK(p.sim.press_model_errors().back() < 0.02 * press.normal_force());
}

TEST_CASE("a frame that comes as the tip touches, before it has pressed in, does not end the press") {
  Press p(scenario(0.5, kUpright));
  const Indentation& press = *p.sim.indentation();
  // Down sample by sample until the tip meets the skin, and a frame at once: no depth yet, and the
  // load of the skin at rest may have either sign.
  while (press.presses() == 0 && p.s.position.z() > -0.001)
    p.sim.on_sample({.t = p.s.t += 0.001, .position = p.s.position += Vec3(0, 0, -2e-5)});
  REQUIRE(press.presses() == 1);
  p.frame();
  CHECK(press.phase() == Indentation::Phase::Pressing);
  CHECK(press.lifted() == 0);
  p.move_to(-0.0015, 0.2);
  CHECK(press.punctures().size() == 1);
  CHECK(p.sim.cutter().totals().tets_created > 0);
}

TEST_CASE("a blade left under the skin cuts as it moves on: it never passes through the tissue") {
  Press p(scenario(8.0, kUpright));
  const Indentation& press = *p.sim.indentation();
  p.move_to(-0.0004, 0.1);
  p.move_to(-0.0004, 0.2);
  REQUIRE(press.phase() == Indentation::Phase::Pressing);
  REQUIRE(press.punctures().empty());
  // Drawn back faster than the skin follows it, and held: the skin lets go of the blade, then
  // springs back up over its tip.
  p.move_to(-0.0002, 0.003);
  p.move_to(-0.0002, 0.5);
  REQUIRE(press.phase() == Indentation::Phase::Free);
  REQUIRE(press.lifted() == 1);
  double top = -1;
  for (const NodeId n : p.sim.mesh().nodes()) top = std::max(top, p.sim.mesh().position(n).z());
  REQUIRE(top > p.s.position.z() + 1e-4);
  CHECK(p.sim.cutter().totals().tets_created == 0);
  // Drawn along under the skin, edge first: it cuts its way.
  for (int k = 1; k <= 300; ++k) p.sample(p.s.position + Vec3(2e-5, 0, 0));
  CHECK(press.phase() == Indentation::Phase::Cutting);
  CHECK(press.unpressed_entries() == 1);
  CHECK(p.sim.cutter().totals().tets_created > 0);
}
