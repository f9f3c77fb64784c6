// Tissue step speed (docs/tissue.md): step time, CG iterations and final relative residual of the
// co-rotational and mass-spring models on a prestressed three-layer skin slab, and the step right
// after an incision compared with the steps before it, with the two-level preconditioner (the
// default) and with block-Jacobi alone.
//
//   ./build/release/bench/bench_fem
//   ./build/release/bench/bench_fem --benchmark_filter='BM_TissueStep/24/0/[12]/'   # 1 and 2 threads
//   ./build/release/bench/bench_fem --benchmark_filter=AfterCut   # medians of 5 repetitions
//   ./build/release/bench/bench_fem --benchmark_filter=Progressive
//   ./build/release/bench/bench_fem --benchmark_filter=CoarseFactorisation
//   ./build/release/bench/bench_fem --benchmark_filter=CorotationalRow   # the assembly's kernel
//   ./build/release/bench/bench_fem --benchmark_filter=CorotationalElements   # four elements at once
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>

#include "fem/block_cholesky.hpp"
#include "fem/row_kernel.hpp"
#include "fem/tissue.hpp"
#include "mesh/generators.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"

using namespace scalpel;

namespace {

constexpr double kDt = 1.0 / 60;  // [s] the visual rate of the simulation thread

struct Scene {
  TetMesh mesh;
  std::unique_ptr<TissueModel> model;
};

// A 4 cm x 4 cm slab, 1 cm deep, cells x cells x 6 cubes of 6 tetrahedra.
std::unique_ptr<Scene> make_scene(int cells, TissueKind kind, double tolerance, int settle_steps,
                                  Preconditioner pre = Preconditioner::TwoLevel,
                                  TwoLevelOptions two_level = {}) {
  auto s = std::make_unique<Scene>();
  s->mesh = make_slab({.size_x = 0.04,
                       .size_y = 0.04,
                       .cells = {cells, cells},
                       .layers = {{"epidermis", 0.002, 2}, {"dermis", 0.003, 2}, {"fat", 0.005, 2}}});
  std::vector<Material> mats(3);
  mats[0].young = 100e3;
  mats[1].young = 50e3;
  mats[2].young = 10e3;
  for (Material& m : mats) m.prestress = 1.1;
  s->model = std::make_unique<TissueModel>(s->mesh, mats,
                                           TissueSettings{.kind = kind,
                                                          .tolerance = tolerance,
                                                          .max_iterations = 200,
                                                          .preconditioner = pre,
                                                          .two_level = two_level});
  for (const NodeId n : s->mesh.nodes()) {
    const Vec3& x = s->mesh.rest(n);
    if (std::abs(std::abs(x.x()) - 0.02) < 1e-12 || std::abs(std::abs(x.y()) - 0.02) < 1e-12 ||
        std::abs(x.z() + 0.01) < 1e-12)
      s->model->set_fixed(n);
  }
  for (int k = 0; k < settle_steps; ++k) (void)s->model->step(kDt);  // settle under gravity and prestress
  return s;
}

// An incision through the top layer along the node plane nearest x = 0 (|y| < half_length): the
// nodes on it are duplicated and the tetrahedra on the +x side re-pointed, as a cut leaves them.
void cut(Scene& s, double half_length) {
  TetMesh& m = s.mesh;
  double plane = 1e9;
  for (const NodeId n : m.nodes())
    if (std::abs(m.rest(n).x()) < std::abs(plane)) plane = m.rest(n).x();
  std::map<NodeId, NodeId> dup;
  std::vector<NodeId> nodes;
  std::vector<NodeParents> parents;
  for (const NodeId n : m.nodes()) {
    const Vec3& x = m.rest(n);
    if (std::abs(x.x() - plane) < 1e-12 && std::abs(x.y()) < half_length && x.z() > -0.002 + 1e-12) {
      NodeParents p;
      p.parents = {n, NodeId{}, NodeId{}};
      p.weights = {1.0, 0.0, 0.0};
      p.count = 1;
      dup[n] = m.add_interpolated_node(p);
      nodes.push_back(dup[n]);
      parents.push_back(p);
    }
  }
  std::vector<std::uint32_t> removed;
  std::vector<TetId> added;
  for (const TetId t : m.tets()) {
    auto v = m.tet_nodes(t);
    double cx = 0;
    bool touches = false;
    for (const NodeId n : v) {
      cx += m.rest(n).x() / 4;
      touches = touches || dup.count(n) > 0;
    }
    if (!touches || cx < plane) continue;
    for (NodeId& n : v)
      if (dup.count(n)) n = dup[n];
    const int region = m.region(t);
    const std::uint32_t parent = m.parent(t);
    m.remove_tet(t);
    removed.push_back(t.index);
    const TetId c = m.add_tet(v, region);
    m.set_parent(c, parent);
    added.push_back(c);
  }
  s.model->on_nodes_added(nodes, parents);
  s.model->on_tets_removed(removed);
  s.model->on_tets_added(added);
}

TissueKind kind_of(const benchmark::State& state) {
  return state.range(1) == 0 ? TissueKind::Corotational : TissueKind::MassSpring;
}

// The settled step; third argument: the tissue's threads (TissueSettings::threads), for the
// parallel efficiency T(1) / (n T(n)).
void BM_TissueStep(benchmark::State& state) {
  auto s = make_scene(static_cast<int>(state.range(0)), kind_of(state), 1e-3, 30);
  s->model->settings().threads = static_cast<int>(state.range(2));
  double iterations = 0, residual = 0, steps = 0;
  double phase[4] = {0, 0, 0, 0};
  for (auto _ : state) {
    const StepStats st = s->model->step(kDt);
    phase[0] += st.seconds.elements;
    phase[1] += st.seconds.assembly;
    phase[2] += st.seconds.local;
    phase[3] += st.seconds.solve;
    iterations += st.cg_iterations;
    residual = std::max(residual, st.residual);
    steps += 1;
  }
  state.counters["tets"] = static_cast<double>(s->mesh.tet_count());
  state.counters["cg_iterations"] = iterations / steps;
  state.counters["max_residual"] = residual;
  // Where the step's time goes (StepStats::seconds), per step.
  const char* names[4] = {"elements_ms", "assembly_ms", "local_ms", "solve_ms"};
  for (int k = 0; k < 4; ++k) state.counters[names[k]] = 1e3 * phase[k] / steps;
}

// The step right after an incision against the mean step before it (manual time = the first step
// after the cut, which includes the topology update). Also reported: the mean of the next four
// steps (the wound keeps settling), the CG iterations of both, how many of them used the two-level
// cycle, and the relative residual of the warm start right after the cut. Third argument: the
// preconditioner, 0 = the two-level cycle, 1 = block-Jacobi, 2 = the cycle with a degree-4
// Chebyshev smoother, 3 = the cycle with the smoothed prolongator (fem/two_level.hpp).
void BM_TissueStepAfterCut(benchmark::State& state) {
  using clock = std::chrono::steady_clock;
  const Preconditioner pre = state.range(2) == 1 ? Preconditioner::BlockJacobi : Preconditioner::TwoLevel;
  TwoLevelOptions two_level;
  if (state.range(2) == 2) two_level.smoothing_degree = 4;
  if (state.range(2) == 3) two_level.prolongator_weight = 4.0 / 3.0;
  for (auto _ : state) {
    state.PauseTiming();
    auto s = make_scene(static_cast<int>(state.range(0)), kind_of(state), 1e-3, 120, pre, two_level);
    double before = 0, cg_before = 0;
    const int n = 20;
    for (int k = 0; k < n; ++k) {
      const auto t0 = clock::now();
      cg_before += s->model->step(kDt).cg_iterations;
      before += std::chrono::duration<double>(clock::now() - t0).count();
    }
    before /= n;
    cut(*s, 0.006);
    state.ResumeTiming();
    const auto t0 = clock::now();
    const StepStats st = s->model->step(kDt);
    const double after = std::chrono::duration<double>(clock::now() - t0).count();
    state.SetIterationTime(after);
    state.PauseTiming();
    double next = 0, cg_next = 0, residual_next = 0;
    const int m = 4;
    for (int k = 0; k < m; ++k) {
      const auto t1 = clock::now();
      const StepStats sn = s->model->step(kDt);
      next += std::chrono::duration<double>(clock::now() - t1).count();
      cg_next += sn.cg_iterations;
      residual_next = std::max(residual_next, sn.residual);
    }
    state.ResumeTiming();
    state.counters["tets"] = static_cast<double>(s->mesh.tet_count());
    state.counters["before_ms"] = 1e3 * before;
    state.counters["after_ms"] = 1e3 * after;
    state.counters["ratio"] = after / before;
    state.counters["cg_before"] = cg_before / n;
    state.counters["cg_after"] = st.cg_iterations;
    state.counters["cycle_after"] = st.cycle_iterations;
    state.counters["r0_after"] = st.initial_residual;
    state.counters["residual_after"] = st.residual;
    state.counters["local_after"] = static_cast<double>(st.local_nodes);
    state.counters["local_its_after"] = st.local_iterations;
    state.counters["split_after"] = static_cast<double>(st.aggregates_split);
    state.counters["next4_ms"] = 1e3 * next / m;
    state.counters["next4_ratio"] = next / m / before;
    state.counters["cg_next4"] = cg_next / m;
    state.counters["residual_next4"] = residual_next;
  }
}

// Height of the top surface [m] over (x, y) of point p: the highest node within 1.5 mm of it.
double settled_surface(const TetMesh& mesh, const Vec3& p) {
  double top = -std::numeric_limits<double>::infinity();
  for (const NodeId n : mesh.nodes()) {
    const Vec3& x = mesh.position(n);
    if (std::abs(x.x() - p.x()) < 0.0015 && std::abs(x.y() - p.y()) < 0.0015) top = std::max(top, x.z());
  }
  return top;
}

// A progressive incision as the simulator runs it: the cutter's topology changes reach the tissue
// model through Simulation, tool samples at 1 kHz, a tissue step per 60 Hz frame. The blade stabs
// 3 mm below the settled surface at y = -6 mm (through epidermis and dermis: the prestressed slab
// has sunk 2.7 mm), runs 12 mm along +y at 12 mm/s and is lifted out. For each tissue step after a
// frame that cut, ratio = its time / the time of the step just before it; first_cut_ratio is that
// of the first cut, which meets tissue at rest (the step before it is a settled one), with the CG
// iterations of both (cg_first, of which cycle_first used the two-level cycle; cg_before_first)
// and both step times. Manual time: the median step after a cut. Second argument: 0 = FEM, 1 =
// mass-spring. Third: the tool's drag on the tissue (tool.cutting_resistance 350 N/m) off (0) or
// on (1). Fourth: replays R. Each step does the same work in every replay (the solve is
// deterministic), so with R > 1 a step's time is the fastest of its R times: one step slowed by
// the machine no longer sets the largest ratio.
void BM_TissueProgressiveIncision(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  const std::string model = state.range(1) == 0 ? "corotational" : "mass_spring";
  const std::string resistance = state.range(2) == 0 ? "0" : "350";
  const std::string yaml = R"(
name: progressive
mesh:
  generator: slab
  size: [0.04, 0.04]
  cells: [)" + std::to_string(cells) +
                           ", " + std::to_string(cells) + R"(]
  layers:
    - {name: epidermis, thickness: 0.002, cells: 2}
    - {name: dermis, thickness: 0.003, cells: 2}
    - {name: fat, thickness: 0.005, cells: 2}
materials:
  epidermis: {young: 1.0e5, poisson: 0.45, density: 1100, prestress: 1.1}
  dermis: {young: 5.0e4, poisson: 0.45, density: 1100, prestress: 1.1}
  fat: {young: 1.0e4, poisson: 0.45, density: 1100, prestress: 1.1}
tissue: {model: )" + model +
                           R"(, rate: 60, solver: {tolerance: 1.0e-3, max_iterations: 200}}
fixed: [{side: bottom}, {side: x_min}, {side: x_max}, {side: y_min}, {side: y_max}]
tool:
  blade: {back: [0, 0, 0.012], tip: [0, 0, 0], edge: [0, 1, 0]}
  cutting_resistance: )" + resistance +
                           "\n";
  const int replays = std::max(1, static_cast<int>(state.range(3)));
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<double> seconds;
    std::vector<std::uint8_t> after;
    std::vector<StepStats> stats;
    double tets = 0, edges_cut = 0;
    for (int replay = 0; replay < replays; ++replay) {
      Simulation sim(parse_scenario(yaml, "progressive.yaml", "."));
      ForceChannel forces;
      ToolSample s;
      auto at = [&](double y, double z) {
        s.position = Vec3(0.0003, y, z);
        sim.on_sample(s);
        s.t += 1e-3;
        const int frame = static_cast<int>(std::floor(s.t * 60 + 1e-9));
        if (frame > static_cast<int>(std::floor((s.t - 1e-3) * 60 + 1e-9)))
          sim.end_frame(frame / 60.0, forces);
      };
      for (int k = 0; k < 2000; ++k) at(-0.006, 0.004);  // 2 s: the tissue settles
      const double tip = settled_surface(sim.mesh(), Vec3(0.0003, -0.006, 0)) - 0.003;
      for (int k = 0; k < 500; ++k) at(-0.006, 0.004 + (tip - 0.004) * k / 500);
      for (int k = 0; k < 1000; ++k) at(-0.006 + 0.012 * k / 1000, tip);
      for (int k = 0; k < 500; ++k) at(0.006, tip + (0.004 - tip) * k / 500);
      const auto& times = sim.tissue_step_seconds();
      if (replay == 0) {
        seconds = times;
        after = sim.tissue_step_after_cut();
        stats = sim.tissue_steps();
        tets = static_cast<double>(sim.mesh().tet_count());
        edges_cut = static_cast<double>(sim.cutter().totals().edges_cut);
      } else {
        if (times.size() != seconds.size()) state.SkipWithError("a replay took other steps");
        for (std::size_t k = 0; k < std::min(times.size(), seconds.size()); ++k)
          seconds[k] = std::min(seconds[k], times[k]);
      }
    }
    std::vector<double> ratio, after_ms, without_ms;
    double first = 0, cg_after = 0, cg_without = 0;
    for (std::size_t k = 120; k < seconds.size(); ++k) {  // from the end of settling
      if (after[k]) {
        ratio.push_back(seconds[k] / seconds[k - 1]);
        if (ratio.size() == 1) {
          first = ratio.back();
          state.counters["cg_first"] = stats[k].cg_iterations;
          state.counters["cg_before_first"] = stats[k - 1].cg_iterations;
          state.counters["cycle_first"] = stats[k].cycle_iterations;
          state.counters["first_ms"] = 1e3 * seconds[k];
          state.counters["before_first_ms"] = 1e3 * seconds[k - 1];
        }
        after_ms.push_back(1e3 * seconds[k]);
        cg_after += stats[k].cg_iterations;
      } else {
        without_ms.push_back(1e3 * seconds[k]);
        cg_without += stats[k].cg_iterations;
      }
    }
    auto quantile = [](std::vector<double> v, double q) {
      if (v.empty()) return 0.0;
      std::sort(v.begin(), v.end());
      return v[static_cast<std::size_t>(std::floor(q * static_cast<double>(v.size() - 1)))];
    };
    state.SetIterationTime(quantile(after_ms, 0.5) / 1e3);
    state.counters["tets"] = tets;
    state.counters["steps_after_cut"] = static_cast<double>(after_ms.size());
    state.counters["after_cut_ms"] = quantile(after_ms, 0.5);
    state.counters["after_cut_p95_ms"] = quantile(after_ms, 0.95);
    state.counters["without_cut_ms"] = quantile(without_ms, 0.5);
    state.counters["ratio_p50"] = quantile(ratio, 0.5);
    state.counters["ratio_p95"] = quantile(ratio, 0.95);
    state.counters["ratio_max"] = quantile(ratio, 1.0);
    state.counters["first_cut_ratio"] = first;
    state.counters["cg_after"] = cg_after / std::max<double>(1.0, static_cast<double>(after_ms.size()));
    state.counters["cg_without"] = cg_without / std::max<double>(1.0, static_cast<double>(without_ms.size()));
    state.counters["edges_cut"] = edges_cut;
    state.ResumeTiming();
  }
}

// Factorisation of a coarse operator as the two-level preconditioner builds it (fem/two_level.hpp):
// dense 6 x 6 blocks, one block row per aggregate, aggregates on an 8 x 8 x 2 grid each coupled to
// its 8 neighbours in the layer and the one above or below (768 unknowns; the coarse operator of
// the 20-thousand-tetrahedron slab has 130-170 aggregates and about 9 neighbours per aggregate).
// Argument: 0 = Eigen's SimplicialLDLT with AMD on the unknowns, 1 = BlockCholesky (fem/
// block_cholesky.hpp). Counters: analyze_ms (ordering and symbolic factorisation), factorize_ms,
// solve_ms (one solve, as in each two-level cycle).
void BM_CoarseFactorisation(benchmark::State& state) {
  constexpr int nx = 8, ny = 8, nz = 2, kBlock = 6;
  const auto id = [&](int x, int y, int z) { return (z * ny + y) * nx + x; };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Triplet<double>> entries;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int X = x + dx, Y = y + dy, Z = z + dz;
              if (X < 0 || Y < 0 || Z < 0 || X >= nx || Y >= ny || Z >= nz) continue;
              if (dz != 0 && (dx != 0 || dy != 0)) continue;
              const int i = id(x, y, z), j = id(X, Y, Z);
              if (j < i) continue;
              for (int r = 0; r < kBlock; ++r)
                for (int c = 0; c < kBlock; ++c) {
                  const double v = (i == j && r == c ? 40.0 : 0.0) + 0.1 * u(rng);
                  entries.emplace_back(kBlock * i + r, kBlock * j + c, v);
                  entries.emplace_back(kBlock * j + c, kBlock * i + r, v);
                }
            }
  const int n = kBlock * nx * ny * nz;
  std::vector<std::vector<BlockCholesky::Entry>> rows(static_cast<std::size_t>(nx * ny * nz));
  for (const auto& t : entries) {
    auto& row = rows[static_cast<std::size_t>(t.row() / kBlock)];
    const auto col = static_cast<std::uint32_t>(t.col() / kBlock);
    auto e =
        std::find_if(row.begin(), row.end(), [&](const BlockCholesky::Entry& x) { return x.col == col; });
    if (e == row.end()) e = row.insert(row.end(), {col, BlockCholesky::Mat6::Zero()});
    e->block(t.row() % kBlock, t.col() % kBlock) += t.value();
  }
  Eigen::SparseMatrix<double> a(n, n);
  a.setFromTriplets(entries.begin(), entries.end());
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(n);
  Eigen::VectorXd x(n);
  double analyze = 0, factorize = 0, solve = 0;
  using Clock = std::chrono::steady_clock;
  const auto seconds = [](Clock::time_point from, Clock::time_point to) {
    return std::chrono::duration<double>(to - from).count();
  };
  for (auto _ : state) {
    const auto t0 = Clock::now();
    Clock::time_point t1, t2;
    if (state.range(0) == 0) {
      Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
      ldlt.analyzePattern(a);
      t1 = Clock::now();
      ldlt.factorize(a);
      t2 = Clock::now();
      x = ldlt.solve(b);
      if (ldlt.info() != Eigen::Success) state.SkipWithError("factorisation failed");
    } else {
      BlockCholesky chol;
      chol.analyze(rows);
      t1 = Clock::now();
      if (!chol.factorize(rows)) state.SkipWithError("factorisation failed");
      t2 = Clock::now();
      x = b;
      chol.solve(x);
    }
    const auto t3 = Clock::now();
    analyze += seconds(t0, t1);
    factorize += seconds(t1, t2);
    solve += seconds(t2, t3);
    state.SetIterationTime(seconds(t0, t2));
  }
  if ((a * x - b).norm() > 1e-9 * b.norm()) state.SkipWithError("wrong solution");
  const auto count = static_cast<double>(state.iterations());
  state.counters["analyze_ms"] = 1e3 * analyze / count;
  state.counters["factorize_ms"] = 1e3 * factorize / count;
  state.counters["solve_ms"] = 1e3 * solve / count;
}

// Prestressed elements of 1 mm, each corner moved at random by up to `spread` of that.
struct ElementPool {
  std::vector<TetRest> rest;
  std::vector<std::array<Vec3, 4>> x;
};
ElementPool element_pool(std::size_t count, double spread, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-spread, spread);
  Material m;
  m.prestress = 1.1;
  ElementPool pool;
  for (std::size_t e = 0; e < count; ++e) {
    std::array<Vec3, 4> x{Vec3(0, 0, 0), Vec3(1e-3, 0, 0), Vec3(0, 1e-3, 0), Vec3(0, 0, 1e-3)};
    pool.rest.push_back(make_tet_rest(x, m, 0.05));
    for (Vec3& p : x) p += 1e-3 * Vec3(u(rng), u(rng), u(rng));
    pool.x.push_back(x);
  }
  return pool;
}

// The assembly's inner kernel (fem/row_kernel.hpp) on element states from a cache-resident pool:
// arithmetic only, no waiting for memory. Per element row (4 blocks); 0 = portable (the scalar block
// functions), 1 = AVX2 (skipped where the processor lacks it).
void BM_CorotationalRow(benchmark::State& state) {
  const bool avx2 = state.range(0) == 1;
  if (avx2 && !avx2_available()) {
    state.SkipWithError("no AVX2 on this processor");
    return;
  }
  const ElementPool pool = element_pool(64, 0.2, 3);
  std::vector<CorotationalState> states(pool.rest.size());
  for (std::size_t e = 0; e < states.size(); ++e) {
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    evaluate_corotational(pool.rest[e], pool.x[e], q, states[e]);
  }
  std::array<Mat3, 4> k;
  for (Mat3& b : k) b.setZero();
  const std::array<Mat3*, 4> out{&k[0], &k[1], &k[2], &k[3]};
  const CorotationalRowKernel kernel = corotational_row_kernel(avx2 ? RowIsa::Avx2 : RowIsa::Portable);
  std::size_t i = 0;
  for (auto _ : state) {
    kernel(states[i % states.size()], static_cast<int>(i % 4), 1e-4, out);
    benchmark::DoNotOptimize(k);
    ++i;
  }
}

// The co-rotational element's evaluation (fem/element.hpp) on a pool of deformed elements, four at
// a time: 0 = one after the other, 1 = in the lanes of AVX2 (skipped where the processor lacks it).
// Per element.
void BM_CorotationalElements(benchmark::State& state) {
  const bool vectorised = state.range(0) == 1;
  if (vectorised && !evaluate_corotational4_vectorised()) {
    state.SkipWithError("no AVX2 on this processor");
    return;
  }
  constexpr std::size_t kPool = 256;
  const ElementPool pool = element_pool(kPool, 0.05, 5);
  std::vector<Eigen::Quaterniond> q(kPool, Eigen::Quaterniond::Identity());
  std::vector<CorotationalState> out(kPool);
  const auto& rest = pool.rest;
  const auto& x = pool.x;
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t e = i % kPool;
    evaluate_corotational4({&rest[e], &rest[e + 1], &rest[e + 2], &rest[e + 3]},
                           {&x[e], &x[e + 1], &x[e + 2], &x[e + 3]}, {&q[e], &q[e + 1], &q[e + 2], &q[e + 3]},
                           {&out[e], &out[e + 1], &out[e + 2], &out[e + 3]}, vectorised);
    benchmark::DoNotOptimize(out[e]);
    i += 4;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(i));
}

// cells per side: 12 -> 5184, 24 -> 20736, 37 -> 49284 tetrahedra; second argument 0 = FEM,
// 1 = mass-spring; third (after a cut) the preconditioner, as above.
BENCHMARK(BM_TissueStep)
    ->ArgsProduct({{12, 24, 37}, {0, 1}, {2}})
    ->ArgsProduct({{24}, {0}, {1, 4, 8, 16}})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);
BENCHMARK(BM_TissueStepAfterCut)
    ->ArgsProduct({{12, 24, 37}, {0, 1}, {0, 1}})
    ->Args({24, 0, 2})
    ->Args({24, 0, 3})
    ->Unit(benchmark::kMillisecond)
    ->UseManualTime()
    ->Iterations(1)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_TissueProgressiveIncision)
    ->ArgsProduct({{12, 24, 37}, {0, 1}, {0, 1}, {1}})
    ->Args({12, 0, 0, 5})
    ->Args({24, 0, 0, 5})
    ->Args({24, 1, 0, 5})
    ->Unit(benchmark::kMillisecond)
    ->UseManualTime()
    ->Iterations(1);
BENCHMARK(BM_CorotationalRow)->DenseRange(0, 1);
BENCHMARK(BM_CorotationalElements)->DenseRange(0, 1);
BENCHMARK(BM_CoarseFactorisation)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseManualTime();

}  // namespace

BENCHMARK_MAIN();
