// Collision step cost (docs/state_machine.md: O(elements near the blade), never O(mesh)).
//
// Boxes of 10 cm with about 10k, 100k and 1M tetrahedra (6 per cube); a 2.3 cm oblique blade makes
// one 1 ms step at 0.1 m/s (0.1 mm). Also: refit after deformation, full rebuild, the remove +
// insert of one tetrahedron the cutter does per subdivision, and the point location of the tool's
// contact (CutEngine::locate) along a blade that has cut 10 mm, and the score's probe of the surface
// above the blade at every sample (sim/surface_probe.hpp), with and without its boxes.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>

#include "cutting/blade_sweep.hpp"
#include "cutting/cut_engine.hpp"
#include "mesh/generators.hpp"
#include "sim/surface_probe.hpp"

using namespace scalpel;

namespace {

// Cubes per side for ~10k, ~100k, ~1M tetrahedra.
TetMesh& box_mesh(int cells) {
  static std::map<int, std::unique_ptr<TetMesh>> cache;
  auto& m = cache[cells];
  if (!m) {
    m = std::make_unique<TetMesh>(
        make_box({Vec3::Zero(), Vec3::Constant(0.1), {cells, cells, cells}, CubeSplit::Six, 0}));
  }
  return *m;
}

BladePose blade(double y) {
  BladePose p;
  p.back = Vec3(0.040, y, 0.030);  // [m]
  p.tip = Vec3(0.055, y + 0.005, 0.047);
  return p;
}

void BM_Sweep(benchmark::State& state) {
  TetMesh& m = box_mesh(static_cast<int>(state.range(0)));
  BladeSweep sweep(m);
  SweepResult r;
  // A 0.1 mm step [m]; y = 0.05 lies on a grid plane of every box: exact fallbacks on every node.
  const double y = state.range(1) != 0 ? 0.0500 : 0.0503;
  const BladePose prev = blade(y), curr = blade(y + 1e-4);
  for (auto _ : state) {
    sweep.sweep(prev, curr, r);
    benchmark::DoNotOptimize(r.edges.data());
  }
  state.counters["tets"] = static_cast<double>(m.tet_count());
  state.counters["candidates"] = static_cast<double>(sweep.last_candidate_count());
  state.counters["touched"] = static_cast<double>(r.tets.size());
  state.counters["edge_cuts"] = static_cast<double>(r.edges.size());
}

void BM_SweepBruteForce(benchmark::State& state) {
  TetMesh& m = box_mesh(static_cast<int>(state.range(0)));
  BladeSweep::Options o;
  o.use_tree = false;
  BladeSweep sweep(m, o);
  SweepResult r;
  const BladePose prev = blade(0.0503), curr = blade(0.0504);
  for (auto _ : state) {
    sweep.sweep(prev, curr, r);
    benchmark::DoNotOptimize(r.edges.data());
  }
  state.counters["tets"] = static_cast<double>(m.tet_count());
}

// Deformation inside the fat margins: every leaf is checked, none moves.
void BM_RefitSmall(benchmark::State& state) {
  TetMesh& m = box_mesh(static_cast<int>(state.range(0)));
  BladeSweep sweep(m);
  const std::vector<Vec3> rest = m.positions();
  const double h = 0.1 / static_cast<double>(state.range(0));
  int k = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const double a = (k++ % 2 == 0 ? 0.02 : -0.02) * h;  // 2% of a cell [m]
    for (std::size_t n = 0; n < rest.size(); ++n)
      m.positions()[n] = rest[n] + Vec3(a * std::sin(50 * rest[n].y()), 0, 0);
    state.ResumeTiming();
    benchmark::DoNotOptimize(sweep.refit());
  }
  m.positions() = rest;
  state.counters["tets"] = static_cast<double>(m.tet_count());
}

// Deformation beyond the fat margins: every leaf gets a new box and its ancestors are recomputed.
void BM_RefitLarge(benchmark::State& state) {
  TetMesh& m = box_mesh(static_cast<int>(state.range(0)));
  BladeSweep sweep(m);
  const std::vector<Vec3> rest = m.positions();
  const double h = 0.1 / static_cast<double>(state.range(0));
  int k = 0;
  std::size_t moved = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const double a = (k++ % 2 == 0 ? 0.5 : -0.5) * h;  // half a cell [m]
    for (std::size_t n = 0; n < rest.size(); ++n)
      m.positions()[n] = rest[n] + Vec3(a * std::sin(50 * rest[n].y()), 0, 0);
    state.ResumeTiming();
    moved = sweep.refit();
  }
  m.positions() = rest;
  state.counters["tets"] = static_cast<double>(m.tet_count());
  state.counters["moved"] = static_cast<double>(moved);
}

void BM_Rebuild(benchmark::State& state) {
  TetMesh& m = box_mesh(static_cast<int>(state.range(0)));
  BladeSweep sweep(m);
  for (auto _ : state) sweep.rebuild();
  state.counters["tets"] = static_cast<double>(m.tet_count());
}

// One leaf removed and inserted again: what each tetrahedron the cutter replaces costs.
void BM_RemoveInsert(benchmark::State& state) {
  TetMesh& m = box_mesh(static_cast<int>(state.range(0)));
  BladeSweep sweep(m);
  std::uint32_t t = 0;
  const auto n = static_cast<std::uint32_t>(m.tet_capacity());
  for (auto _ : state) {
    sweep.on_tet_removed(t);
    sweep.on_tet_added(t);
    t = (t + 7919) % n;
  }
  state.counters["tets"] = static_cast<double>(m.tet_count());
  state.counters["height"] = sweep.tree().height();
}

// The simulation's contact query per frame (sim/simulation.hpp): points 0.1 mm apart along the
// blade's edge, after the blade has cut 10 mm through the box: they lie in the tetrahedra it cuts.
void BM_LocateAlongBlade(benchmark::State& state) {
  TetMesh m = box_mesh(static_cast<int>(state.range(0)));  // a copy: the cutter edits it
  CutEngine cutter(m);
  cutter.place(blade(0.0403));
  for (int k = 1; k <= 100; ++k) cutter.step(blade(0.0403 + 1e-4 * k));
  const BladePose now = blade(0.0503);
  const int points = static_cast<int>(std::ceil((now.tip - now.back).norm() / 1e-4));
  int found = 0;
  for (auto _ : state) {
    found = 0;
    for (int k = 0; k < points; ++k)
      found += cutter.locate(now.back + (k + 0.5) / points * (now.tip - now.back), 2e-4).has_value() ? 1 : 0;
  }
  state.SetItemsProcessed(state.iterations() * points);
  state.counters["tets"] = static_cast<double>(m.tet_count());
  state.counters["points"] = points;
  state.counters["in_tissue"] = found;
}

// What Simulation::on_sample asks of the surface at a sample in the tissue: the blade's deepest
// point, the nearest skin above it now and at rest; an incision 3 mm deep in the box's top. fitted = 0:
// positions the probe has no boxes for (every triangle is tested, as before the boxes).
void BM_SurfaceProbe(benchmark::State& state) {
  const TetMesh& m = box_mesh(static_cast<int>(state.range(0)));
  SurfaceProbe probe(m);
  probe.fit(m);
  const std::vector<Vec3> unfitted = m.positions();
  const std::vector<Vec3>& x = state.range(1) != 0 ? m.positions() : unfitted;
  BladePose b;
  b.tip = Vec3(0.0503, 0.0497, 0.097);
  b.back = b.tip + Vec3(0.012, 0.004, 0.02);
  const Vec3 up = b.back - b.tip;
  double depth = 0;
  for (auto _ : state) {
    const auto deepest = probe.deepest_in_tissue(x, b.tip, b.back);
    depth = probe.nearest(x, *deepest, up).depth + probe.nearest(m.rest_positions(), *deepest, up).depth;
    benchmark::DoNotOptimize(depth);
  }
  state.counters["depth_mm"] = 1e3 * depth / 2;
}

// The probe's refit after the tissue moved: once a frame (Simulation::update_bounds).
void BM_SurfaceProbeFit(benchmark::State& state) {
  const TetMesh& m = box_mesh(static_cast<int>(state.range(0)));
  SurfaceProbe probe(m);
  probe.fit(m);
  for (auto _ : state) probe.fit(m);
}

}  // namespace

BENCHMARK(BM_Sweep)
    ->ArgNames({"cells", "on_grid_plane"})
    ->Args({12, 0})
    ->Args({26, 0})
    ->Args({55, 0})
    ->Args({12, 1})
    ->Args({55, 1})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SweepBruteForce)->Arg(12)->Arg(26)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RefitSmall)->Arg(12)->Arg(26)->Arg(55)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RefitLarge)->Arg(12)->Arg(26)->Arg(55)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Rebuild)->Arg(12)->Arg(26)->Arg(55)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RemoveInsert)->Arg(12)->Arg(26)->Arg(55)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LocateAlongBlade)->Arg(12)->Arg(26)->Arg(55)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SurfaceProbe)
    ->ArgNames({"cells", "fitted"})
    ->Args({12, 0})
    ->Args({12, 1})
    ->Args({26, 0})
    ->Args({26, 1})
    ->Args({55, 0})
    ->Args({55, 1})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SurfaceProbeFit)->Arg(12)->Arg(26)->Arg(55)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
