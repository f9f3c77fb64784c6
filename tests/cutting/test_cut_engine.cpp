#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <tuple>
#include <vector>

#include "cutting/cut_engine.hpp"
#include "mesh/generators.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "mesh/topology.hpp"
#include "mesh/validate.hpp"

using namespace scalpel;

namespace {

// A vertical blade at x = `x`, from z = 1.5 (back) down to z = -0.5 (tip), at y.
BladePose vertical_blade(double x, double y) {
  return {Vec3(x, y, 1.5), Vec3(x, y, -0.5), Vec3::Zero()};
}

void require_valid(const TetMesh& m, double volume) {
  const auto r = validate(m, {.reference_volume = volume});
  REQUIRE_MESSAGE(r.ok(), r.summary());
}

// Sweeps the vertical blade at x across the whole unit box along +y; `each` runs after every step.
template <class Each>
void sweep_through(CutEngine& cutter, double x, Each&& each) {
  cutter.place(vertical_blade(x, -0.5));
  for (int k = 1; k <= 200; ++k) {
    cutter.step(vertical_blade(x, -0.5 + 0.01 * k));
    each();
  }
}

}  // namespace

TEST_CASE("a planar through-cut separates a box into two exact halves" * doctest::test_suite("slow")) {
  for (const CubeSplit split : {CubeSplit::Six, CubeSplit::Five}) {
    CAPTURE(static_cast<int>(split));
    TetMesh mesh = make_box({.cells = {4, 4, 4}, .split = split});
    CutEngine cutter(mesh);
    const double x = 0.37;
    sweep_through(cutter, x, [&] { require_valid(mesh, 1.0); });
    const auto comps = connected_components(mesh);
    REQUIRE(comps.count() == 2);
    std::vector<double> v = comps.rest_volume;
    std::sort(v.begin(), v.end());
    CHECK(std::abs(v[0] - x) <= 1e-9 * x);
    CHECK(std::abs(v[1] - (1 - x)) <= 1e-9 * (1 - x));
    CHECK(std::abs(cutter.cut_surface_area() - 1.0) < 1e-9);
    // Each side: every tetrahedron lies wholly on its side of the plane.
    for (const TetId t : mesh.tets()) {
      double lo = 1e9, hi = -1e9;
      for (const NodeId n : mesh.tet_nodes(t)) {
        lo = std::min(lo, mesh.rest(n).x());
        hi = std::max(hi, mesh.rest(n).x());
      }
      CHECK((hi <= x + 1e-12 || lo >= x - 1e-12));
    }
  }
}

namespace {

// Area of the opened crack: boundary faces whose vertices all lie (rest) in the plane x = x0,
// halved because each side has its own copy.
double open_crack_area(const TetMesh& m, double x0) {
  double area = 0;
  for (const auto& f : boundary_faces(m)) {
    const auto& r = m.rest_positions();
    bool in_plane = true;
    for (const auto n : f.nodes) in_plane &= std::abs(r[n].x() - x0) < 1e-12;
    if (in_plane) area += 0.5 * (r[f.nodes[1]] - r[f.nodes[0]]).cross(r[f.nodes[2]] - r[f.nodes[0]]).norm();
  }
  return area / 2;
}

}  // namespace

TEST_CASE("the cut surface opens behind the blade at every step (invariant 6)") {
  TetMesh mesh = make_box({.cells = {4, 4, 4}});
  CutEngine cutter(mesh);
  const double x = 0.37, h = 0.25;  // cell size: the blade is inside tetrahedra one cell wide
  cutter.place(vertical_blade(x, -0.5));
  for (int k = 1; k <= 110; ++k) {
    const double y = -0.5 + 0.01 * k;
    const auto stats = cutter.step(vertical_blade(x, y));
    require_valid(mesh, 1.0);
    // Every edge crossed forward so far is split: none of them is left whole in the mesh.
    CHECK(stats.recrossed_edges == 0);
    const double swept = std::clamp(y, 0.0, 1.0);  // swept area inside the unit box
    const double open = open_crack_area(mesh, x);
    CHECK(open <= swept + 1e-12);
    CHECK(open >= swept - 2 * h);
  }
  // The incision stopped at y = 0.6: the box holds together, and ahead of the blade nothing opened.
  CHECK(connected_components(mesh).count() == 1);
  for (const auto& f : boundary_faces(mesh)) {
    const auto& r = mesh.rest_positions();
    bool in_plane = true;
    double ymin = 1e9;
    for (const auto n : f.nodes) {
      in_plane &= std::abs(r[n].x() - x) < 1e-12;
      ymin = std::min(ymin, r[n].y());
    }
    if (in_plane) CHECK(ymin <= 0.6 + 1e-12);
  }
}

namespace {

// The opened crack of a cut unit box: the boundary faces that are not on the box's own boundary
// (rest configuration), halved because each lip has its own copy; and the deepest rest point of one.
struct OpenedCrack {
  double area = 0;
  double lowest = 1e9;
};

OpenedCrack opened_crack(const TetMesh& m) {
  const auto& r = m.rest_positions();
  auto on_box = [](const Vec3& p) {
    for (int i = 0; i < 3; ++i)
      if (std::abs(p[i]) < 1e-12 || std::abs(p[i] - 1) < 1e-12) return true;
    return false;
  };
  OpenedCrack out;
  for (const auto& f : boundary_faces(m)) {
    const Vec3 &a = r[f.nodes[0]], &b = r[f.nodes[1]], &c = r[f.nodes[2]];
    if (on_box((a + b + c) / 3)) continue;
    out.area += 0.25 * (b - a).cross(c - a).norm();
    out.lowest = std::min({out.lowest, a.z(), b.z(), c.z()});
  }
  return out;
}

}  // namespace

// Paper section 4.1: the cut surface reaches the tool. A partial-depth incision opens the whole area
// the blade swept inside the box, down to the tip's path, and cut_surface_area() reports that area.
// Before faces with entry nodes counted as crack faces, and before the entry nodes were split first,
// the crack ended at the mid nodes half a face above the tip: 87-96 % of the swept area, the deepest
// opened point 0.04-0.22 of a cell above the tip.
TEST_CASE("a partial-depth incision opens the swept area down to the tip's path") {
  const double h = 0.25;                 // 4 cells
  for (const double end : {0.7, 1.3}) {  // the blade stops inside the box, or leaves it
    for (const double tip : {0.26, 0.3, 0.35, 0.4, 0.45}) {
      for (const double tilt : {0.0, 0.3}) {
        CAPTURE(end);
        CAPTURE(tip);
        CAPTURE(tilt);
        TetMesh mesh = make_box({.cells = {4, 4, 4}});
        CutEngine cutter(mesh);
        const double x = 0.37, top = 1.6;
        auto blade = [&](double y) {
          return BladePose{Vec3(x + tilt, y, top), Vec3(x, y, tip), Vec3(0, 1, 0)};
        };
        cutter.place(blade(-0.3));
        const int n = static_cast<int>(std::lround((end + 0.3) * 1600));
        for (int k = 1; k <= n; ++k) cutter.step(blade(-0.3 + (end + 0.3) * k / n));
        require_valid(mesh, 1.0);
        // The blade swept the plane through its two lines from the tip's path up to the top of the
        // box, from y = 0 to where it stopped.
        const double slant = std::sqrt(1 + tilt * tilt / ((top - tip) * (top - tip)));
        const double swept = (1.0 - tip) * slant * std::min(end, 1.0);
        const OpenedCrack open = opened_crack(mesh);
        MESSAGE("blade stopped at y = " << end << ", tip " << tip << ", tilt " << tilt << ": opened "
                                        << open.area / swept << " of the swept area, deepest opened point "
                                        << (open.lowest - tip) / h << " cells above the tip");
        // While the blade stands in the box, the tip is inside a tetrahedron, where no node follows
        // it: the strip between the last face it pierced and the tip opens once it leaves.
        CHECK(open.area >= (end < 1 ? 0.97 : 0.98) * swept);
        CHECK(open.area <= swept * (1 + 1e-9));
        CHECK(open.lowest - tip <= 0.1 * h);
        CHECK(std::abs(cutter.cut_surface_area() - open.area) <= 0.02 * open.area);
        CHECK(connected_components(mesh).count() == 1);
      }
    }
  }
}

TEST_CASE("a curved incision (an arc) keeps the mesh valid and separates the box") {
  TetMesh mesh = make_box({.cells = {5, 5, 3}, .split = CubeSplit::Five});
  CutEngine cutter(mesh);
  const Vec3 centre(0.5, -0.4, 0);
  const double radius = 0.9;
  auto blade = [&](double angle) {
    const Vec3 p = centre + radius * Vec3(std::cos(angle), std::sin(angle), 0);
    return BladePose{Vec3(p.x(), p.y(), 1.5), Vec3(p.x(), p.y(), -0.5), Vec3::Zero()};
  };
  // From the right side (x > 1) to the left (x < 0) across the box, counter-clockwise.
  const double a0 = 0.2, a1 = 3.14159 - 0.2;
  cutter.place(blade(a0));
  for (int k = 1; k <= 300; ++k) {
    cutter.step(blade(a0 + (a1 - a0) * k / 300));
    require_valid(mesh, 1.0);
  }
  const auto comps = connected_components(mesh);
  REQUIRE(comps.count() == 2);
  CHECK(std::abs(comps.rest_volume[0] + comps.rest_volume[1] - 1.0) < 1e-12);
  CHECK(cutter.totals().edges_cut > 0);
}

TEST_CASE("a scalpel entering the top surface from above pierces faces before cutting edges") {
  TetMesh mesh = make_box({.cells = {4, 4, 4}});
  CutEngine cutter(mesh);
  // A blade tilted 30 degrees from vertical in the yz plane, tip first, 0.3 long.
  const Vec3 along = Vec3(0, -std::sin(0.5236), std::cos(0.5236)) * 0.3;  // from tip to back
  auto blade = [&](const Vec3& tip) { return BladePose{tip + along, tip, Vec3::Zero()}; };
  Vec3 tip(0.37, 0.3, 1.1);
  cutter.place(blade(tip));
  std::size_t pierces_before_first_edge = 0;
  bool edge_seen = false;
  int k = 0;
  auto advance = [&](const Vec3& d, int n) {
    for (int i = 0; i < n; ++i, ++k) {
      tip += d;
      const auto s = cutter.step(blade(tip));
      if (!edge_seen) pierces_before_first_edge += s.face_pierces;
      edge_seen |= s.edges_cut > 0;
      require_valid(mesh, 1.0);
    }
  };
  advance(Vec3(0, 0.002, -0.01), 30);  // descend to z = 0.8
  advance(Vec3(0, 0.01, 0), 40);       // draw the incision along +y
  advance(Vec3(0, 0.002, 0.01), 40);   // lift out
  CHECK(pierces_before_first_edge >= 1);
  CHECK(cutter.totals().face_pierces >= 2);
  CHECK(cutter.totals().edges_cut > 0);
  CHECK(connected_components(mesh).count() == 1);
}

TEST_CASE("a planar through-cut of a gmsh-made irregular mesh separates exact halves" *
          doctest::test_suite("slow")) {
  TetMesh mesh = read_gmsh(SCALPEL_TEST_MSH22);
  const MeshSummary before = summarize(mesh);
  CutEngine cutter(mesh);
  // The block is 40 x 30 x 20 mm; cut it at x = c with a vertical blade longer than it is high.
  const Vec3 lo = before.box_min, hi = before.box_max;
  const double c = lo.x() + 0.4123 * (hi.x() - lo.x());
  auto blade = [&](double y) {
    return BladePose{Vec3(c, y, hi.z() + 0.01), Vec3(c, y, lo.z() - 0.01), Vec3::Zero()};
  };
  const double y0 = lo.y() - 0.005, y1 = hi.y() + 0.005;
  const int steps = 400;
  cutter.place(blade(y0));
  for (int k = 1; k <= steps; ++k) {
    cutter.step(blade(y0 + (y1 - y0) * k / steps));
    require_valid(mesh, before.rest_volume);
  }
  const auto comps = connected_components(mesh);
  REQUIRE(comps.count() == 2);
  const double left = (c - lo.x()) * (hi.y() - lo.y()) * (hi.z() - lo.z());
  const double right = before.rest_volume - left;
  std::vector<double> v = comps.rest_volume;
  std::sort(v.begin(), v.end());
  const double small = std::min(left, right), large = std::max(left, right);
  CHECK(std::abs(v[0] - small) <= 1e-9 * small);
  CHECK(std::abs(v[1] - large) <= 1e-9 * large);
  MESSAGE("irregular mesh: " << before.tets << " tetrahedra, " << cutter.totals().coarse_tets_cut << " cut, "
                             << mesh.tet_count() << " after");
}

TEST_CASE("element counts per final pattern and tetrahedra per cut tetrahedron") {
  // A lone tetrahedron put into each complete planar state: the subdivision the script's program
  // makes, counted. Mid nodes sit on every face around a cut edge (section 5.2).
  struct Expect {
    CutTopology topology;
    std::size_t tets;
    std::size_t parts;
  };
  const std::vector<Expect> cases = {
      {{0b000001, 0, 0}, 6, 1},     // A3: one edge and its two faces' mid nodes
      {{0b000011, 0, 0}, 10, 1},    // B3: two adjacent edges, three faces with mid nodes
      {{0b000111, 0, 0}, 11, 2},    // D3: the 1|3 split around vertex A
      {{0b011110, 0, 0}, 15, 2},    // E3: the 2|2 split (loop AC AD BD BC)
      {{0, 0b0100, 0b0100}, 5, 1},  // O: the tip pierced a face and the blade crossed it
  };
  for (const auto& e : cases) {
    TetMesh mesh;
    const NodeId a = mesh.add_node(Vec3(0, 0, 0)), b = mesh.add_node(Vec3(1, 0, 0)),
                 c = mesh.add_node(Vec3(0.2, 1, 0)), d = mesh.add_node(Vec3(0.3, 0.2, 1));
    mesh.add_tet({a, b, c, d});
    CutEngine cutter(mesh);
    const CutStepStats s = cutter.impose(0, e.topology, true);
    CAPTURE(cutter.state_label_of(0));
    CHECK(mesh.tet_count() == e.tets);
    CHECK(cutter.subdivision_sizes() == std::vector<std::size_t>{e.tets});
    CHECK(s.tets_created == e.tets);
    CHECK(s.tets_removed == 1);
    CHECK(connected_components(mesh).count() == e.parts);
    require_valid(mesh, 1.0 / 6.0 * (Vec3(1, 0, 0).dot(Vec3(0.2, 1, 0).cross(Vec3(0.3, 0.2, 1)))));
  }
}

TEST_CASE("backward crossings are registered, a later forward crossing cuts in their place (Eq. 1, Fig. 9)") {
  TetMesh mesh = make_box({.cells = {4, 4, 4}});
  CutEngine cutter(mesh);
  // The sharp edge faces -y. Pulling the blade along +y leads with the blunt side.
  auto blade = [](double x, double y) {
    return BladePose{Vec3(x, y, 1.5), Vec3(x, y, -0.5), Vec3(0, -1, 0)};
  };
  cutter.place(blade(0.37, -0.5));
  for (int k = 1; k <= 200; ++k) {
    cutter.step(blade(0.37, -0.5 + 0.01 * k));
    require_valid(mesh, 1.0);
  }
  const std::size_t registered = cutter.totals().backward_crossings;
  CHECK(registered > 0);
  CHECK(cutter.totals().edges_cut == 0);
  CHECK(connected_components(mesh).count() == 1);
  CHECK(open_crack_area(mesh, 0.37) == 0.0);  // nothing opened
  const std::size_t tets_after_backward = mesh.tet_count();

  // Forward along -y at x = 0.38: the same edges, crossed by the sharp side. Their nodes move to the
  // new crossings and cut; the subdivision stays.
  cutter.place(blade(0.38, 1.5));
  for (int k = 1; k <= 200; ++k) {
    cutter.step(blade(0.38, 1.5 - 0.01 * k));
    require_valid(mesh, 1.0);
  }
  CHECK(cutter.totals().replaced_crossings == registered);
  CHECK(cutter.totals().edges_cut == registered);
  CHECK(cutter.totals().recrossed_edges == 0);
  CHECK(mesh.tet_count() == tets_after_backward);
  CHECK(connected_components(mesh).count() == 2);
  for (const Vec3& p : cutter.cut_points()) CHECK(p.x() == doctest::Approx(0.38).epsilon(1e-12));
}

TEST_CASE("example 4 (Fig. 11): a tetrahedron cut over one edge without a pierce is in A0") {
  TetMesh mesh;
  const NodeId a = mesh.add_node(Vec3(0, 0, 0)), b = mesh.add_node(Vec3(1, 0, 0)),
               c = mesh.add_node(Vec3(0, 1, 0)), d = mesh.add_node(Vec3(0, 0, 1));
  mesh.add_tet({a, b, c, d});
  CutEngine cutter(mesh);
  // A blade across edge AB, on the line y + z = s at x = 0.5, both ends outside the tetrahedron;
  // s goes from -0.05 (outside, beyond AB) to 0.05: the blade enters over the edge, not by a face.
  auto blade = [](double s) {
    return BladePose{Vec3(0.5, -0.1, 0.1 + s), Vec3(0.5, 0.1 + s, -0.1), Vec3::Zero()};
  };
  cutter.place(blade(-0.05));
  for (int k = 1; k <= 10; ++k) {
    cutter.step(blade(-0.05 + 0.01 * k));
    require_valid(mesh, 1.0 / 6.0);
  }
  CHECK(cutter.totals().edges_cut == 1);
  CHECK(cutter.totals().face_pierces == 0);
  CHECK(cutter.state_label_of(0) == "A0");
  CHECK(cutter.transitions_by_label().at("O0->A0") == 1);
  CHECK(mesh.tet_count() == 6);  // one edge, two crossed faces: the in-progress pattern of section 4.1
}

TEST_CASE(
    "pulling back (section 5.2, Fig. 10): a face's mid node settles at the average of its sampled "
    "trajectory") {
  TetMesh mesh;
  const NodeId a = mesh.add_node(Vec3(0, 0, 0)), b = mesh.add_node(Vec3(1, 0, 0)),
               c = mesh.add_node(Vec3(0, 1, 0)), d = mesh.add_node(Vec3(0, 0, 1));
  mesh.add_tet({a, b, c, d});
  CutEngine cutter(mesh);
  // A vertical blade at x = 0.3 through the bottom face ABC (z = 0): in over edge AB, forward to a
  // turning point at y = 0.513, back and out over AB again.
  auto blade = [](double y) { return BladePose{Vec3(0.3, y, -0.5), Vec3(0.3, y, 0.3), Vec3::Zero()}; };
  std::vector<double> ys;
  for (int k = 0; k <= 12; ++k) ys.push_back(-0.087 + 0.05 * k);
  for (int k = 11; k >= 0; --k) ys.push_back(-0.087 + 0.05 * k);
  cutter.place(blade(ys[0]));
  double sum = 0;
  int samples = 0;
  for (std::size_t i = 1; i < ys.size(); ++i) {
    cutter.step(blade(ys[i]));
    require_valid(mesh, 1.0 / 6.0);
    if (ys[i] > 0) {  // the blade crosses face ABC at (0.3, y, 0): one sample of the ENP
      sum += ys[i];
      ++samples;
    }
  }
  REQUIRE(samples == 21);
  // The mid node of ABC: the created node inside the face (off edge AB, which holds y = 0).
  std::vector<Vec3> inside;
  for (const NodeId n : mesh.nodes())
    if (n.index > 3 && mesh.rest(n).z() == 0.0 && mesh.rest(n).y() > 1e-9) inside.push_back(mesh.rest(n));
  REQUIRE(inside.size() == 1);
  CHECK(inside[0].x() == doctest::Approx(0.3).epsilon(1e-12));
  CHECK(inside[0].y() == doctest::Approx(sum / samples).epsilon(1e-12));
  // Not the face centre, and not the turning point.
  CHECK(std::abs(inside[0].y() - 1.0 / 3.0) > 0.05);
  CHECK(std::abs(inside[0].y() - 0.513) > 0.2);
}

TEST_CASE(
    "several incisions: two parallel through-cuts sever a slab, a crossing cut splits all three pieces" *
    doctest::test_suite("slow")) {
  // y = 0.4151 crosses the earlier cuts between their nodes, with no sample in their planes; y =
  // 0.41 passes exactly through the face nodes they left at their samples (the earlier blades
  // stood at y = 0.41 and 0.42) and samples in their planes: the new surface runs over nodes of the
  // old one (Fig. 12), and cut nodes keep their clamp distance (CutOptions) from them.
  for (const auto& [y, x0, volume_tolerance] :
       {std::tuple{0.4151, 0.0037, 1e-9}, std::tuple{0.41, 0.0, 1e-4}})
    for (const CubeSplit split : {CubeSplit::Six, CubeSplit::Five}) {
      CAPTURE(y);
      CAPTURE(static_cast<int>(split));
      TetMesh mesh = make_box({.cells = {4, 4, 4}, .split = split});
      CutEngine cutter(mesh);
      auto along_y = [](double x, double at) {
        return BladePose{Vec3(x, at, 1.5), Vec3(x, at, -0.5), Vec3::Zero()};
      };
      for (const double x : {0.37, 0.83}) {
        cutter.place(along_y(x, -0.5));
        for (int k = 1; k <= 200; ++k) {
          cutter.step(along_y(x, -0.5 + 0.01 * k));
          require_valid(mesh, 1.0);
        }
      }
      REQUIRE(connected_components(mesh).count() == 3);  // the slab x > 0.83 is severed
      CHECK(cutter.totals().recursions == 0);
      // Across both earlier cuts and into the severed slab.
      cutter.place(along_y(-0.5 + x0, y));
      for (int k = 1; k <= 200; ++k) {
        cutter.step(along_y(-0.5 + x0 + 0.01 * k, y));
        require_valid(mesh, 1.0);
        REQUIRE_MESSAGE(cutter.check_faithful(1e-12).empty(), cutter.check_faithful(1e-12));
      }
      const auto comps = connected_components(mesh);
      REQUIRE(comps.count() == 6);
      std::vector<double> expect;
      for (const double w : {0.37, 0.46, 0.17})
        for (const double h : {y, 1.0 - y}) expect.push_back(w * h);
      std::sort(expect.begin(), expect.end());
      std::vector<double> v = comps.rest_volume;
      std::sort(v.begin(), v.end());
      // The crossing cut reaches tetrahedra the earlier cuts finished: each earlier cut's
      // tetrahedra continue one level deeper (section 6), so the pieces are exact (invariant 7).
      CHECK(cutter.totals().recursions == 2);
      CHECK(cutter.totals().recursion_fallbacks == 0);
      CHECK(cutter.totals().max_recursion_depth == 1);
      for (std::size_t i = 0; i < 6; ++i) CHECK(std::abs(v[i] - expect[i]) < volume_tolerance * expect[i]);
      CHECK(std::abs(std::accumulate(v.begin(), v.end(), 0.0) - 1.0) < 1e-12);
    }
}

TEST_CASE("one stroke that closes on itself excises what it encloses, a figure of eight both lobes" *
          doctest::test_suite("slow")) {
  // Through-cuts by a vertical blade in one stroke, without lifting out: a circle run 0.3 rad past
  // its start, and a figure of eight (x, y) = (0.35 sin a, 0.25 sin 2a) that crosses its own cut at
  // the centre. Each lobe of the eight encloses 4/3 * 0.35 * 0.25 of the unit-square section; on
  // a 12-cell box the pieces come within 3 % of the enclosed areas (the mesh's chords). In 400
  // samples the blade is back at the centre while the tetrahedra there are still the basic
  // machine's (tremble, §5); in 1000 it has left them behind and the second crossing continues the
  // first one level deeper (§6). The circle closes onto its own start along the same surface: the
  // basic machine extends the cut there, at any speed.
  const double lobe = 4.0 / 3.0 * 0.35 * 0.25, disc = 3.14159265358979 * 0.09;
  for (const bool eight : {false, true})
    for (const int samples : {400, 1000}) {
      CAPTURE(eight);
      CAPTURE(samples);
      TetMesh mesh = make_box({.cells = {12, 12, 3}, .split = CubeSplit::Six});
      CutEngine cutter(mesh);
      auto blade = [&](double a) {
        const Vec3 p = eight ? Vec3(0.5 + 0.35 * std::sin(a), 0.5 + 0.25 * std::sin(2 * a), 0)
                             : Vec3(0.5 + 0.3 * std::cos(a), 0.5 + 0.3 * std::sin(a), 0);
        return BladePose{Vec3(p.x(), p.y(), 1.5), Vec3(p.x(), p.y(), -0.5), Vec3::Zero()};
      };
      const double end = eight ? 2 * 3.14159265358979 : 2 * 3.14159265358979 + 0.3;
      cutter.place(blade(0));
      for (int k = 1; k <= samples; ++k) {
        cutter.step(blade(end * k / samples));
        require_valid(mesh, 1.0);
      }
      const auto comps = connected_components(mesh);
      std::vector<double> v = comps.rest_volume;
      std::sort(v.begin(), v.end());
      REQUIRE(v.size() == (eight ? 3u : 2u));
      if (eight) {
        CHECK(std::abs(v[0] - lobe) < 0.03 * lobe);
        CHECK(std::abs(v[1] - lobe) < 0.03 * lobe);
        CHECK(cutter.totals().stroke_recursions == (samples == 1000 ? 1u : 0u));
      } else {
        CHECK(std::abs(v[0] - disc) < 0.03 * disc);
        CHECK(cutter.totals().recursions == 0);
      }
      CHECK(std::abs(std::accumulate(v.begin(), v.end(), 0.0) - 1.0) < 1e-12);
    }
}

TEST_CASE("one stroke that crosses its own incision where the blade has left it continues it there" *
          doctest::test_suite("slow")) {
  // A vertical blade in one stroke, never lifted: up x = 0.37, right along y = 0.8, down x = 0.8,
  // then left along y = 0.4151 across the first leg and out. The first leg was cut some 900
  // samples before the blade returns to it: that part of the stroke is continued one level deeper
  // (section 6), while the tetrahedra around the blade keep the basic machine. The piece the first
  // and last legs sever, x < 0.37 and y < 0.4151, has straight sides only and is exact; the square
  // the loop excises has three turns inside tetrahedra, which the one-level subdivision rounds.
  const std::vector<Vec3> path{Vec3(0.37, -0.5, 0), Vec3(0.37, 0.8, 0), Vec3(0.8, 0.8, 0),
                               Vec3(0.8, 0.4151, 0), Vec3(-0.5, 0.4151, 0)};
  const double corner = 0.37 * 0.4151, square = 0.43 * 0.3849;
  for (const CubeSplit split : {CubeSplit::Six, CubeSplit::Five})
    for (const bool recursive : {true, false}) {
      CAPTURE(static_cast<int>(split));
      CAPTURE(recursive);
      TetMesh mesh = make_box({.cells = {4, 4, 4}, .split = split});
      CutOptions options;
      if (!recursive) options.finished_after_steps = 1u << 30;  // the stroke's cut is never left behind
      CutEngine cutter(mesh, options);
      cutter.place(vertical_blade(path[0].x(), path[0].y()));
      for (std::size_t leg = 1; leg < path.size(); ++leg) {
        const int n = static_cast<int>(std::ceil((path[leg] - path[leg - 1]).norm() / 0.002));
        for (int k = 1; k <= n; ++k) {
          const Vec3 p = path[leg - 1] + (path[leg] - path[leg - 1]) * k / n;
          cutter.step(vertical_blade(p.x(), p.y()));
          require_valid(mesh, 1.0);
        }
      }
      REQUIRE_MESSAGE(cutter.check_faithful(1e-12).empty(), cutter.check_faithful(1e-12));
      const auto comps = connected_components(mesh);
      REQUIRE(comps.count() == 3);
      std::vector<double> v = comps.rest_volume;
      std::sort(v.begin(), v.end());
      CHECK(std::abs(std::accumulate(v.begin(), v.end(), 0.0) - 1.0) < 1e-12);
      CHECK(std::abs(v[1] - square) < 0.03 * square);
      const CutTotals& t = cutter.totals();
      const char* how = recursive ? "continued" : "basic machine only";
      MESSAGE(std::string(how) << ": corner piece off by " << (v[0] - corner) / corner << ", "
                               << t.stroke_recursions << " continuations within the stroke");
      if (recursive) {
        CHECK(t.stroke_recursions == 1);
        CHECK(t.recursion_fallbacks == 0);
        CHECK(std::abs(v[0] - corner) < 1e-9 * corner);
      } else {
        CHECK(t.recursions == 0);
        CHECK(std::abs(v[0] - corner) > 1e-3 * corner);  // the second surface only approximated
      }
    }
}

TEST_CASE("a cut that starts where an earlier one ends frees the flap between them (Fig. 12)" *
          doctest::test_suite("slow")) {
  // An incision along y at x = 0.37 up to y = 0.6, pulled back out along its path; then a new one
  // from its end along x to the far side: an L that frees the corner x > 0.37, y < 0.6. The new
  // cut starts in the tetrahedra where the first ends, whose cut nodes there have not opened: the
  // basic machine continues them, so the flap comes free, as close to 0.63 x 0.6 as the one-level
  // subdivision resolves the corner inside a tetrahedron.
  for (const CubeSplit split : {CubeSplit::Six, CubeSplit::Five}) {
    CAPTURE(static_cast<int>(split));
    TetMesh mesh = make_box({.cells = {4, 4, 4}, .split = split});
    CutEngine cutter(mesh);
    cutter.place(vertical_blade(0.37, -0.5));
    for (int k = 1; k <= 110; ++k) cutter.step(vertical_blade(0.37, -0.5 + 0.01 * k));
    for (int k = 109; k >= 0; --k) cutter.step(vertical_blade(0.37, -0.5 + 0.01 * k));
    cutter.place(vertical_blade(0.37, 0.6));
    for (int k = 1; k <= 120; ++k) {
      cutter.step(vertical_blade(0.37 + 0.01 * k, 0.6));
      require_valid(mesh, 1.0);
    }
    const auto comps = connected_components(mesh);
    REQUIRE(comps.count() == 2);
    const double flap = *std::min_element(comps.rest_volume.begin(), comps.rest_volume.end());
    CHECK(std::abs(flap - 0.63 * 0.6) < 0.02 * 0.63 * 0.6);
  }
}

TEST_CASE("a third cut goes two levels deep: at the depth bound it falls back and the mesh stays valid" *
          doctest::test_suite("slow")) {
  // x = 0.37 and x = 0.3913 along y, y = 0.4151 along x: the third cut runs through the tetrahedra
  // of the first, which the second cut promoted and cut again.
  auto cut = [](CutEngine& cutter, TetMesh& mesh, bool along_y, double at, double offset) {
    auto pose = [&](double s) {
      const Vec3 c = along_y ? Vec3(at, s, 0) : Vec3(s, at, 0);
      return BladePose{c + Vec3(0, 0, 1.5), c - Vec3(0, 0, 0.5), Vec3::Zero()};
    };
    cutter.place(pose(-0.5 + offset));
    for (int k = 1; k <= 200; ++k) {
      cutter.step(pose(-0.5 + offset + 0.01 * k));
      require_valid(mesh, 1.0);
    }
  };
  std::vector<double> expect;
  for (const double w : {0.37, 0.0213, 0.6087})
    for (const double h : {0.4151, 0.5849}) expect.push_back(w * h);
  std::sort(expect.begin(), expect.end());
  for (const int bound : {8, 1}) {
    CAPTURE(bound);
    TetMesh mesh = make_box({.cells = {4, 4, 4}});
    CutOptions options;
    options.max_recursion_depth = bound;
    CutEngine cutter(mesh, options);
    cut(cutter, mesh, true, 0.37, 0.0);
    cut(cutter, mesh, false, 0.4151, 0.0037);
    cut(cutter, mesh, true, 0.3913, 0.0);
    const auto comps = connected_components(mesh);
    REQUIRE(comps.count() == 6);
    std::vector<double> v = comps.rest_volume;
    std::sort(v.begin(), v.end());
    CHECK(std::abs(std::accumulate(v.begin(), v.end(), 0.0) - 1.0) < 1e-12);
    const CutTotals& t = cutter.totals();
    MESSAGE("depth bound " << bound << ": " << t.recursions << " recursive continuations, depth "
                           << t.max_recursion_depth << ", " << t.recursion_fallbacks << " fallbacks");
    if (bound == 8) {
      CHECK(t.max_recursion_depth == 2);
      CHECK(t.recursion_fallbacks == 0);
      for (std::size_t i = 0; i < 6; ++i) CHECK(std::abs(v[i] - expect[i]) < 1e-9 * expect[i]);
    } else {
      // The third cut cannot go below level 1 where the second cut runs: it keeps the one-level
      // subdivision there, valid but not exact.
      CHECK(t.max_recursion_depth == 1);
      CHECK(t.recursion_fallbacks > 0);
      double worst = 0;
      for (std::size_t i = 0; i < 6; ++i) worst = std::max(worst, std::abs(v[i] - expect[i]));
      CHECK(worst > 1e-9);
      CHECK(worst < 0.015);
    }
  }
}

TEST_CASE("an opened crack stays open where later cuts reach it: copies follow their elements" *
          doctest::test_suite("slow")) {
  // A cut that stops inside the box, its crack opened by moving each side apart, then a cut across
  // it and a third along the first, through the tetrahedra the second promoted. No element may hold
  // nodes from both sides of the opened crack: that would tear it across the gap.
  for (const CubeSplit split : {CubeSplit::Six, CubeSplit::Five}) {
    CAPTURE(static_cast<int>(split));
    TetMesh mesh = make_box({.cells = {4, 4, 4}, .split = split});
    CutEngine cutter(mesh);
    cutter.place(vertical_blade(0.37, -0.5));
    for (int k = 1; k <= 110; ++k) cutter.step(vertical_blade(0.37, -0.5 + 0.01 * k));
    cutter.place(vertical_blade(0.37, 1.5));  // lift out: the first cut ends at y = 0.6
    constexpr double d = 0.01;
    for (const NodeId n : mesh.nodes()) {
      bool left = false, right = false;
      for (const std::uint32_t t : mesh.node_tets(n)) {
        Vec3 c = Vec3::Zero();
        for (const NodeId v : mesh.tet_nodes(mesh.tet_handle(t))) c += mesh.rest(v) / 4;
        (c.x() < 0.37 ? left : right) = true;
      }
      const double side = left && !right ? -1.0 : right && !left ? 1.0 : 0.0;
      mesh.set_position(n, mesh.rest(n) + Vec3(d * side, 0, 0));
    }
    cutter.refit();
    // An element that spans the gap has nodes displaced by -d and by +d.
    auto spans = [&](TetId t) {
      double lo = 0, hi = 0;
      for (const NodeId v : mesh.tet_nodes(t)) {
        const double u = (mesh.position(v) - mesh.rest(v)).x() / d;
        lo = std::min(lo, u);
        hi = std::max(hi, u);
      }
      return lo < -0.5 && hi > 0.5;
    };
    auto check_open = [&](int cut, int k) {
      for (const TetId t : cutter.changes().added_tets)
        REQUIRE_MESSAGE(!(mesh.alive(t) && spans(t)),
                        "cut " << cut << " step " << k << ": tetrahedron " << t.index << " spans the gap");
    };
    auto across = [](double x) {
      return BladePose{Vec3(x, 0.4151, 1.5), Vec3(x, 0.4151, -0.5), Vec3::Zero()};
    };
    cutter.place(across(-0.4963));
    for (int k = 1; k <= 200; ++k) {
      cutter.step(across(-0.4963 + 0.01 * k));
      check_open(2, k);
    }
    require_valid(mesh, 1.0);
    cutter.place(vertical_blade(0.3913 + d, -0.5));
    for (int k = 1; k <= 200; ++k) {
      cutter.step(vertical_blade(0.3913 + d, -0.5 + 0.01 * k));
      check_open(3, k);
    }
    require_valid(mesh, 1.0);
    for (const TetId t : mesh.tets()) REQUIRE(!spans(t));
    CHECK(cutter.totals().recursions > 0);
    CHECK(cutter.totals().recursion_fallbacks == 0);
  }
}

TEST_CASE(
    "locate: a point in the tissue gives its original tetrahedron's corners and weights, a gap gives none") {
  TetMesh mesh = make_box({.cells = {4, 4, 4}});
  CutEngine cutter(mesh);
  const std::size_t original_nodes = mesh.node_capacity();
  const double x0 = 0.37;
  const Vec3 inside(0.2, 0.55, 0.45);
  const auto check_weights = [&](const Vec3& p) {
    const std::optional<TetLocation> at = cutter.locate(p);
    REQUIRE(at.has_value());
    Vec3 sum = Vec3::Zero();
    double total = 0;
    for (int i = 0; i < 4; ++i) {
      REQUIRE(mesh.alive(at->corners[i]));
      CHECK(at->corners[i].index < original_nodes);  // never a cut node
      CHECK(at->weights[i] >= -1e-9);
      sum += at->weights[i] * mesh.position(at->corners[i]);
      total += at->weights[i];
    }
    CHECK(std::abs(total - 1.0) < 1e-12);
    CHECK((sum - p).norm() < 1e-12);
    return *at;
  };
  check_weights(inside);
  CHECK_FALSE(cutter.locate(Vec3(1.2, 0.5, 0.5)).has_value());  // beside the box
  CHECK_FALSE(cutter.locate(Vec3(0.5, 0.5, 1.1)).has_value());  // above it

  // Half a through-cut: on the cut plane ahead of the blade the tissue is whole.
  cutter.place(vertical_blade(x0, -0.5));
  for (int k = 1; k <= 100; ++k) cutter.step(vertical_blade(x0, -0.5 + 0.01 * k));
  check_weights(Vec3(x0, 0.9, 0.5));

  // The whole cut, and the far side moved 0.1 away: the gap between the halves is not tissue,
  // although the hulls of the cut units' corners span it.
  for (int k = 101; k <= 200; ++k) cutter.step(vertical_blade(x0, -0.5 + 0.01 * k));
  std::vector<std::uint8_t> far(mesh.node_capacity(), 0);
  for (const TetId t : mesh.tets()) {
    double lo = 1e9;
    for (const NodeId n : mesh.tet_nodes(t)) lo = std::min(lo, mesh.rest(n).x());
    if (lo >= x0 - 1e-12)
      for (const NodeId n : mesh.tet_nodes(t)) far[n.index] = 1;
  }
  for (const NodeId n : mesh.nodes())
    if (far[n.index]) mesh.set_position(n, mesh.position(n) + Vec3(0.1, 0, 0));
  cutter.refit();
  check_weights(inside);
  check_weights(Vec3(0.6, 0.55, 0.45));
  for (const double y : {0.1, 0.3, 0.5, 0.7, 0.9})
    for (const double z : {0.1, 0.3, 0.5, 0.7, 0.9}) {
      CAPTURE(y);
      CAPTURE(z);
      CHECK_FALSE(cutter.locate(Vec3(x0 + 0.05, y, z)).has_value());
      // A blade 0.12 thick in that 0.1 wide gap touches both sides.
      CHECK(cutter.locate(Vec3(x0 + 0.05, y, z), 0.06).has_value());
      CHECK_FALSE(cutter.locate(Vec3(x0 + 0.05, y, z), 0.04).has_value());
    }
}

TEST_CASE("a blade back along an opened cut at a slight slant shaves no slivers off it" *
          doctest::test_suite("slow")) {
  // x = 0.37 along y, then y = 0.4151 along x, which continues the first cut one level deeper
  // (section 6): its cut nodes become corners of units, and edges between them lie in the opened
  // crack. A third stroke goes back along the first with the blade slanted by 0.05 (about 3
  // degrees), meeting the first surface along the bottom face: the same surface as far as the mesh
  // resolves it (CutOptions::same_cut_angle_deg, same_cut_distance). Its crossings of edges lying
  // in the opened crack are the old surface, not a new one; cut, they shave off a piece of no
  // volume along the bottom where the blade meets the old surface, severed where it crosses the
  // second cut. Free fragments of no volume are debris the tissue model cannot condition (docs/tissue.md).
  auto stroke = [](CutEngine& cutter, TetMesh& mesh, bool along_y, double at, double slant, double to) {
    auto pose = [&](double s) {
      auto p = [&](double z) { return along_y ? Vec3(at + slant * z, s, z) : Vec3(s, at + slant * z, z); };
      return BladePose{p(1.5), p(-0.5), Vec3::Zero()};
    };
    const double from = along_y ? -0.5 : -0.4963;  // samples off the first cut's plane
    cutter.place(pose(from));
    const int n = static_cast<int>(std::lround((to - from) / 0.01));
    for (int k = 1; k <= n; ++k) {
      cutter.step(pose(from + 0.01 * k));
      require_valid(mesh, 1.0);
    }
  };
  TetMesh mesh = make_box({.cells = {4, 4, 2}});
  CutEngine cutter(mesh);
  stroke(cutter, mesh, true, 0.37, 0.0, 1.05);
  stroke(cutter, mesh, false, 0.4151, 0.0, 1.05);
  REQUIRE(connected_components(mesh).count() == 4);
  REQUIRE(cutter.totals().recursions == 1);
  stroke(cutter, mesh, true, 0.37, 0.05, 0.6);
  const auto comps = connected_components(mesh);
  std::vector<double> v = comps.rest_volume;
  std::sort(v.begin(), v.end());
  MESSAGE(comps.count() << " pieces, the smallest " << v[0] << ", " << mesh.tet_count() << " tetrahedra");
  // The four pieces of the first two cuts, and at most the wedges the slanted blade could sever
  // between its surface and the first (0.0104 below the second cut): no smaller piece.
  CHECK(comps.count() <= 6);
  CHECK(v[0] > 1e-3);
  CHECK(std::abs(std::accumulate(v.begin(), v.end(), 0.0) - 1.0) < 1e-12);
}

namespace {

// Live nodes no live tetrahedron uses: the tissue model would never move them.
std::size_t unreferenced_nodes(const TetMesh& m) {
  std::size_t out = 0;
  for (const NodeId n : m.nodes()) out += m.node_tets(n).empty() ? 1 : 0;
  return out;
}

// Moves the nodes of the elements on the side x > x0 (by rest centroid) by d; the other side stays.
void move_side(TetMesh& m, double x0, const Vec3& d) {
  for (const NodeId n : m.nodes()) {
    bool right = false;
    for (const std::uint32_t t : m.node_tets(n)) {
      Vec3 c = Vec3::Zero();
      for (const NodeId v : m.tet_nodes(m.tet_handle(t))) c += m.rest(v) / 4;
      right |= c.x() > x0;
    }
    if (right) m.set_position(n, m.rest(n) + d);
  }
}

// The widest distance between two copies of one cut node (cut_node_copies() lists those live
// elements use).
double crack_opening(const CutEngine& cutter, const TetMesh& m) {
  double widest = 0.0;
  for (const auto& n : cutter.cut_node_copies())
    for (std::size_t i = 0; i < n.copies.size(); ++i)
      for (std::size_t j = i + 1; j < n.copies.size(); ++j)
        widest = std::max(widest, (m.position(n.copies[i]) - m.position(n.copies[j])).norm());
  return widest;
}

}  // namespace

TEST_CASE("the cut area is one side's crack faces: a rigidly moved side leaves it unchanged") {
  // A planar through-cut of the unit box at x = 0.37: the section is 1 x 1. Its crack faces are
  // measured at one side's copies, so moving the other side away does not stretch them.
  for (const CubeSplit split : {CubeSplit::Six, CubeSplit::Five}) {
    CAPTURE(static_cast<int>(split));
    TetMesh mesh = make_box({.cells = {4, 4, 4}, .split = split});
    CutEngine cutter(mesh);
    const double x = 0.37;
    sweep_through(cutter, x, [] {});
    REQUIRE(connected_components(mesh).count() == 2);
    CHECK(std::abs(cutter.cut_surface_area() - 1.0) < 1e-9);
    for (const Vec3& d : {Vec3(0.005, 0, 0), Vec3(0.05, 0.02, -0.03), Vec3(0.3, 0, 0)}) {
      CAPTURE(d.transpose());
      move_side(mesh, x, d);
      cutter.refit();
      CHECK(std::abs(cutter.cut_surface_area() - 1.0) < 1e-9);
      CHECK(crack_opening(cutter, mesh) == doctest::Approx(d.norm()).epsilon(1e-9));
    }
  }
}

TEST_CASE("cut node copies that no element uses are removed: every live node is in a live element" *
          doctest::test_suite("slow")) {
  // Groups around a cut node can join again (an entry node of the tip's path, which never opens,
  // takes a crack face's place), and promotion changes which groups remain: the copy a group no
  // longer has must go with its elements, at every step.
  SUBCASE("a scalpel entering from above, drawn along and lifted out") {
    TetMesh mesh = make_box({.cells = {4, 4, 4}});
    CutEngine cutter(mesh);
    const Vec3 along = Vec3(0, -std::sin(0.5236), std::cos(0.5236)) * 0.3;  // from tip to back
    Vec3 tip(0.37, 0.3, 1.1);
    cutter.place({tip + along, tip, Vec3::Zero()});
    int k = 0;
    for (const auto& [d, n] : {std::pair{Vec3(0, 0.002, -0.01), 30}, std::pair{Vec3(0, 0.01, 0), 40},
                               std::pair{Vec3(0, 0.002, 0.01), 40}})
      for (int i = 0; i < n; ++i, ++k) {
        tip += d;
        cutter.step({tip + along, tip, Vec3::Zero()});
        REQUIRE_MESSAGE(unreferenced_nodes(mesh) == 0, "step " << k);
      }
    move_side(mesh, 0.37, Vec3(0.01, 0, 0));  // open it: every copy moves with its elements
    CHECK(crack_opening(cutter, mesh) == doctest::Approx(0.01).epsilon(1e-9));
  }
  SUBCASE("a stroke that crosses its own opened incision where the blade has left it") {
    const std::vector<Vec3> path{Vec3(0.37, -0.5, 0), Vec3(0.37, 0.8, 0), Vec3(0.8, 0.8, 0),
                                 Vec3(0.8, 0.4151, 0), Vec3(-0.5, 0.4151, 0)};
    for (const CubeSplit split : {CubeSplit::Six, CubeSplit::Five}) {
      CAPTURE(static_cast<int>(split));
      TetMesh mesh = make_box({.cells = {4, 4, 4}, .split = split});
      CutEngine cutter(mesh);
      cutter.place(vertical_blade(path[0].x(), path[0].y()));
      for (std::size_t leg = 1; leg < path.size(); ++leg) {
        const int n = static_cast<int>(std::ceil((path[leg] - path[leg - 1]).norm() / 0.002));
        for (int k = 1; k <= n; ++k) {
          const Vec3 p = path[leg - 1] + (path[leg] - path[leg - 1]) * k / n;
          cutter.step(vertical_blade(p.x(), p.y()));
          REQUIRE_MESSAGE(unreferenced_nodes(mesh) == 0, "leg " << leg << " step " << k);
        }
      }
      CHECK(cutter.totals().stroke_recursions == 1);
      require_valid(mesh, 1.0);
    }
  }
}
