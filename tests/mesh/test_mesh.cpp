#include <doctest/doctest.h>

#include "mesh/generators.hpp"
#include "mesh/mesh.hpp"
#include "mesh/predicates.hpp"
#include "mesh/topology.hpp"
#include "mesh/validate.hpp"

using namespace scalpel;

namespace {

TetMesh unit_tet() {
  TetMesh m;
  const NodeId a = m.add_node(Vec3(0, 0, 0)), b = m.add_node(Vec3(1, 0, 0)), c = m.add_node(Vec3(0, 1, 0)),
               d = m.add_node(Vec3(0, 0, 1));
  m.add_tet({a, b, c, d});
  return m;
}

}  // namespace

TEST_CASE("orient3d is exact on nearly coplanar points") {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  CHECK(orient3d(a, b, c, Vec3(0.2, 0.3, 1e-300)) == 1);
  CHECK(orient3d(a, b, c, Vec3(0.2, 0.3, -1e-300)) == -1);
  CHECK(orient3d(a, b, c, Vec3(0.2, 0.3, 0.0)) == 0);
  // Points on a line through large coordinates: the float determinant is pure rounding noise.
  const Vec3 p(1e15, 1e15, 1e15);
  CHECK(orient3d(p, p + Vec3(1, 1, 0), p + Vec3(2, 2, 0), p + Vec3(0.5, 0.25, 3)) == 0);
  // Three points collinear in decimal but not as doubles: the float filter cannot decide, and the
  // exact sign must change with the parity of any reordering of the four points.
  const Vec3 q0(0.1, 0.2, 0.3), q1(0.4, 0.5, 0.6), q2(0.7, 0.8, 0.9), q3(0.3, 0.1, 0.7);
  const unsigned long long exact_before = orient3d_exact_fallbacks();
  const int s = orient3d(q0, q1, q2, q3);
  CHECK(orient3d_exact_fallbacks() > exact_before);
  CHECK(orient3d(q1, q0, q2, q3) == -s);
  CHECK(orient3d(q1, q2, q0, q3) == s);
  CHECK(orient3d(q0, q1, q3, q2) == -s);
  CHECK(orient3d(q3, q2, q1, q0) == s);
}

TEST_CASE("handles detect reuse of a freed slot") {
  TetMesh m = unit_tet();
  const TetId t = m.tets().front();
  const auto nodes = m.tet_nodes(t);
  m.remove_tet(t);
  CHECK_FALSE(m.alive(t));
  const TetId t2 = m.add_tet(nodes);
  CHECK(t2.index == t.index);
  CHECK(t2.generation != t.generation);
  CHECK_THROWS((void)m.rest_volume(t));
  CHECK(m.rest_volume(t2) == doctest::Approx(1.0 / 6.0));
}

TEST_CASE("adjacency is linked and unlinked incrementally") {
  TetMesh m = make_box({.cells = {2, 2, 2}, .split = CubeSplit::Five});
  CHECK(m.tet_count() == 40);
  CHECK(validate(m, {.reference_volume = 1.0}).ok());
  const TetId victim = m.tets()[7];
  const auto nodes = m.tet_nodes(victim);
  const int region = m.region(victim);
  m.remove_tet(victim);
  CHECK(validate(m).ok());  // a hole is still a closed surface
  m.add_tet(nodes, region);
  const auto report = validate(m, {.reference_volume = 1.0});
  CHECK_MESSAGE(report.ok(), report.summary());
  CHECK(boundary_faces(m).size() == 2u * 4u * 6u);  // 5-split: two triangles per cube face
}

TEST_CASE("box generators conform and conserve volume") {
  for (const CubeSplit split : {CubeSplit::Five, CubeSplit::Six}) {
    const TetMesh m =
        make_box({.min = Vec3(-1, 0, 0), .max = Vec3(2, 1, 0.5), .cells = {3, 2, 2}, .split = split});
    CHECK(m.tet_count() == 12u * static_cast<unsigned>(split));
    const auto report = validate(m, {.reference_volume = 1.5});
    CHECK_MESSAGE(report.ok(), report.summary());
    CHECK(connected_components(m).count() == 1);
  }
}

TEST_CASE("slab layers become regions from the top down") {
  const TetMesh m = make_slab({.size_x = 0.02,
                               .size_y = 0.01,
                               .cells = {4, 2},
                               .layers = {{"epidermis", 0.001, 1}, {"dermis", 0.002, 2}, {"fat", 0.004, 2}}});
  CHECK(validate(m, {.reference_volume = 0.02 * 0.01 * 0.007}).ok());
  for (const TetId t : m.tets()) {
    double zc = 0;
    for (const NodeId n : m.tet_nodes(t)) zc += m.rest(n).z() / 4;
    const int expected = zc > -0.001 ? 0 : (zc > -0.003 ? 1 : 2);
    CHECK(m.region(t) == expected);
  }
}

TEST_CASE("an incision path goes down, along and up again in steps of the given length") {
  // Lengths exact in binary, so that the counts below do not hang on rounding.
  const Vec3 start(1, 2, 3), along(0, 1, 0);
  const double step = 0.25;
  const std::vector<Vec3> path = incision_path(start, 1.6, along, 2.0, step);
  REQUIRE(path.size() == 20);
  CHECK(path.front() == start);
  // Down from 3 to 1.5 (the first height not above 1.6), 2 along, up to 2.75 (below the start).
  std::size_t down = 0, across = 0, up = 0;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const Vec3 d = path[i] - path[i - 1];
    CHECK(d.norm() == step);
    (d.z() < 0 ? down : d.z() > 0 ? up : across) += 1;
  }
  CHECK(down == 6);
  CHECK(across == 8);
  CHECK(up == 5);
  CHECK(path.back() == Vec3(1, 4, 2.75));
}

TEST_CASE("validate names the broken invariant and element") {
  SUBCASE("inverted tetrahedron") {
    TetMesh m;
    const NodeId a = m.add_node(Vec3(0, 0, 0)), b = m.add_node(Vec3(1, 0, 0)), c = m.add_node(Vec3(0, 1, 0)),
                 d = m.add_node(Vec3(0, 0, 1));
    m.add_tet({a, c, b, d});
    const auto r = validate(m);
    REQUIRE_FALSE(r.ok());
    CHECK(r.violations[0].invariant == Invariant::Oriented);
    CHECK(r.summary().find("tet 0") != std::string::npos);
  }
  SUBCASE("hanging node on a face") {
    // Two tets glued along a face, one of them split into three at an interior point of that face:
    // the other side does not follow, so the split node hangs.
    TetMesh m;
    const NodeId a = m.add_node(Vec3(0, 0, 0)), b = m.add_node(Vec3(1, 0, 0)), c = m.add_node(Vec3(0, 1, 0)),
                 top = m.add_node(Vec3(0, 0, 1)), bottom = m.add_node(Vec3(0.2, 0.2, -1));
    const NodeId mid = m.add_node(Vec3(1.0 / 3, 1.0 / 3, 0));
    m.add_tet({a, b, c, top});
    m.add_tet({a, mid, b, bottom});
    m.add_tet({b, mid, c, bottom});
    m.add_tet({c, mid, a, bottom});
    const auto r = validate(m);
    CHECK_FALSE(r.passed[2]);
    CHECK(r.summary().find("hanging node") != std::string::npos);
  }
  SUBCASE("hanging node on an edge") {
    // The lower tet split in two at the middle of an edge of the shared face.
    TetMesh m;
    const NodeId a = m.add_node(Vec3(0, 0, 0)), b = m.add_node(Vec3(1, 0, 0)), c = m.add_node(Vec3(0, 1, 0)),
                 top = m.add_node(Vec3(0, 0, 1)), bottom = m.add_node(Vec3(0.2, 0.2, -1));
    const NodeId mid = m.add_node(Vec3(0.5, 0, 0));
    m.add_tet({a, b, c, top});
    m.add_tet({a, mid, c, bottom});
    m.add_tet({mid, b, c, bottom});
    const auto r = validate(m);
    CHECK_FALSE(r.passed[2]);
    CHECK(r.summary().find("hanging node") != std::string::npos);
  }
  SUBCASE("one side of a crack split up to the crack's front is no hanging node") {
    // The same shape, but the sides are apart (copies b2, c2 of b, c) except at node a, the front
    // of the crack between them: a later cut may split one side only (paper section 6).
    TetMesh m;
    const NodeId a = m.add_node(Vec3(0, 0, 0)), b = m.add_node(Vec3(1, 0, 0)), c = m.add_node(Vec3(0, 1, 0)),
                 top = m.add_node(Vec3(0, 0, 1)), bottom = m.add_node(Vec3(0.2, 0.2, -1));
    const NodeId b2 = m.add_node(Vec3(1, 0, 0)), c2 = m.add_node(Vec3(0, 1, 0)),
                 mid = m.add_node(Vec3(0.5, 0, 0));
    m.add_tet({a, b, c, top});
    m.add_tet({a, mid, c2, bottom});
    m.add_tet({mid, b2, c2, bottom});
    const auto r = validate(m);
    CHECK_MESSAGE(r.passed[2], r.summary());
  }
  SUBCASE("the hanging-node search copes with faces of any size and position") {
    // A box of micrometre cells beside a tetrahedron ten metres wide, and one at 1e300 m: a search
    // in cells of the mean face size (about a centimetre here) visited 1e8 cells for the large face,
    // and cast a coordinate over the cell size to an integer.
    TetMesh m = make_box({.max = Vec3(1e-5, 1e-5, 1e-5), .cells = {16, 16, 16}});
    const auto far_tet = [&](double at, double size) {
      const NodeId a = m.add_node(Vec3(at, 0, 0)), b = m.add_node(Vec3(at + size, 0, 0)),
                   c = m.add_node(Vec3(at, size, 0)), d = m.add_node(Vec3(at, 0, size));
      m.add_tet({a, b, c, d});
    };
    far_tet(1.0, 10.0);
    const auto r = validate(m);
    CHECK_MESSAGE(r.passed[2], r.summary());
    CHECK(r.passed[3]);
    far_tet(1e300, 1e290);
    CHECK(validate(m).passed[2]);
  }
  SUBCASE("lost volume") {
    TetMesh m = make_box({});
    m.remove_tet(m.tets().front());
    const auto r = validate(m, {.reference_volume = 1.0});
    CHECK_FALSE(r.passed[4]);
    CHECK(r.passed[3]);
  }
}

TEST_CASE("validate_local checks the neighbourhood of a change") {
  SUBCASE("a valid local change passes") {
    TetMesh m = make_box({.cells = {3, 3, 3}});
    const TetId t = m.tets()[40];
    const auto n = m.tet_nodes(t);
    // Split the tetrahedron at its centroid into four.
    const NodeId c = m.add_node((m.rest(n[0]) + m.rest(n[1]) + m.rest(n[2]) + m.rest(n[3])) / 4);
    m.remove_tet(t);
    for (int f = 0; f < 4; ++f) {
      auto v = n;
      v[static_cast<size_t>(f)] = c;
      m.add_tet(v);
    }
    const std::vector<std::uint32_t> touched{n[0].index, n[1].index, n[2].index, n[3].index, c.index};
    const auto r = validate_local(m, touched, {.reference_volume = 1.0});
    CHECK_MESSAGE(r.ok(), r.summary());
  }
  SUBCASE("a hanging node next to the change is found") {
    TetMesh m;
    const NodeId a = m.add_node(Vec3(0, 0, 0)), b = m.add_node(Vec3(1, 0, 0)), c = m.add_node(Vec3(0, 1, 0)),
                 top = m.add_node(Vec3(0, 0, 1)), bottom = m.add_node(Vec3(0.2, 0.2, -1));
    m.add_tet({a, b, c, top});
    const NodeId mid = m.add_node(Vec3(1.0 / 3, 1.0 / 3, 0));
    m.add_tet({a, mid, b, bottom});
    m.add_tet({b, mid, c, bottom});
    m.add_tet({c, mid, a, bottom});
    const std::vector<std::uint32_t> touched{mid.index, bottom.index};
    const auto r = validate_local(m, touched);
    CHECK_FALSE(r.passed[2]);
  }
  SUBCASE("an inverted element and an open surface are found") {
    TetMesh m = make_box({.cells = {2, 2, 2}});
    const TetId t = m.tets()[5];
    auto n = m.tet_nodes(t);
    m.remove_tet(t);
    std::swap(n[0], n[1]);
    m.add_tet(n);
    const std::vector<std::uint32_t> touched{n[0].index};
    const auto r = validate_local(m, touched, {.reference_volume = 1.0});
    CHECK_FALSE(r.passed[1]);
    CHECK_FALSE(r.passed[2]);  // the flipped element's faces no longer match their neighbours
    CHECK_FALSE(r.passed[4]);
  }
}

TEST_CASE("node pieces: tetrahedra joined by a shared vertex are one piece, apart they are two") {
  TetMesh m;
  const NodeId o = m.add_node(Vec3(0, 0, 0));
  const NodeId a = m.add_node(Vec3(1, 0, 0)), b = m.add_node(Vec3(0, 1, 0)), c = m.add_node(Vec3(0, 0, 1));
  const NodeId d = m.add_node(Vec3(-1, 0, 0)), e = m.add_node(Vec3(0, -1, 0)), f = m.add_node(Vec3(0, 0, -1));
  const NodeId lone = m.add_node(Vec3(5, 5, 5));
  (void)m.add_tet({o, a, b, c});
  const TetId second = m.add_tet({o, d, f, e});  // meets the first at o only
  REQUIRE(m.rest_volume(second) > 0);
  auto piece = node_pieces(m);
  CHECK(piece[a.index] == piece[o.index]);
  CHECK(piece[d.index] == piece[a.index]);  // through the shared vertex
  CHECK(piece[lone.index] == lone.index);
  CHECK(connected_components(m).count() == 2);  // by faces they are apart
  // Without the shared vertex, two pieces.
  m.remove_tet(second);
  const NodeId o2 = m.add_node(Vec3(0, 0, 0));
  (void)m.add_tet({o2, d, f, e});
  piece = node_pieces(m);
  CHECK(piece[d.index] != piece[a.index]);
  CHECK(piece[d.index] == piece[o2.index]);
}
