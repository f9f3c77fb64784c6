#include <doctest/doctest.h>

#include "mesh/generators.hpp"
#include "mesh/manifold.hpp"

using namespace scalpel;

namespace {

// Two positively oriented unit tetrahedra; the second is the first moved by `shift` and sharing
// the first's vertices given in `shared` (its local vertex -> the first's node).
TetMesh two_tets(const Vec3& shift, const std::vector<std::pair<int, int>>& shared) {
  TetMesh m;
  const Vec3 corner[4] = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  std::array<NodeId, 4> a{}, b{};
  for (int i = 0; i < 4; ++i) a[static_cast<std::size_t>(i)] = m.add_node(corner[i]);
  for (int i = 0; i < 4; ++i) {
    NodeId n;
    for (const auto& [mine, theirs] : shared)
      if (mine == i) n = a[static_cast<std::size_t>(theirs)];
    b[static_cast<std::size_t>(i)] = n.is_null() ? m.add_node(corner[i] + shift) : n;
  }
  m.add_tet(a, 0);
  m.add_tet(b, 0);
  return m;
}

}  // namespace

TEST_CASE("manifold: a generated box is a manifold") {
  for (const CubeSplit split : {CubeSplit::Five, CubeSplit::Six}) {
    const TetMesh m = make_box({.cells = {3, 2, 2}, .split = split});
    CHECK(check_manifold(m).ok());
  }
}

TEST_CASE("manifold: tetrahedra meeting at a vertex or along an edge only are a bow-tie") {
  SUBCASE("at a vertex") {
    // The second tetrahedron's vertex 0 is the first's vertex 3, the rest above it.
    const TetMesh m = two_tets(Vec3(0, 0, 1), {{0, 3}});
    const ManifoldReport r = check_manifold(m);
    REQUIRE(r.pinched_vertices.size() == 1);
    CHECK(r.pinched_vertices[0] == 3);
    CHECK(r.pinched_edges.empty());
    CHECK(r.summary(m).find("1 vertices and 0 edges") == 0);
    CHECK(r.summary(m).find("node 3 at (0, 0, 1)") != std::string::npos);
  }
  SUBCASE("along an edge") {
    // The first turned half a turn about its edge from (0, 0, 0) to (0, 0, 1).
    TetMesh m;
    const NodeId o = m.add_node(Vec3(0, 0, 0)), x = m.add_node(Vec3(1, 0, 0)), y = m.add_node(Vec3(0, 1, 0)),
                 z = m.add_node(Vec3(0, 0, 1)), mx = m.add_node(Vec3(-1, 0, 0)),
                 my = m.add_node(Vec3(0, -1, 0));
    m.add_tet({o, x, y, z}, 0);
    m.add_tet({o, mx, my, z}, 0);
    const ManifoldReport r = check_manifold(m);
    REQUIRE(r.pinched_edges.size() == 1);
    CHECK(r.pinched_edges[0] == std::array<std::uint32_t, 2>{o.index, z.index});
    CHECK(r.pinched_vertices.size() == 2);  // each end of the edge, too
  }
  SUBCASE("through a face: a manifold") {
    // The mirror image of the first through its face (1, 2, 3) shares that face.
    TetMesh m;
    const NodeId o = m.add_node(Vec3(0, 0, 0)), x = m.add_node(Vec3(1, 0, 0)), y = m.add_node(Vec3(0, 1, 0)),
                 z = m.add_node(Vec3(0, 0, 1)), far = m.add_node(Vec3(1, 1, 1));
    m.add_tet({o, x, y, z}, 0);
    m.add_tet({far, x, z, y}, 0);
    CHECK(check_manifold(m).ok());
  }
}
