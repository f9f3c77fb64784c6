// The surface probe's boxes (sim/surface_probe.hpp): queries in fitted positions find the same
// triangle, depth and point as a test of every triangle, on a deformed and a cut-open surface; boxes
// the positions moved away from are detected.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

#include "mesh/generators.hpp"
#include "sim/surface_probe.hpp"

using namespace scalpel;

namespace {

// A 3 x 2 cm patch 5 mm thick, bent into a hump and twisted, so that its surface triangles lean every
// way and their boxes overlap.
TetMesh bent_patch() {
  BoxSpec spec;
  spec.min = Vec3(0, 0, 0);
  spec.max = Vec3(0.03, 0.02, 0.005);
  spec.cells = {12, 8, 3};
  TetMesh mesh = make_box(spec);
  for (const NodeId n : mesh.nodes()) {
    Vec3& x = mesh.positions()[n.index];
    const Vec3 r = mesh.rest(n);
    x.z() += 0.004 * std::sin(M_PI * r.x() / 0.03) * std::cos(M_PI * r.y() / 0.04);
    x.y() += 0.1 * (r.z() - 0.0025) * (r.x() - 0.015) / 0.03;
  }
  return mesh;
}

// The same query in the fitted positions (boxes) and in a copy of them (every triangle).
void check_same(const SurfaceProbe& probe, const TetMesh& mesh, std::mt19937& rng, int queries, int& hits) {
  const std::vector<Vec3>& fitted = mesh.positions();
  const std::vector<Vec3> copy = fitted;
  std::uniform_real_distribution<double> ux(-0.005, 0.035), uy(-0.005, 0.025), uz(-0.006, 0.012),
      lean(-1.0, 1.0);
  for (int q = 0; q < queries; ++q) {
    const Vec3 p(ux(rng), uy(rng), uz(rng));
    const Vec3 up = Vec3(0.6 * lean(rng), 0.6 * lean(rng), 1.0) * (q % 7 == 0 ? -1.0 : 1.0);
    const Vec3 back = p + 0.02 * up.normalized();
    const SurfaceHit a = probe.nearest(fitted, p, up), b = probe.nearest(copy, p, up);
    CHECK(a.face == b.face);
    CHECK(a.depth == b.depth);
    CHECK(a.point == b.point);
    hits += a.depth > 0 ? 1 : 0;
    const auto ra = probe.nearest(mesh.rest_positions(), p, up);
    const std::vector<Vec3> rest_copy = mesh.rest_positions();
    CHECK(ra.face == probe.nearest(rest_copy, p, up).face);
    const auto da = probe.deepest_in_tissue(fitted, p, back), db = probe.deepest_in_tissue(copy, p, back);
    REQUIRE(da.has_value() == db.has_value());
    if (da) CHECK(*da == *db);
    const auto ea = probe.entry(fitted, back, p), eb = probe.entry(copy, back, p);
    REQUIRE(ea.has_value() == eb.has_value());
    if (ea) {
      CHECK(ea->face == eb->face);
      CHECK(ea->depth == eb->depth);
    }
    const auto aa = probe.above(fitted, p, back), ab = probe.above(copy, p, back);
    REQUIRE(aa.has_value() == ab.has_value());
    if (aa) CHECK(aa->point == ab->point);
  }
}

}  // namespace

TEST_CASE("surface probe: queries in fitted positions find what a test of every triangle finds") {
  TetMesh mesh = bent_patch();
  SurfaceProbe probe(mesh);
  probe.fit(mesh);
  CHECK_FALSE(probe.stale(mesh.positions()));
  std::mt19937 rng(7);
  int hits = 0;
  check_same(probe, mesh, rng, 2000, hits);
  CHECK(hits > 1000);

  // The tissue moves and the probe is fitted again.
  for (Vec3& x : mesh.positions()) x += Vec3(0.001, -0.0005, 0.002);
  CHECK(probe.stale(mesh.positions()));
  probe.fit(mesh);
  CHECK_FALSE(probe.stale(mesh.positions()));
  check_same(probe, mesh, rng, 500, hits);

  // Triangles forgotten with a deleted piece: every triangle is tested until the next fit.
  std::vector<std::uint32_t> removed;
  for (const NodeId n : mesh.nodes())
    if (mesh.rest(n).x() < 0.006) removed.push_back(n.index);
  probe.drop_faces_of(removed);
  check_same(probe, mesh, rng, 200, hits);
  probe.fit(mesh);
  check_same(probe, mesh, rng, 500, hits);
}

TEST_CASE("surface probe: ties between triangles go to the first in order, with boxes as without") {
  // At rest the patch is flat: rays straight down through its grid's vertices and edges (every other
  // point here) meet two to six triangles at exactly the same distance, and points above them are as
  // near to all of them.
  TetMesh mesh = bent_patch();
  mesh.positions() = mesh.rest_positions();
  SurfaceProbe probe(mesh);
  probe.fit(mesh);
  const std::vector<Vec3> copy = mesh.positions();
  for (int i = 0; i <= 24; ++i)
    for (int j = 0; j <= 16; ++j) {
      const Vec3 p(0.00125 * i, 0.00125 * j, 0.01), down(p.x(), p.y(), -0.01);
      const auto a = probe.entry(mesh.positions(), p, down), b = probe.entry(copy, p, down);
      REQUIRE(a.has_value() == b.has_value());
      REQUIRE(a);
      CHECK(a->face == b->face);
      const auto c = probe.above(mesh.positions(), down, p), d = probe.above(copy, down, p);
      REQUIRE(c.has_value() == d.has_value());
      if (c) CHECK(c->point == d->point);
      const SurfaceHit n = probe.nearest(mesh.positions(), p, Vec3(0, 0, 1));
      CHECK(n.face == probe.nearest(copy, p, Vec3(0, 0, 1)).face);
    }
}

TEST_CASE("surface probe: boxes the positions moved away from miss the surface, and are detected") {
  TetMesh mesh = bent_patch();
  SurfaceProbe probe(mesh);
  probe.fit(mesh);
  // Lifted by 5 cm without a new fit: a ray up from under the lifted patch meets none of the old
  // boxes, while the same ray tested on every triangle meets its underside.
  for (Vec3& x : mesh.positions()) x.z() += 0.05;
  const Vec3 from(0.0151, 0.0101, 0.04), to(0.0151, 0.0101, 0.07);
  const std::vector<Vec3> copy = mesh.positions();
  CHECK(probe.entry(copy, from, to));
  CHECK_FALSE(probe.entry(mesh.positions(), from, to));
  CHECK(probe.stale(mesh.positions()));
  probe.fit(mesh);
  CHECK(probe.entry(mesh.positions(), from, to));
}
