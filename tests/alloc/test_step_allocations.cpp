// Heap allocations of a cutter step, and of the tissue taking in the first cut. An executable of its own,
// since it counts every operator new of the process: the cutter's per-step scratch is reused, so a tool
// sample that adds no cut node allocates nothing once that scratch has grown to the size a step needs.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "base/count_allocations.hpp"
#include "cutting/cut_engine.hpp"
#include "fem/tissue.hpp"
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

TEST_CASE("tissue: taking in the first cut moves none of the model's arrays") {
  // The first grow leaves room for the slots cuts add: without it, the first cut reallocated and
  // copied every per-tetrahedron and per-node array of the model in the frame it happened (some
  // thirty allocations; 7.6 ms at 20 thousand tetrahedra).
  const int n = 6;
  const double h = 1e-3;
  TetMesh mesh = make_box({.min = Vec3::Zero(), .max = Vec3::Constant(n * h), .cells = {n, n, n}});
  TissueModel tissue(mesh, {Material{}});
  tissue.step(1e-3);
  CutEngine cutter(mesh);
  const double top = n * h, mid = 3.37 * h;
  cutter.place({Vec3(mid, 0.5 * h, top + 2 * h), Vec3(mid, 0.5 * h, top - 1.5 * h), Vec3::Zero()});
  std::size_t step = 0;
  for (; step < 100 && cutter.changes().added_nodes.empty(); ++step) {
    const double y = (0.5 + 0.05 * static_cast<double>(step + 1)) * h;
    cutter.step({Vec3(mid, y, top + 2 * h), Vec3(mid, y, top - 1.5 * h), Vec3::Zero()});
  }
  const CutChanges& c = cutter.changes();
  REQUIRE(!c.added_nodes.empty());
  const std::size_t before = heap_allocations();
  tissue.on_nodes_added(c.added_nodes, c.added_node_parents);
  tissue.on_tets_removed(c.removed_tets);
  tissue.on_tets_added(c.added_tets);
  const std::size_t allocations = heap_allocations() - before;
  INFO(c.added_nodes.size() << " nodes and " << c.added_tets.size() << " tetrahedra added");
  // What is left is the first growth of the short lists of the hand-over (born and dirty nodes):
  // 7 here. One array of the model more that moves makes it fail.
  CHECK(allocations <= 8);
}
