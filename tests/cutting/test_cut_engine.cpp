#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

#include "cutting/cut_engine.hpp"
#include "cutting/generators.hpp"
#include "cutting/topology.hpp"
#include "cutting/validate.hpp"

using namespace scalpel;

namespace {

// A vertical blade at x = `x`, from z = 1.5 (back) down to z = -0.5 (tip), at y.
BladePose vertical_blade(double x, double y) { return {Vec3(x, y, 1.5), Vec3(x, y, -0.5), Vec3::Zero()}; }

void require_valid(const TetMesh& m, double volume) {
  const auto r = validate(m, {.reference_volume = volume});
  REQUIRE_MESSAGE(r.ok(), r.summary());
}

}  // namespace

TEST_CASE("a planar through-cut separates a box into two exact halves") {
  for (const CubeSplit split : {CubeSplit::Six, CubeSplit::Five}) {
    CAPTURE(static_cast<int>(split));
    TetMesh mesh = make_box({.cells = {4, 4, 4}, .split = split});
    CutEngine cutter(mesh);
    const double x = 0.37;
    cutter.place(vertical_blade(x, -0.5));
    for (int k = 1; k <= 200; ++k) {
      cutter.step(vertical_blade(x, -0.5 + 0.01 * k));
      require_valid(mesh, 1.0);
    }
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
