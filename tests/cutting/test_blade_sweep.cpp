#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <set>

#include "cutting/blade_sweep.hpp"
#include "mesh/generators.hpp"
#include "mesh/predicates.hpp"

using namespace scalpel;

namespace {

using EdgeSet = std::set<std::pair<std::uint32_t, std::uint32_t>>;

TetMesh unit_tet() {
  TetMesh m;
  const NodeId a = m.add_node(Vec3(0, 0, 0)), b = m.add_node(Vec3(1, 0, 0)), c = m.add_node(Vec3(0, 1, 0)),
               d = m.add_node(Vec3(0, 0, 1));
  m.add_tet({a, b, c, d});
  return m;
}

BladePose pose(const Vec3& back, const Vec3& tip, const Vec3& dir = Vec3::Zero()) {
  BladePose p;
  p.back = back;
  p.tip = tip;
  p.cutting_direction = dir;
  return p;
}

EdgeSet all_edges(const TetMesh& m) {
  EdgeSet edges;
  for (std::uint32_t t = 0; t < m.tet_capacity(); ++t) {
    if (!m.tet_slot_alive(t)) continue;
    const auto& v = m.tet_vertex_indices(t);
    for (const auto& e : kEdgeVertices) {
      const std::uint32_t a = v[static_cast<std::size_t>(e[0])], b = v[static_cast<std::size_t>(e[1])];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  }
  return edges;
}

EdgeSet cut_set(const SweepResult& r) {
  EdgeSet s;
  for (const EdgeCut& c : r.edges) s.insert({c.a, c.b});
  return s;
}

// Expected cut edges of a sweep covering the whole mesh, from a side label per node.
EdgeSet partition_cuts(const TetMesh& m, const std::function<bool(const Vec3&)>& positive) {
  EdgeSet s;
  for (const auto& [a, b] : all_edges(m)) {
    if (positive(m.positions()[a]) != positive(m.positions()[b])) s.insert({a, b});
  }
  return s;
}

// Every tetrahedron, looking at its own edges in its own vertex order (both directions), must see
// exactly the global decision.
void check_tets_agree(const TetMesh& m, const BladePose& prev, const BladePose& curr, const EdgeSet& cut) {
  const std::array<Vec3, 4> q = {prev.back, prev.tip, curr.tip, curr.back};
  for (std::uint32_t t = 0; t < m.tet_capacity(); ++t) {
    if (!m.tet_slot_alive(t)) continue;
    const auto& v = m.tet_vertex_indices(t);
    for (const auto& e : kEdgeVertices) {
      const std::uint32_t a = v[static_cast<std::size_t>(e[0])], b = v[static_cast<std::size_t>(e[1])];
      const Vec3 &xa = m.positions()[a], &xb = m.positions()[b];
      const int ab = int(mesh_segment_crosses_blade_triangle(xa, xb, q[0], q[1], q[2])) +
                     int(mesh_segment_crosses_blade_triangle(xa, xb, q[0], q[2], q[3]));
      const int ba = int(mesh_segment_crosses_blade_triangle(xb, xa, q[0], q[1], q[2])) +
                     int(mesh_segment_crosses_blade_triangle(xb, xa, q[0], q[2], q[3]));
      CHECK(ab == ba);
      CHECK((ab == 1) == (cut.count({std::min(a, b), std::max(a, b)}) == 1));
    }
  }
}

// Each edge of a planar sweep is reported at most once (the diagonal counts once).
void check_once(const SweepResult& r) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> count;
  for (const EdgeCut& c : r.edges) ++count[{c.a, c.b}];
  for (const auto& [e, n] : count) CHECK_MESSAGE(n == 1, "edge ", e.first, "-", e.second, " reported ", n);
}

bool inside_tet(const TetMesh& m, std::uint32_t t, const Vec3& x) {
  for (int f = 0; f < 4; ++f) {
    const auto fv = face_vertex_indices(m, t, f);
    if (orient3d(m.positions()[fv[0]], m.positions()[fv[1]], m.positions()[fv[2]], x) >= 0) return false;
  }
  return true;
}

std::uint32_t tet_containing(const TetMesh& m, const Vec3& x) {
  for (std::uint32_t t = 0; t < m.tet_capacity(); ++t)
    if (m.tet_slot_alive(t) && inside_tet(m, t, x)) return t;
  return kInvalidIndex;
}

// A tip path from strictly inside tet `from` to strictly inside tet `to` must be a consistent walk:
// every pierced face has one leaving and one entering record (boundary faces aside), and per tet
// (#entering - #leaving) is -1 for `from`, +1 for `to`, 0 for the others.
void check_walk(const SweepResult& r, std::uint32_t from, std::uint32_t to) {
  std::map<std::uint32_t, int> net;
  for (const FacePierce& p : r.pierces) net[p.tet] += p.entering ? 1 : -1;
  for (const auto& [tet, n] : net) {
    const int expected = tet == from ? -1 : tet == to ? 1 : 0;
    CHECK_MESSAGE(n == expected, "tet ", tet);
  }
  CHECK(net.count(from) == 1);
  CHECK(net.count(to) == 1);
}

}  // namespace

TEST_CASE("perturbed orientations equal orient3d of a slightly displaced mesh") {
  std::mt19937 rng(2024);
  std::uniform_int_distribution<int> coord(-3, 3), k(-2, 2);
  auto ipoint = [&] { return Vec3(coord(rng), coord(rng), coord(rng)); };
  const Vec3 delta(1e-3, 1e-6, 1e-9);  // eps, eps^2, eps^3 with eps = 1e-3
  int degenerate = 0;
  for (int i = 0; i < 400; ++i) {
    const Vec3 p = ipoint(), q = ipoint(), r = ipoint();
    // A point in the plane of (p, q, r): orient3d is exactly 0.
    const Vec3 a = p + k(rng) * (q - p) + k(rng) * (r - p);
    const int s1 = perturbed_orient_blade_triangle_mesh_point(p, q, r, a);
    CHECK(s1 == orient3d(p, q, r, a + delta));
    const int s2 = perturbed_orient_mesh_triangle_blade_point(p, q, r, a);
    if ((q - p).cross(r - p) == Vec3::Zero()) {
      CHECK(s1 == 0);  // a zero-area triangle stays degenerate
      CHECK(s2 == 0);
    } else {
      CHECK(s2 == orient3d(p + delta, q + delta, r + delta, a));
    }
    // Two segments in one plane.
    const Vec3 b = ipoint();
    const Vec3 e = p + k(rng) * (b - p) + k(rng) * (q - p);
    const int s3 = perturbed_orient_mesh_edge_blade_edge(p, b, q, e);
    if ((b - p).cross(e - q) == Vec3::Zero()) {
      CHECK(s3 == 0);  // parallel lines stay coplanar under any translation
    } else {
      CHECK(s3 == orient3d(p + delta, b + delta, q, e));
    }
    degenerate += (orient3d(p, q, r, a) == 0) + (orient3d(p, b, q, e) == 0);
  }
  CHECK(degenerate == 800);
}

TEST_CASE("planar sweep through a single tetrahedron cuts exactly the edges crossing the plane") {
  const TetMesh m = unit_tet();
  BladeSweep sweep(m);
  SweepResult r;
  // Blade along z at x = 0.3, moving from y = -1 to y = 2: the quad covers the plane section.
  sweep.sweep(pose({0.3, -1, -1}, {0.3, -1, 2}), pose({0.3, 2, -1}, {0.3, 2, 2}), r);
  REQUIRE(r.edges.size() == 3);
  CHECK(cut_set(r) == EdgeSet{{0, 1}, {1, 2}, {1, 3}});
  for (const EdgeCut& c : r.edges) {
    const Vec3 expected_point = c.a == 0 ? Vec3(0.3, 0, 0) : c.b == 2 ? Vec3(0.3, 0.7, 0) : Vec3(0.3, 0, 0.7);
    CHECK(std::abs(c.t - (c.a == 0 ? 0.3 : 0.7)) < 1e-12);
    CHECK((c.point - expected_point).norm() < 1e-12);
    // The quad is a rectangle: s = (z + 1) / 3, u = (y + 1) / 3.
    CHECK(std::abs(c.s - (expected_point.z() + 1) / 3) < 1e-12);
    CHECK(std::abs(c.u - (expected_point.y() + 1) / 3) < 1e-12);
    CHECK(c.forward);
  }
  // Sweep order.
  CHECK(std::is_sorted(r.edges.begin(), r.edges.end(),
                       [](const EdgeCut& x, const EdgeCut& y) { return x.u < y.u; }));
  CHECK(r.tets == std::vector<std::uint32_t>{0});
  CHECK(r.pierces.empty());
  CHECK(r.crossings.empty());
}

TEST_CASE("planar sweep through a box cuts the analytic edge set, each edge once") {
  const TetMesh m = make_box({Vec3::Zero(), Vec3::Ones(), {4, 4, 4}, CubeSplit::Six, 0});
  BladeSweep sweep(m);
  SweepResult r;
  const double x0 = 0.375;  // between grid planes: every crossing is proper
  // Diagonal P_k -> T_k+1 runs along y = z: the cube diagonals through (x0, y, y) cross it exactly.
  const BladePose prev = pose({x0, -1, -1}, {x0, -1, 2}), curr = pose({x0, 2, -1}, {x0, 2, 2});
  sweep.sweep(prev, curr, r);
  const EdgeSet expected = partition_cuts(m, [&](const Vec3& x) { return x.x() > x0; });
  CHECK(expected.size() > 40);
  CHECK(cut_set(r) == expected);
  check_once(r);
  const auto& x = m.positions();
  bool diagonal_hit = false;
  for (const EdgeCut& c : r.edges) {
    CHECK(std::abs(c.t - (x0 - x[c.a].x()) / (x[c.b].x() - x[c.a].x())) < 1e-12);
    CHECK(std::abs(c.point.x() - x0) < 1e-12);
    CHECK(std::abs(c.u - (c.point.y() + 1) / 3) < 1e-12);
    CHECK(std::abs(c.s - (c.point.z() + 1) / 3) < 1e-12);
    CHECK(c.forward);
    diagonal_hit |= c.point.y() == c.point.z();
  }
  CHECK(diagonal_hit);
  // Touched: exactly the tetrahedra with nodes on both sides.
  std::vector<std::uint32_t> tets;
  for (std::uint32_t t = 0; t < m.tet_capacity(); ++t) {
    bool lo = false, hi = false;
    for (std::uint32_t n : m.tet_vertex_indices(t)) (x[n].x() < x0 ? lo : hi) = true;
    if (lo && hi) tets.push_back(t);
  }
  CHECK(r.tets == tets);
  check_tets_agree(m, prev, curr, expected);
}

TEST_CASE("Eq. 1: forward and backward crossings") {
  const TetMesh m = unit_tet();
  BladeSweep sweep(m);
  SweepResult r;
  const Vec3 y(0, 1, 0);
  SUBCASE("the blade's own motion is forward") {
    sweep.sweep(pose({0.3, 2, -1}, {0.3, 2, 2}), pose({0.3, -1, -1}, {0.3, -1, 2}), r);
    REQUIRE(r.edges.size() == 3);
    for (const EdgeCut& c : r.edges) CHECK(c.forward);
  }
  SUBCASE("moving with the sharp edge forward") {
    sweep.sweep(pose({0.3, -1, -1}, {0.3, -1, 2}, y), pose({0.3, 2, -1}, {0.3, 2, 2}, y), r);
    REQUIRE(r.edges.size() == 3);
    for (const EdgeCut& c : r.edges) CHECK(c.forward);
  }
  SUBCASE("pulled back against the sharp edge") {
    sweep.sweep(pose({0.3, 2, -1}, {0.3, 2, 2}, y), pose({0.3, -1, -1}, {0.3, -1, 2}, y), r);
    REQUIRE(r.edges.size() == 3);
    for (const EdgeCut& c : r.edges) CHECK_FALSE(c.forward);
  }
  SUBCASE("a blade rotating about its back point cuts forward") {
    sweep.sweep(pose({0.3, -1, -1}, {0.3, -1, 2}), pose({0.3, -1, -1}, {0.3, 3, 2}), r);
    REQUIRE(!r.edges.empty());
    for (const EdgeCut& c : r.edges) CHECK(c.forward);
  }
}

TEST_CASE("tip pierce of a boundary face: entering, leaving, and the blade's face crossing") {
  const TetMesh m = unit_tet();
  BladeSweep sweep(m);
  SweepResult r;
  // Stab along +z through the bottom face z = 0 (local face 3, nodes 0, 1, 2).
  const BladePose below = pose({0.2, 0.2, -1.5}, {0.2, 0.2, -0.5});
  const BladePose in = pose({0.2, 0.2, -0.9}, {0.2, 0.2, 0.1});
  sweep.sweep(below, in, r);
  REQUIRE(r.pierces.size() == 1);
  const FacePierce& p = r.pierces[0];
  CHECK(p.tet == 0);
  CHECK(p.local_face == 3);
  CHECK(p.nodes == std::array<std::uint32_t, 3>{0, 1, 2});
  CHECK(p.entering);
  CHECK((p.point - Vec3(0.2, 0.2, 0)).norm() < 1e-12);
  CHECK((p.bary - Vec3(0.6, 0.2, 0.2)).norm() < 1e-12);
  CHECK(std::abs(p.u - 0.5 / 0.6) < 1e-12);
  CHECK(r.back_pierces.empty());
  REQUIRE(r.crossings.size() == 1);
  CHECK(r.crossings[0].local_face == 3);
  CHECK(std::abs(r.crossings[0].s - 0.9) < 1e-12);
  CHECK((r.crossings[0].bary - Vec3(0.6, 0.2, 0.2)).norm() < 1e-12);
  CHECK(r.tets == std::vector<std::uint32_t>{0});
  CHECK(r.edges.empty());  // a stab sweeps no area

  sweep.sweep(in, below, r);
  REQUIRE(r.pierces.size() == 1);
  CHECK_FALSE(r.pierces[0].entering);
  CHECK(std::abs(r.pierces[0].u - 0.1 / 0.6) < 1e-12);
  CHECK(r.crossings.empty());
  CHECK(r.tets == std::vector<std::uint32_t>{0});  // the previous blade was in it

  // Tip ending inside: no face crossed by the current blade's tip end, the tet holds it.
  sweep.sweep(pose({0.1, 0.1, 0.1}, {0.2, 0.1, 0.1}), pose({0.1, 0.2, 0.1}, {0.2, 0.2, 0.1}), r);
  CHECK(r.pierces.empty());
  CHECK(r.crossings.empty());
  CHECK(r.edges.empty());
  CHECK(r.tets == std::vector<std::uint32_t>{0});
}

TEST_CASE("tip pierce of an interior face gives one leaving and one entering record") {
  TetMesh m;
  const NodeId a = m.add_node(Vec3(0, 0, 0)), b = m.add_node(Vec3(1, 0, 0)), c = m.add_node(Vec3(0, 1, 0)),
               d = m.add_node(Vec3(0, 0, 1)), e = m.add_node(Vec3(1, 1, 1));
  m.add_tet({a, b, c, d});
  m.add_tet({b, c, d, e});
  BladeSweep sweep(m);
  SweepResult r;
  sweep.sweep(pose({0.2, 0.2, -1.8}, {0.2, 0.2, 0.2}), pose({0.5, 0.5, -1.5}, {0.5, 0.5, 0.5}), r);
  REQUIRE(r.pierces.size() == 2);
  for (const FacePierce& p : r.pierces) {
    CHECK(p.nodes == std::array<std::uint32_t, 3>{1, 2, 3});
    CHECK((p.point - Vec3::Constant(1.0 / 3.0)).norm() < 1e-12);
    CHECK((p.bary - Vec3::Constant(1.0 / 3.0)).norm() < 1e-12);
    CHECK(std::abs(p.u - 4.0 / 9.0) < 1e-12);
    CHECK(p.entering == (p.tet == 1));
  }
  CHECK(r.pierces[0].point == r.pierces[1].point);
  CHECK(r.tets == std::vector<std::uint32_t>{0, 1});
}

TEST_CASE("degenerate sweeps follow the single perturbation rule") {
  const TetMesh m = make_box({Vec3::Zero(), Vec3::Ones(), {4, 4, 4}, CubeSplit::Six, 0});
  BladeSweep sweep(m);
  SweepResult r;

  SUBCASE("through a grid plane of nodes: they count on the +x side") {
    const BladePose prev = pose({0.5, -1, -1}, {0.5, -1, 2}), curr = pose({0.5, 2, -1}, {0.5, 2, 2});
    sweep.sweep(prev, curr, r);
    const EdgeSet expected = partition_cuts(m, [](const Vec3& x) { return x.x() >= 0.5; });
    CHECK(!expected.empty());
    CHECK(cut_set(r) == expected);
    check_once(r);
    for (const EdgeCut& c : r.edges) CHECK((c.t == 0.0 || c.t == 1.0));
    check_tets_agree(m, prev, curr, expected);
  }
  SUBCASE("normal along y: nodes on the surface count on the +y side") {
    const BladePose prev = pose({-1, 0.5, -1}, {-1, 0.5, 2}), curr = pose({2, 0.5, -1}, {2, 0.5, 2});
    sweep.sweep(prev, curr, r);
    const EdgeSet expected = partition_cuts(m, [](const Vec3& x) { return x.y() >= 0.5; });
    CHECK(cut_set(r) == expected);
    check_once(r);
    check_tets_agree(m, prev, curr, expected);
  }
  SUBCASE("oblique plane through a node shared by many tetrahedra") {
    // Plane (x - c) . (1, 2, 3) = 0 through c = (0.5, 0.5, 0.5); corners chosen exactly on it.
    auto on_plane = [](double y, double z) { return Vec3(0.5 - 2 * (y - 0.5) - 3 * (z - 0.5), y, z); };
    const BladePose prev = pose(on_plane(-2, -2), on_plane(-2, 3)),
                    curr = pose(on_plane(3, -2), on_plane(3, 3));
    sweep.sweep(prev, curr, r);
    const Vec3 normal(1, 2, 3), c(0.5, 0.5, 0.5);
    const EdgeSet expected = partition_cuts(m, [&](const Vec3& x) { return normal.dot(x - c) >= 0; });
    std::size_t centre_tets = 0;
    for (std::uint32_t n = 0; n < m.node_capacity(); ++n)
      if (m.positions()[n] == c) centre_tets = m.node_tets(m.node_handle(n)).size();
    CHECK(centre_tets >= 6);
    CHECK(cut_set(r) == expected);
    check_once(r);
    check_tets_agree(m, prev, curr, expected);
  }
  SUBCASE("blade moving in the plane of mesh faces") {
    // The swept quad lies in z = 0.5 and covers the nodes with y = 0.5 on it.
    const BladePose prev = pose({-1, 0.3, 0.5}, {2, 0.3, 0.5}), curr = pose({-1, 0.6, 0.5}, {2, 0.6, 0.5});
    sweep.sweep(prev, curr, r);
    const auto& x = m.positions();
    EdgeSet expected;
    for (const auto& [a, b] : all_edges(m)) {
      auto covered = [&](std::uint32_t n) { return x[n].z() == 0.5 && x[n].y() == 0.5; };
      if ((covered(a) && x[b].z() < 0.5) || (covered(b) && x[a].z() < 0.5)) expected.insert({a, b});
    }
    CHECK(expected.size() >= 5);
    CHECK(cut_set(r) == expected);
    check_once(r);
    check_tets_agree(m, prev, curr, expected);
    CHECK(r.pierces.empty());  // the tip path lies in the face plane
  }
}

TEST_CASE("a tip path exactly through a mesh edge or node is a consistent walk") {
  const TetMesh m = make_box({Vec3::Zero(), Vec3::Ones(), {2, 2, 2}, CubeSplit::Six, 0});
  BladeSweep sweep(m);
  SweepResult r;
  SUBCASE("through the interior edge x = y = 0.5") {
    const Vec3 hinge(0.5, 0.5, 0.6875), d(0.1875, 0.4375, 0.0625);
    const Vec3 s = hinge - d, e = hinge + d;
    const std::uint32_t from = tet_containing(m, s), to = tet_containing(m, e);
    REQUIRE(from != kInvalidIndex);
    REQUIRE(to != kInvalidIndex);
    sweep.sweep(pose(s - Vec3(0, 0, 3), s), pose(e - Vec3(0, 0, 3), e), r);
    CHECK(!r.pierces.empty());
    check_walk(r, from, to);
    const auto at_hinge = std::count_if(r.pierces.begin(), r.pierces.end(), [&](const FacePierce& p) {
      return (p.point - hinge).norm() < 1e-12;
    });
    CHECK(at_hinge >= 2);  // one face around the edge, seen from both of its tetrahedra
  }
  SUBCASE("through the centre node") {
    const Vec3 hinge(0.5, 0.5, 0.5), d(0.1875, 0.4375, 0.0625);
    const Vec3 s = hinge - d, e = hinge + d;
    const std::uint32_t from = tet_containing(m, s), to = tet_containing(m, e);
    REQUIRE(from != kInvalidIndex);
    REQUIRE(to != kInvalidIndex);
    sweep.sweep(pose(s - Vec3(0, 0, 3), s), pose(e - Vec3(0, 0, 3), e), r);
    check_walk(r, from, to);
  }
}

TEST_CASE("sweep reuses the result's storage") {
  const TetMesh m = make_box({Vec3::Zero(), Vec3::Ones(), {4, 4, 4}, CubeSplit::Six, 0});
  BladeSweep sweep(m);
  SweepResult r;
  const BladePose prev = pose({0.3, 0.2, 0.1}, {0.35, 0.4, 0.8}),
                  curr = pose({0.4, 0.25, 0.1}, {0.5, 0.45, 0.8});
  sweep.sweep(prev, curr, r);
  REQUIRE(!r.edges.empty());
  REQUIRE(!r.tets.empty());
  const auto* edges = r.edges.data();
  const auto* tets = r.tets.data();
  const std::size_t n = r.edges.size();
  sweep.sweep(prev, curr, r);
  CHECK(r.edges.data() == edges);
  CHECK(r.tets.data() == tets);
  CHECK(r.edges.size() == n);
}

namespace {

void check_same(const SweepResult& x, const SweepResult& y) {
  REQUIRE(x.edges.size() == y.edges.size());
  for (std::size_t i = 0; i < x.edges.size(); ++i) {
    CHECK(x.edges[i].a == y.edges[i].a);
    CHECK(x.edges[i].b == y.edges[i].b);
    CHECK(x.edges[i].t == y.edges[i].t);
    CHECK(x.edges[i].u == y.edges[i].u);
    CHECK(x.edges[i].s == y.edges[i].s);
    CHECK(x.edges[i].forward == y.edges[i].forward);
  }
  REQUIRE(x.pierces.size() == y.pierces.size());
  for (std::size_t i = 0; i < x.pierces.size(); ++i) {
    CHECK(x.pierces[i].tet == y.pierces[i].tet);
    CHECK(x.pierces[i].local_face == y.pierces[i].local_face);
    CHECK(x.pierces[i].entering == y.pierces[i].entering);
    CHECK(x.pierces[i].point == y.pierces[i].point);
  }
  REQUIRE(x.crossings.size() == y.crossings.size());
  for (std::size_t i = 0; i < x.crossings.size(); ++i) {
    CHECK(x.crossings[i].tet == y.crossings[i].tet);
    CHECK(x.crossings[i].local_face == y.crossings[i].local_face);
    CHECK(x.crossings[i].s == y.crossings[i].s);
  }
  CHECK(x.back_pierces.size() == y.back_pierces.size());
  CHECK(x.tets == y.tets);
}

// Independent reference for the edge set: every edge of the mesh against both triangles.
EdgeSet reference_cuts(const TetMesh& m, const BladePose& prev, const BladePose& curr) {
  const std::array<Vec3, 4> q = {prev.back, prev.tip, curr.tip, curr.back};
  EdgeSet s;
  for (const auto& [a, b] : all_edges(m)) {
    const Vec3 &xa = m.positions()[a], &xb = m.positions()[b];
    if (mesh_segment_crosses_blade_triangle(xa, xb, q[0], q[1], q[2]) ||
        mesh_segment_crosses_blade_triangle(xa, xb, q[0], q[2], q[3]))
      s.insert({a, b});
  }
  return s;
}

}  // namespace

TEST_CASE("after deformation, refit and incremental updates the tree query equals brute force" *
          doctest::test_suite("slow")) {
  TetMesh m = make_box({Vec3::Zero(), Vec3::Ones(), {8, 8, 8}, CubeSplit::Six, 0});
  REQUIRE(m.tet_count() == 3072);
  BladeSweep fast(m);
  BladeSweep::Options brute_options;
  brute_options.use_tree = false;
  BladeSweep brute(m, brute_options);
  std::mt19937 rng(4242);
  std::uniform_real_distribution<double> unit(0.0, 1.0), noise(-0.02, 0.02);
  auto random_point = [&] { return Vec3(unit(rng), unit(rng), unit(rng)); };
  auto random_dir = [&] {
    Vec3 d(noise(rng), noise(rng), noise(rng));
    return d.normalized();
  };
  SweepResult rf, rb;
  std::size_t total_cuts = 0, total_pierces = 0, total_candidates = 0;
  for (int round = 0; round < 4; ++round) {
    // Deform: smooth bend plus per-node noise (keeps tetrahedra positive for this amplitude).
    for (std::uint32_t n = 0; n < m.node_capacity(); ++n) {
      const Vec3& x0 = m.rest_positions()[n];
      const Vec3 bend(0.05 * std::sin(3.0 * x0.y() + round), 0.03 * std::cos(2.0 * x0.z()), 0.0);
      m.positions()[n] = x0 + bend + 0.2 * Vec3(noise(rng), noise(rng), noise(rng));
    }
    CHECK(fast.refit() > m.tet_count() / 2);
    CHECK(fast.tree().validate().empty());
    if (round == 1) {
      // One node pushed far: only its tetrahedra leave their fat boxes.
      const std::uint32_t n = 4 * 81 + 4 * 9 + 4;
      m.positions()[n] += Vec3(0.03, -0.02, 0.01);
      const std::size_t moved = fast.refit();
      CHECK(moved >= 1);
      CHECK(moved <= m.node_tets(m.node_handle(n)).size());
      CHECK(fast.tree().validate().empty());
    }
    if (round >= 2) {
      // The cutter's pattern: replace tetrahedra by children around a new interior node.
      for (int k = 0; k < 40; ++k) {
        std::uint32_t t = std::uniform_int_distribution<std::uint32_t>(
            0, static_cast<std::uint32_t>(m.tet_capacity() - 1))(rng);
        if (!m.tet_slot_alive(t)) continue;
        const auto v = m.tet_nodes(m.tet_handle(t));
        Vec3 rest = Vec3::Zero(), cur = Vec3::Zero();
        for (const NodeId n : v) {
          rest += 0.25 * m.rest(n);
          cur += 0.25 * m.position(n);
        }
        const NodeId c = m.add_node(rest, cur);
        m.remove_tet(m.tet_handle(t));
        fast.on_tet_removed(t);
        for (int i = 0; i < 4; ++i) {
          auto child = v;
          child[static_cast<std::size_t>(i)] = c;
          fast.on_tet_added(m.add_tet(child).index);
        }
      }
      CHECK(fast.tree().validate().empty());
      CHECK(fast.tree().leaf_count() == m.tet_count());
    }
    for (int i = 0; i < 100; ++i) {
      const Vec3 back = random_point();
      const double len = 0.05 + 0.5 * unit(rng);
      const Vec3 tip = back + len * random_dir();
      const Vec3 move = (i % 3 == 0 ? 0.3 : 0.02) * unit(rng) * random_dir();
      const double turn = 0.2 * (unit(rng) - 0.5);
      const BladePose prev = pose(back, tip);
      const BladePose curr =
          pose(back + move, back + move + Eigen::AngleAxisd(turn, Vec3::UnitZ()) * (tip - back));
      fast.sweep(prev, curr, rf);
      brute.sweep(prev, curr, rb);
      check_same(rf, rb);
      CHECK(cut_set(rf) == reference_cuts(m, prev, curr));
      total_cuts += rf.edges.size();
      total_pierces += rf.pierces.size();
      total_candidates += fast.last_candidate_count();
    }
  }
  // The random sweeps exercised the events and the culling.
  CHECK(total_cuts > 1000);
  CHECK(total_pierces > 50);
  CHECK(total_candidates < 400u * m.tet_count() / 4);
}
