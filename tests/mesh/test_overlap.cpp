#include <doctest/doctest.h>

#include <random>

#include "mesh/generators.hpp"
#include "mesh/overlap.hpp"

using namespace scalpel;

namespace {

using Tet = std::array<Vec3, 4>;

const Tet kUnit = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};

Tet moved(const Tet& t, const Vec3& by) {
  Tet out = t;
  for (Vec3& p : out) p += by;
  return out;
}

// Two tetrahedra whose only separating planes are spanned by an edge of each: A's top edge runs
// along x at z = 0 above its bottom edge along y; B's bottom edge runs along y at z = gap, below
// its top edge along x. The edges cross at z = 0 for gap 0.
std::pair<Tet, Tet> crossed_edges(double gap) {
  const Tet a = {Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, -1), Vec3(0, -1, -1)};
  const Tet b = {Vec3(0, -1, gap), Vec3(0, 1, gap), Vec3(1, 0, 1 + gap), Vec3(-1, 0, 1 + gap)};
  return {a, b};
}

// Whether p lies strictly inside t (barycentric coordinates all above a margin).
bool strictly_inside(const Tet& t, const Vec3& p, double margin) {
  Eigen::Matrix3d m;
  for (int k = 0; k < 3; ++k) m.col(k) = t[static_cast<std::size_t>(k + 1)] - t[0];
  const Vec3 l = m.colPivHouseholderQr().solve(p - t[0]);
  return l.minCoeff() > margin && 1.0 - l.sum() > margin;
}

}  // namespace

TEST_CASE("overlap: separated, touching and nested tetrahedra") {
  CHECK_FALSE(tetrahedra_overlap(kUnit, moved(kUnit, Vec3(2, 0, 0))));
  // Touching along a face, an edge, a vertex: no interior point in common.
  CHECK_FALSE(tetrahedra_overlap(kUnit, {Vec3(1, 1, 1), Vec3(1, 0, 0), Vec3(0, 0, 1), Vec3(0, 1, 0)}));
  CHECK_FALSE(tetrahedra_overlap(kUnit, moved(kUnit, Vec3(1, 0, 0))));
  CHECK_FALSE(tetrahedra_overlap(kUnit, moved(kUnit, Vec3(0, 0, 1))));
  // The same tetrahedron, one inside the other, one pushed a little into the other.
  CHECK(tetrahedra_overlap(kUnit, kUnit));
  CHECK(tetrahedra_overlap(
      kUnit, {Vec3(0.1, 0.1, 0.1), Vec3(0.3, 0.1, 0.1), Vec3(0.1, 0.3, 0.1), Vec3(0.1, 0.1, 0.3)}));
  CHECK(tetrahedra_overlap(kUnit, moved(kUnit, Vec3(0.999, 0, 0))));
  // Either orientation.
  const Tet inverted = {kUnit[0], kUnit[2], kUnit[1], kUnit[3]};
  CHECK(tetrahedra_overlap(inverted, moved(kUnit, Vec3(0.5, 0, 0))));
  CHECK_FALSE(tetrahedra_overlap(inverted, moved(kUnit, Vec3(1.5, 0, 0))));
}

TEST_CASE("overlap: tetrahedra that only a plane through an edge of each separates, decided exactly") {
  for (const double gap : {1e-12, 1e-300, 0.0}) {
    const auto [a, b] = crossed_edges(gap);
    CHECK_FALSE(tetrahedra_overlap(a, b));
    CHECK_FALSE(tetrahedra_overlap(b, a));
  }
  for (const double gap : {-1e-12, -1e-300}) {
    const auto [a, b] = crossed_edges(gap);
    CHECK(tetrahedra_overlap(a, b));
    CHECK(tetrahedra_overlap(b, a));
  }
}

TEST_CASE("overlap: random pairs agree with points sampled inside both") {
  // A pair with a sampled point inside both must overlap; a pair the test calls apart must have
  // none. (Apart pairs found to overlap would show up here as sampled points.)
  std::mt19937_64 rng(0x5eed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto random_tet = [&] {
    Tet t;
    for (Vec3& p : t) p = Vec3(u(rng), u(rng), u(rng));
    return t;
  };
  int overlapping = 0, apart = 0;
  for (int pair = 0; pair < 300; ++pair) {
    const Tet a = random_tet(), b = random_tet();
    const bool overlap = tetrahedra_overlap(a, b);
    bool witness = false;
    for (int s = 0; s < 4000 && !witness; ++s) {
      // A random point of a: random barycentric weights.
      double w[4], sum = 0;
      for (double& x : w) sum += (x = -std::log(u(rng)));
      Vec3 p = Vec3::Zero();
      for (std::size_t k = 0; k < 4; ++k) p += w[k] / sum * a[k];
      witness = strictly_inside(b, p, 1e-9);
    }
    if (witness) CHECK(overlap);
    (overlap ? overlapping : apart) += 1;
  }
  // Both outcomes are exercised.
  CHECK(overlapping > 30);
  CHECK(apart > 30);
}

TEST_CASE(
    "overlap: none in a generated box, found in a copy laid over it and in one tetrahedron given twice") {
  const TetMesh box = make_box({.cells = {3, 2, 2}, .split = CubeSplit::Six});
  CHECK(check_overlaps(box).ok());

  // Two boxes side by side, touching along a face: none.
  TetMesh two = make_box({.cells = {2, 2, 2}});
  const TetMesh other = make_box({.cells = {2, 2, 2}});
  const auto copy = [&](const Vec3& by) {
    std::vector<NodeId> map(other.node_capacity());
    for (const NodeId n : other.nodes()) map[n.index] = two.add_node(other.rest(n) + by);
    for (const TetId t : other.tets()) {
      const auto v = other.tet_nodes(t);
      two.add_tet({map[v[0].index], map[v[1].index], map[v[2].index], map[v[3].index]}, 0);
    }
  };
  copy(Vec3(1, 0, 0));
  CHECK(check_overlaps(two).ok());
  // A third copy half a box into the second: many pairs, the first listed in slot order.
  copy(Vec3(1.5, 0, 0));
  const OverlapReport r = check_overlaps(two, 3);
  CHECK(r.pairs > 10);
  REQUIRE(r.first.size() == 3);
  CHECK(r.first[0][0] < r.first[0][1]);
  CHECK(r.summary(two).find(std::to_string(r.pairs) +
                            " pairs of overlapping tetrahedra; first: tetrahedron ") == 0);
}
