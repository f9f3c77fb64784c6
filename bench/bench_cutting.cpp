// Cost of one tool sample of progressive cutting, by mesh size (issue: speed of the cutter).
//
// The same incision, measured in cells, in boxes of about 10 thousand, 100 thousand and 1 million
// tetrahedra (Kuhn split, 1 mm cells): a blade three cells long, tilted 30 degrees, enters the top
// surface from above, draws an incision twelve cells long at 0.01 mm per sample (10 mm/s at
// 1 kHz) and lifts out. The cost of a sample should depend on what the blade touches, not on the
// size of the mesh: the ratio of the 1-million to the 10-thousand p99 is the figure of merit.
// Then a second incision of the same kind crosses the first in its middle (the recursive
// continuation, paper section 6): its samples are timed separately, and its slowest sample is the
// one that promotes the first incision's tetrahedra.
//
// The heap allocations a sample makes are counted too (base/count_allocations.hpp): a sample
// that cuts nothing new should make none, since the cutter's per-step scratch is reused; one that
// cuts allocates for the cut nodes and elements it adds.
//
// A harness of our own, since the figures are percentiles over samples: prints a table and, with
// --json, one JSON object per mesh.
//   bench_cutting [--sizes 12,26,55] [--json]
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "base/count_allocations.hpp"
#include "cutting/cut_engine.hpp"
#include "mesh/generators.hpp"

using namespace scalpel;

namespace {

// Resident set size [bytes], from /proc/self/statm.
double resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  double pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * static_cast<double>(sysconf(_SC_PAGESIZE));
}

struct Result {
  int cells;
  std::size_t tets;
  std::size_t samples;
  double p50, p99, max;  // [us]
  double bytes_per_tet;
  std::size_t edges_cut;
  std::size_t tets_after;
  double cross_p50, cross_p99, cross_max;  // [us] the crossing incision
  std::size_t promoted;                    // tetrahedra the crossing promoted
  // Heap allocations per sample of the first incision: all samples, and those that added no node.
  double allocs_p50, allocs_p99, allocs_max;
  std::size_t quiet_samples;
  double quiet_allocs_max;
};

// Percentiles of a list of sample times.
struct Percentiles {
  double p50, p99, max;
};
Percentiles percentiles(std::vector<double> us) {
  std::sort(us.begin(), us.end());
  auto at = [&](double q) { return us[static_cast<size_t>(q * static_cast<double>(us.size() - 1))]; };
  return {at(0.5), at(0.99), us.back()};
}

// Per sample of one incision: its time [us] and heap allocations, and the allocations of those
// samples that added no node.
struct Samples {
  std::vector<double> us, allocs, quiet_allocs;
};

Result run(int n) {
  const double h = 1e-3;  // [m] cell size
  const double before = resident_bytes();
  TetMesh mesh = make_box({.min = Vec3::Zero(), .max = Vec3::Constant(n * h), .cells = {n, n, n}});
  CutEngine cutter(mesh);
  const double after = resident_bytes();
  const std::size_t tets = mesh.tet_count();

  // Incisions along `along` (+x, then +y) through the middle of the top face, between grid planes.
  const double top = n * h, mid = std::floor(n / 2.0) * h;
  auto incision = [&](const Vec3& start, const Vec3& along) {
    const Vec3 back_offset = (-std::sin(0.5236) * along + Vec3(0, 0, std::cos(0.5236))) * (3 * h);
    auto blade = [&](const Vec3& tip) { return BladePose{tip + back_offset, tip, Vec3::Zero()}; };
    const double step = 1e-5;  // [m] per sample
    const std::vector<Vec3> path =
        incision_path(start + Vec3(0, 0, top + 0.5 * h), top - 1.3 * h, along, 12 * h, step);
    cutter.place(blade(path.front()));
    Samples out;
    out.us.reserve(path.size());
    out.allocs.reserve(path.size());
    out.quiet_allocs.reserve(path.size());
    for (std::size_t i = 1; i < path.size(); ++i) {
      const BladePose pose = blade(path[i]);
      const std::size_t allocs_before = heap_allocations();
      const auto t0 = std::chrono::steady_clock::now();
      const CutStepStats stats = cutter.step(pose);
      const auto t1 = std::chrono::steady_clock::now();
      const auto allocs = static_cast<double>(heap_allocations() - allocs_before);
      out.us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      out.allocs.push_back(allocs);
      if (stats.nodes_created == 0) out.quiet_allocs.push_back(allocs);
    }
    return out;
  };
  const Samples first_cut = incision(Vec3(mid - 5.79 * h, mid + 0.37 * h, 0), Vec3(1, 0, 0));
  const std::vector<double>& us = first_cut.us;
  const std::size_t edges_cut = cutter.totals().edges_cut, tets_after = mesh.tet_count();
  const std::vector<double> cross = incision(Vec3(mid + 0.13 * h, mid - 5.71 * h, 0), Vec3(0, 1, 0)).us;
  const Percentiles first = percentiles(us), second = percentiles(cross);
  const Percentiles allocs = percentiles(first_cut.allocs);
  const double quiet_max = first_cut.quiet_allocs.empty() ? 0.0
                                                          : *std::max_element(first_cut.quiet_allocs.begin(),
                                                                              first_cut.quiet_allocs.end());
  return {n,
          tets,
          us.size(),
          first.p50,
          first.p99,
          first.max,
          (after - before) / static_cast<double>(tets),
          edges_cut,
          tets_after,
          second.p50,
          second.p99,
          second.max,
          cutter.totals().promoted_tets,
          allocs.p50,
          allocs.p99,
          allocs.max,
          first_cut.quiet_allocs.size(),
          quiet_max};
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{12, 26, 55};
  bool json = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--json") == 0) {
      json = true;
    } else if (std::strcmp(argv[i], "--sizes") == 0 && i + 1 < argc) {
      sizes.clear();
      for (const char* p = argv[++i]; *p;) {
        sizes.push_back(std::atoi(p));
        while (*p && *p != ',') ++p;
        if (*p == ',') ++p;
      }
    } else {
      std::fprintf(stderr, "usage: bench_cutting [--sizes 12,26,55] [--json]\n");
      return 2;
    }
  }
  std::vector<Result> results;
  if (!json)
    std::printf("%10s %8s %10s %10s %10s %12s %10s | crossing: %10s %10s %10s %9s\n", "tets", "samples",
                "p50 [us]", "p99 [us]", "max [us]", "bytes/tet", "edges cut", "p50 [us]", "p99 [us]",
                "max [us]", "promoted");
  for (const int n : sizes) {
    const Result r = run(n);
    results.push_back(r);
    if (json)
      std::printf(
          "{\"tets\": %zu, \"samples\": %zu, \"p50_us\": %.3f, \"p99_us\": %.3f, \"max_us\": %.3f, "
          "\"bytes_per_tet\": %.1f, \"edges_cut\": %zu, \"tets_after\": %zu, \"crossing_p50_us\": %.3f, "
          "\"crossing_p99_us\": %.3f, \"crossing_max_us\": %.3f, \"promoted\": %zu, \"allocs_p50\": %.0f, "
          "\"allocs_p99\": %.0f, \"allocs_max\": %.0f, \"quiet_samples\": %zu, \"quiet_allocs_max\": %.0f}\n",
          r.tets, r.samples, r.p50, r.p99, r.max, r.bytes_per_tet, r.edges_cut, r.tets_after, r.cross_p50,
          r.cross_p99, r.cross_max, r.promoted, r.allocs_p50, r.allocs_p99, r.allocs_max, r.quiet_samples,
          r.quiet_allocs_max);
    else
      std::printf("%10zu %8zu %10.1f %10.1f %10.1f %12.1f %10zu |           %10.1f %10.1f %10.1f %9zu\n",
                  r.tets, r.samples, r.p50, r.p99, r.max, r.bytes_per_tet, r.edges_cut, r.cross_p50,
                  r.cross_p99, r.cross_max, r.promoted);
  }
  if (!json) {
    std::printf(
        "\nheap allocations per sample (first incision): %10s %10s %10s | samples adding no node: %8s %10s\n",
        "p50", "p99", "max", "count", "max");
    for (const Result& r : results)
      std::printf("%10zu tets %34.0f %10.0f %10.0f |                         %8zu %10.0f\n", r.tets,
                  r.allocs_p50, r.allocs_p99, r.allocs_max, r.quiet_samples, r.quiet_allocs_max);
  }
  if (!json && results.size() >= 2)
    std::printf("p99 ratio largest/smallest mesh: %.2f\n", results.back().p99 / results.front().p99);
  return 0;
}
