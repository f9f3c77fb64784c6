// Heap allocations of a cutter step. An executable of its own, since it counts every operator new
// of the process: the cutter's per-step scratch is reused, so a tool sample that adds no cut node
// allocates nothing once that scratch has grown to the size a step needs.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "base/count_allocations.hpp"
#include "cutting/cut_engine.hpp"
#include "mesh/generators.hpp"

using namespace scalpel;

TEST_CASE("cutter step: 19 in 20 samples that add no cut node allocate nothing, the scratch reused") {
#ifdef SCALPEL_VALIDATE
  // The invariant checks after every step allocate their reports.
  MESSAGE("skipped: a VALIDATE build checks the mesh after every step");
#else
  // A 10-thousand-tetrahedron box (1 mm cells); a blade three cells long, tilted 30 degrees, enters
  // the top face, draws an incision twelve cells long at 0.01 mm per sample and lifts out.
  const int n = 12;
  const double h = 1e-3;
  TetMesh mesh = make_box({.min = Vec3::Zero(), .max = Vec3::Constant(n * h), .cells = {n, n, n}});
  CutEngine cutter(mesh);
  const double top = n * h, mid = std::floor(n / 2.0) * h;
  const Vec3 along(1, 0, 0);
  const Vec3 back_offset = (-std::sin(0.5236) * along + Vec3(0, 0, std::cos(0.5236))) * (3 * h);
  const std::vector<Vec3> path =
      incision_path(Vec3(mid - 5.79 * h, mid + 0.37 * h, top + 0.5 * h), top - 1.3 * h, along, 12 * h, 1e-5);

  cutter.place({path.front() + back_offset, path.front(), Vec3::Zero()});
  std::size_t quiet = 0, quiet_allocating = 0;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const BladePose pose{path[i] + back_offset, path[i], Vec3::Zero()};
    const std::size_t before = heap_allocations();
    const CutStepStats stats = cutter.step(pose);
    const std::size_t allocations = heap_allocations() - before;
    if (stats.nodes_created != 0 || i < 200) continue;  // the first samples grow the scratch
    ++quiet;
    if (allocations > 0) ++quiet_allocating;
  }
  INFO(quiet_allocating << " of " << quiet << " samples that added no node allocated");
  CHECK(cutter.totals().edges_cut > 50);
  CHECK(quiet > 1000);
  // A sample allocates where one of the scratch buffers meets a step larger than any before.
  CHECK(quiet_allocating * 20 < quiet);
#endif
}
