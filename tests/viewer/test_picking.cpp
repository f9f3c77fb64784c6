// Picking and moving pieces of rigid tissue in the window (viewer/picking.hpp): the cursor's ray,
// the piece under it, a point inside that piece the simulation finds it by, and the preview.
#include <doctest/doctest.h>

#include <cmath>

#include "sim/log_generator.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "viewer/picking.hpp"

using namespace scalpel;

namespace {

// A rigid box cut through its whole depth along y = 1.3 mm: two pieces.
Simulation& halves() {
  static Simulation* sim = [] {
    const Scenario scenario = parse_scenario(
        "name: halves\n"
        "mesh: {generator: box, min: [-0.012, -0.01, -0.008], max: [0.012, 0.01, 0.0], cells: [12, 10, 4]}\n"
        "tissue: {model: rigid}\n"
        "tool: {contact: none, blade: {back: [0, 0, 0.030], tip: [0, 0, 0]}}\n"
        "task:\n"
        "  path: [[-0.012, 0.0013, 0.0], [0.012, 0.0013, 0.0]]\n"
        "  tolerance: 0.001\n"
        "  depth: [0.007, 0.008]\n"
        "  scored: false\n",
        "halves.yaml", ".");
    IncisionMotion motion;
    motion.extend = 0.004;
    motion.depth = 0.010;
    auto* s = new Simulation(scenario);
    ForceChannel forces;
    const double frame = 1.0 / scenario.simulation.visual_rate;
    double next = frame;
    for (const ToolSample& x : generate_task_log(scenario, motion)) {
      s->on_sample(x);
      while (x.t >= next) {
        s->end_frame(next, forces);
        next += frame;
      }
    }
    s->end_frame(next, forces);
    return s;
  }();
  return *sim;
}

// Looking straight down on (x, y) from 10 cm.
Camera above(double x, double y) {
  Camera c;
  c.target = Vec3(x, y, 0.0);
  c.distance = 0.1;
  c.pitch = 1.5707963267948966;
  return c;
}

}  // namespace

TEST_CASE("the cursor's ray passes through the point the camera projects to that pixel") {
  Camera c;
  c.target = Vec3(0.01, -0.02, 0.003);
  c.yaw = -2.1;
  c.pitch = 0.6;
  c.distance = 0.15;
  const Vec3 p(0.02, -0.015, 0.0);
  const Eigen::Vector3d px = c.project(p, 800, 600);
  const Ray r = camera_ray(c, px.x(), px.y(), 800, 600);
  CHECK(r.direction.norm() == doctest::Approx(1.0));
  CHECK((r.origin - c.eye()).norm() < 0.02 * c.distance);  // from the near plane, by the eye
  const Vec3 off = (p - r.origin) - (p - r.origin).dot(r.direction) * r.direction;
  CHECK(off.norm() < 1e-12);
  c.ortho_half_height = 0.05;  // orthographic: parallel rays, the same rule
  const Eigen::Vector3d po = c.project(p, 800, 600);
  const Ray ro = camera_ray(c, po.x(), po.y(), 800, 600);
  CHECK(((p - ro.origin) - (p - ro.origin).dot(ro.direction) * ro.direction).norm() < 1e-12);
}

TEST_CASE("a click on a severed piece picks it, and the point it gives lies in that piece" *
          doctest::test_suite("slow")) {
  Simulation& sim = halves();
  FrameSnapshot s;
  sim.snapshot(s, true);
  REQUIRE(s.pieces.size() == 2);
  CHECK(s.triangle_piece.size() * 3 == s.surface.size());
  CHECK(s.edge_piece.size() * 2 == s.edges.size());
  // The pieces' volumes and centroids: 24 x 8.7 and 24 x 11.3 mm, 8 mm deep.
  const FrameSnapshot::Piece& a = s.pieces[0];
  const FrameSnapshot::Piece& b = s.pieces[1];
  CHECK(a.volume + b.volume == doctest::Approx(0.024 * 0.020 * 0.008).epsilon(1e-9));
  const FrameSnapshot::Piece& far = a.centroid.y() > b.centroid.y() ? a : b;
  CHECK(far.volume == doctest::Approx(0.024 * 0.0087 * 0.008).epsilon(1e-9));
  CHECK(far.centroid.y() == doctest::Approx((0.0013 + 0.01) / 2).epsilon(1e-9));
  CHECK(far.centroid.z() == doctest::Approx(-0.004).epsilon(1e-9));

  for (const double y : {0.006, -0.004}) {
    CAPTURE(y);
    const Camera c = above(0.0031, y);
    const std::optional<PieceHit> hit = pick_piece(s, camera_ray(c, 400, 300, 800, 600));
    REQUIRE(hit);
    CHECK(hit->surface.z() == doctest::Approx(0.0).scale(1e-3));  // the top face
    CHECK(hit->surface.y() == doctest::Approx(y).scale(1e-3));
    CHECK(hit->inside.z() < 0.0);
    const FrameSnapshot::Piece& picked = s.pieces[hit->piece];
    CHECK((picked.centroid.y() > 0.0013) == (y > 0.0013));
    // The simulation finds the same piece there: every node on the picked side of the cut.
    const std::vector<std::uint32_t> nodes = sim.piece_at(hit->inside);
    REQUIRE_FALSE(nodes.empty());
    CHECK(nodes.size() < sim.mesh().node_count());
    for (const std::uint32_t n : nodes) {
      const double rest_y = sim.mesh().rest(sim.mesh().node_handle(n)).y();
      CHECK((y > 0.0013 ? rest_y >= 0.0013 - 1e-9 : rest_y <= 0.0013 + 1e-9));
    }
  }
  // Outside the box: nothing.
  CHECK_FALSE(pick_piece(s, camera_ray(above(0.05, 0.0), 400, 300, 800, 600)));
}

TEST_CASE("the preview moves the dragged piece's triangles and edges, and nothing else" *
          doctest::test_suite("slow")) {
  FrameSnapshot s;
  halves().snapshot(s, true);
  REQUIRE(s.pieces.size() == 2);
  FrameSnapshot moved = s;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix();
  const Vec3 shift(0.0, 0.01, 0.005);
  move_piece_preview(moved, 1, turn, shift);
  const Vec3 c = s.pieces[1].centroid;
  const auto at = [](const std::array<float, 3>& p) { return Vec3(p[0], p[1], p[2]); };
  for (std::size_t t = 0; t < s.triangle_piece.size(); ++t)
    for (std::size_t k = 3 * t; k < 3 * t + 3; ++k) {
      const Vec3 was = at(s.surface[k].position), now = at(moved.surface[k].position);
      const Vec3 expect = s.triangle_piece[t] == 1 ? Vec3(c + turn * (was - c) + shift) : was;
      CHECK((now - expect).norm() < 1e-8);  // [m] float storage
    }
  for (std::size_t e = 0; e < s.edge_piece.size(); ++e) {
    const Vec3 was = at(s.edges[2 * e]), now = at(moved.edges[2 * e]);
    CHECK(((s.edge_piece[e] == 1) == ((now - was).norm() > 1e-4)));
  }
}
