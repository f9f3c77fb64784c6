#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "base/input_error.hpp"
#include "mesh/validate.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "sim/tool_body.hpp"
#include "tests/sim/press_patch.hpp"

using namespace scalpel;

namespace {

// The blade upright at the origin, its edge facing +x: back 6 mm up, flats in the x-z plane.
BladePose upright() {
  return {Vec3(0, 0, 0.006), Vec3::Zero(), Vec3::UnitX()};
}

// The press patch (press_patch.hpp), giving way at 0.3 N; `tool`: the tool's blade and handle.
Scenario scenario(const std::string& tool) {
  return test::press_patch(0.3, tool);
}

// Drives the tool in straight lines at 1 kHz, a frame every 16 samples as the replay does, and
// calls `check` after every frame.
template <class Check>
struct Drive {
  Simulation sim;
  ForceChannel forces;
  ToolSample s;
  double t = 0;
  std::size_t samples = 0;
  Check check;
  Drive(const Scenario& sc, const Vec3& start, Check c) : sim(sc), check(std::move(c)) {
    s.position = start;
    sim.on_sample(s);
    frame();
  }
  void frame() {
    sim.end_frame(t += 1.0 / 60, forces);
    check(sim);
  }
  void move_to(const Vec3& p, double seconds) {
    const Vec3 p0 = s.position;
    const int n = static_cast<int>(seconds * 1000);
    for (int k = 1; k <= n; ++k) {
      s.t += 0.001;
      s.position = p0 + (p - p0) * (static_cast<double>(k) / n);
      sim.on_sample(s);
      if (++samples % 16 == 0) frame();
    }
  }
};
template <class Check>
Drive(const Scenario&, const Vec3&, Check) -> Drive<Check>;

}  // namespace

TEST_CASE("the tool's body: the blade's frame, the flats' outline and the handle's capsule") {
  const ToolBody body(upright(), {.blade_width = 0.004, .handle_radius = 0.003, .handle_length = 0.05});
  REQUIRE(body.has_flats());
  REQUIRE(body.has_handle());
  // s runs from the back point to the tip, w from the edge to the spine (-x), d across (x-z plane).
  const ToolBody::Local l = body.local(Vec3(-0.001, 0.0005, 0.002));
  CHECK(l.s == doctest::Approx(0.004));
  CHECK(l.w == doctest::Approx(0.001));
  CHECK(std::abs(l.d) == doctest::Approx(0.0005));
  CHECK((body.world(l) - Vec3(-0.001, 0.0005, 0.002)).norm() < 1e-15);
  CHECK(body.over_flats(l));
  CHECK_FALSE(body.over_flats(body.local(Vec3(0.0005, 0, 0.002))));   // ahead of the edge
  CHECK_FALSE(body.over_flats(body.local(Vec3(-0.0045, 0, 0.002))));  // behind the spine
  // The spine meets the edge at the tip: 4 mm behind the edge at the back point, 1 mm at 1.5 mm
  // from the tip.
  CHECK(body.over_flats(body.local(Vec3(-0.0039, 0, 0.0059))));
  CHECK(body.over_flats(body.local(Vec3(-0.00099, 0, 0.0015))));
  CHECK_FALSE(body.over_flats(body.local(Vec3(-0.00101, 0, 0.0015))));
  CHECK_FALSE(body.over_flats(body.local(Vec3(-0.001, 0, -0.0005))));  // beyond the tip
  // The handle: a capsule along the blade's axis above the back point, its rounded end there.
  CHECK_FALSE(body.handle_exit(Vec3(0, 0, 0.0055)));  // on the blade below the back point
  CHECK_FALSE(body.handle_exit(Vec3(0.0031, 0, 0.02)));
  const auto side = body.handle_exit(Vec3(0.001, 0, 0.02));
  REQUIRE(side);
  CHECK((side->point - Vec3(0.003, 0, 0.02)).norm() < 1e-12);
  CHECK((side->normal - Vec3::UnitX()).norm() < 1e-12);
  const auto end = body.handle_exit(Vec3(0, 0.001, 0.0065));  // in the rounded end
  REQUIRE(end);
  CHECK((end->point - Vec3(0, 0, 0.009)).norm() == doctest::Approx(0.003));
  CHECK_FALSE(body.handle_exit(Vec3(0, 0, 0.057)));  // beyond its length
  // Without the edge's direction the spine is not known: no flats.
  const ToolBody bare({Vec3(0, 0, 0.006), Vec3::Zero(), Vec3::Zero()}, {.blade_width = 0.004});
  CHECK_FALSE(bare.has_flats());
  CHECK_FALSE(bare.has_handle());
}

TEST_CASE("a blade moved flat first inside its incision pushes the lip: no node passes through its flats") {
  // The blade cuts in upright and along +x at y = y0, then is moved 1.5 mm towards +y, flat first,
  // across the grid's line y = 2 mm, and held. Each node of the generated mesh belongs to the side
  // of y0 it rests on; over the flats it must still be on that side of the blade, or on them.
  const double y0 = 0.0012;
  const ToolBodySize size{.blade_width = 0.012};
  const auto run = [&](const std::string& tool, bool& crossed, double& push) {
    crossed = false;
    push = 0;
    bool still = false;
    std::size_t generated = 0;  // the mesh's nodes before any cut
    Drive d(scenario(tool), Vec3(-0.0037, y0, 0.004), [&](const Simulation& sim) {
      const ToolBody body(sim.blade(sim.last_sample()), size);
      const TetMesh& m = sim.mesh();
      if (generated == 0) generated = m.node_count();
      for (const NodeId n : m.nodes()) {
        if (n.index >= generated) continue;  // the cutter's, made on the blade's path
        const ToolBody::Local l = body.local(m.position(n));
        if (!body.over_flats(l)) continue;
        const double side = (m.position(n) - sim.blade(sim.last_sample()).back).dot(Vec3::UnitY());
        crossed = crossed || side * (m.rest(n).y() - y0) < -1e-12;
      }
      // Held still against the lip, the lip pushes back at every frame: the most it does at the
      // frame that pushes back least.
      if (still && sim.body_contact() != nullptr) push = std::max(push, sim.body_contact()->force().y());
    });
    d.move_to(Vec3(-0.0037, y0, -0.0025), 0.3);  // presses, punctures, cuts in
    d.move_to(Vec3(0.0043, y0, -0.0025), 0.4);   // the incision
    d.move_to(Vec3(0.0043, y0 + 0.0015, -0.0025), 0.3);
    push = -1e9;
    still = true;
    d.move_to(Vec3(0.0043, y0 + 0.0015, -0.0025), 0.2);
    REQUIRE(d.sim.indentation()->punctures().size() == 1);
  };
  bool crossed = false;
  double push = 0;
  SUBCASE("with flats") {
    run("  blade: {back: [0, 0, 0.006], tip: [0, 0, 0], edge: [1, 0, 0], width: 0.012}", crossed, push);
    CHECK_FALSE(crossed);
    // The lip pushes back against the blade's motion, and the hand feels it.
    CHECK(push < -0.05);
  }
  SUBCASE("without, the tissue passes through where they would be") {
    run("  blade: {back: [0, 0, 0.006], tip: [0, 0, 0], edge: [1, 0, 0]}", crossed, push);
    CHECK(crossed);
  }
}

TEST_CASE("the handle pushes the skin it meets: no node inside it, and the hand feels the skin") {
  // A 4 mm blade driven in upright until its back point is 1.5 mm under the skin: the handle's
  // rounded end meets the surface. Held there, then drawn out.
  const ToolBodySize size{.handle_radius = 0.003, .handle_length = 0.05};
  struct Seen {
    double deepest = 0;                             // [m] a node inside the handle, the deepest
    double held_force_min = 1e9;                    // [N] up, the least while held still
    std::size_t held_min = 1u << 30, held_max = 0;  // nodes the handle holds while held still
    std::size_t fixed_at_start = 0, fixed_at_end = 0, held_at_end = 0;
  };
  const auto run = [&](const std::string& tool) {
    Seen seen;
    bool still = false;
    Drive d(scenario(tool), Vec3(0.0011, 0.0007, 0.006), [&](const Simulation& sim) {
      const ToolBody body(sim.blade(sim.last_sample()), size);
      // Cut nodes whose crack has not opened (one copy) are the cutter's: they ride on the blade,
      // whose back point the handle's end touches.
      std::vector<std::uint8_t> closed(sim.mesh().node_capacity(), 0);
      for (const auto& c : sim.cutter().cut_node_copies())
        if (c.copies.size() == 1) closed[c.copies.front().index] = 1;
      for (const NodeId n : sim.mesh().nodes()) {
        const Vec3& x = sim.mesh().position(n);
        if (closed[n.index]) continue;
        if (const auto exit = body.handle_exit(x))
          seen.deepest = std::max(seen.deepest, (exit->point - x).norm());
      }
      if (still && sim.body_contact() != nullptr) {
        seen.held_force_min = std::min(seen.held_force_min, sim.body_contact()->force().z());
        seen.held_min = std::min(seen.held_min, sim.body_contact()->held_count());
        seen.held_max = std::max(seen.held_max, sim.body_contact()->held_count());
      }
    });
    const auto count = [&](bool held) {
      std::size_t k = 0;
      for (const NodeId n : d.sim.mesh().nodes())
        k += (held ? d.sim.tissue().held(n) : d.sim.tissue().fixed(n)) ? 1 : 0;
      return k;
    };
    seen.fixed_at_start = count(false);
    d.move_to(Vec3(0.0011, 0.0007, -0.0055), 0.6);
    d.move_to(Vec3(0.0011, 0.0007, -0.0055), 0.1);  // settling
    still = true;
    d.move_to(Vec3(0.0011, 0.0007, -0.0055), 0.3);
    still = false;
    REQUIRE(d.sim.indentation()->punctures().size() == 1);
    d.move_to(Vec3(0.0011, 0.0007, 0.006), 0.5);  // drawn out
    d.move_to(Vec3(0.0011, 0.0007, 0.006), 0.2);
    seen.fixed_at_end = count(false);
    seen.held_at_end = count(true);
    return seen;
  };
  SUBCASE("with a handle") {
    const Seen seen =
        run("  blade: {back: [0, 0, 0.004], tip: [0, 0, 0], edge: [1, 0, 0]}\n  handle: {radius: 0.003, "
            "length: 0.05}");
    CHECK(seen.deepest < 1e-6);
    // Held still, the skin pushes the handle up at every frame, with the same nodes.
    CHECK(seen.held_force_min > 0.1);
    CHECK(seen.held_min > 0);
    CHECK(seen.held_max - seen.held_min <= seen.held_max / 10);
    // Drawn out, it holds nothing, and the cutter's new nodes did not inherit its hold.
    CHECK(seen.held_at_end == 0);
    CHECK(seen.fixed_at_end >= seen.fixed_at_start);
    MESSAGE("held " << seen.held_min << "-" << seen.held_max << " nodes, force >= " << seen.held_force_min
                    << " N; fixed nodes " << seen.fixed_at_start << " -> " << seen.fixed_at_end);
  }
  SUBCASE("without, the skin would be inside it") {
    const Seen seen = run("  blade: {back: [0, 0, 0.004], tip: [0, 0, 0], edge: [1, 0, 0]}");
    CHECK(seen.deepest > 5e-4);
  }
}

TEST_CASE("the blade's width and the handle are read from the scenario, with located errors") {
  const Scenario s = scenario(
      "  blade: {back: [0, 0, 0.006], tip: [0, 0, 0], edge: [1, 0, 0], width: 0.005}\n"
      "  handle: {radius: 0.004, length: 0.08}");
  CHECK(s.tool.blade_width == 0.005);
  CHECK(s.tool.handle_radius == 0.004);
  CHECK(s.tool.handle_length == 0.08);
  const auto fails = [](const std::string& tool, const std::string& what) {
    CAPTURE(tool);
    try {
      (void)scenario(tool);
      FAIL("accepted");
    } catch (const InputError& e) {
      CAPTURE(e.what());
      CHECK(std::string(e.what()).find(what) != std::string::npos);
      CHECK(std::string(e.what()).find("patch.yaml:") != std::string::npos);
    }
  };
  fails("  blade: {back: [0, 0, 0.006], tip: [0, 0, 0], width: 0.005}", "needs blade.edge");
  fails("  blade: {back: [0, 0, 0.006], tip: [0, 0, 0], edge: [1, 0, 0], width: -1}", "0 <= value <= 0.05");
  fails("  handle: {radius: 0.004}", "length");
  fails("  handle: {radius: 0.004, length: 0.006}", "2 radius <= value");
  fails("  handle: {radius: 0.004, length: 0.08, colour: red}", "colour");
}

TEST_CASE(
    "random strokes with the body: no node passes through the flats or lies in the handle, and the mesh "
    "stays valid" *
    doctest::test_suite("slow")) {
  // Seeded strokes on the small patch: the blade goes in upright with a random lean, then for a
  // second moves forward, sideways (flat first), turns about its axis and goes deeper, at random.
  // After every frame: the mesh's invariants; no node of the generated mesh that was over the
  // flats and 50 µm or more off their plane at the frame before is on their other side (it
  // passed through them); no node inside the handle but the cutter's on the blade (cut nodes
  // whose crack has not opened).
  const ToolBodySize size{.blade_width = 0.006, .handle_radius = 0.0025, .handle_length = 0.05};
  const Scenario sc = scenario(
      "  blade: {back: [0, 0, 0.004], tip: [0, 0, 0], edge: [1, 0, 0], width: 0.006}\n"
      "  handle: {radius: 0.0025, length: 0.05}");
  std::mt19937_64 rng(0xb0d7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::size_t pushes = 0, checked = 0;
  for (int stroke = 0; stroke < 12; ++stroke) {
    CAPTURE(stroke);
    std::size_t generated = 0;
    std::vector<double> side_before;  // by node slot: off the flats' plane, NaN when not over them
    int passed = 0, inside = 0;
    std::string invalid;
    const double volume = [&] {
      Simulation probe(sc);
      return probe.mesh().total_rest_volume();
    }();
    Drive d(sc, Vec3(0.001 * unit(rng), 0.001 * unit(rng), 0.005), [&](const Simulation& sim) {
      const TetMesh& m = sim.mesh();
      if (generated == 0) generated = m.node_count();
      const BladePose pose = sim.blade(sim.last_sample());
      const ToolBody body(pose, size);
      std::vector<std::uint8_t> closed(m.node_capacity(), 0);
      for (const auto& c : sim.cutter().cut_node_copies())
        if (c.copies.size() == 1) closed[c.copies.front().index] = 1;
      std::vector<double> side(generated, std::numeric_limits<double>::quiet_NaN());
      for (const NodeId n : m.nodes()) {
        const Vec3& x = m.position(n);
        if (!closed[n.index] && body.handle_exit(x) && (body.handle_exit(x)->point - x).norm() > 1e-9)
          ++inside;
        if (n.index >= generated) continue;
        const ToolBody::Local l = body.local(x);
        if (!body.over_flats(l)) continue;
        side[n.index] = l.d;
        const double b = n.index < side_before.size() ? side_before[n.index] : std::nan("");
        if (std::abs(b) >= kSideBand && b * l.d < 0.0) ++passed;
        ++checked;
      }
      side_before = std::move(side);
      if (invalid.empty()) {
        ValidationOptions o;
        o.reference_volume = volume;
        if (const ValidationReport r = validate(m, o); !r.ok()) invalid = r.summary();
      }
    });
    // In upright with a lean, then eight random moves of an eighth of a second.
    const Eigen::Quaterniond lean(Eigen::AngleAxisd(0.35 * unit(rng), Vec3::UnitY()));
    d.s.orientation = lean;
    d.move_to(Vec3(d.s.position.x(), d.s.position.y(), -0.002), 0.4);
    for (int k = 0; k < 8; ++k) {
      const Vec3 step(0.0015 * unit(rng), 0.0015 * unit(rng), 0.0005 * unit(rng));
      Vec3 to = d.s.position + step;
      to.z() = std::clamp(to.z(), -0.0045, -0.0005);
      to.x() = std::clamp(to.x(), -0.006, 0.006);
      to.y() = std::clamp(to.y(), -0.006, 0.006);
      const double turn = 0.15 * unit(rng);  // about the blade's axis
      const Eigen::Quaterniond from_q = d.s.orientation;
      const Eigen::Quaterniond to_q = from_q * Eigen::Quaterniond(Eigen::AngleAxisd(turn, Vec3::UnitZ()));
      const Vec3 p0 = d.s.position;
      for (int j = 1; j <= 125; ++j) {
        const double u = j / 125.0;
        d.s.orientation = from_q.slerp(u, to_q);
        d.s.t += 0.001;
        d.s.position = p0 + u * (to - p0);
        d.sim.on_sample(d.s);
        if (++d.samples % 16 == 0) d.frame();
      }
    }
    d.move_to(Vec3(d.s.position.x(), d.s.position.y(), 0.006), 0.3);
    d.move_to(Vec3(d.s.position.x(), d.s.position.y(), 0.006), 0.1);
    std::size_t still_held = 0;  // drawn out, the body holds nothing
    for (const NodeId n : d.sim.mesh().nodes()) still_held += d.sim.tissue().held(n) ? 1 : 0;
    CHECK(still_held == 0);
    CHECK(passed == 0);
    CHECK(inside == 0);
    CHECK(invalid.empty());
    pushes += d.sim.body_contact()->stats().pushes;
  }
  MESSAGE(checked << " node-frames over the flats checked, " << pushes << " nodes put back on the body");
  CHECK(pushes > 0);
}
