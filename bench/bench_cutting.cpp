// Cost of one tool sample of progressive cutting, by mesh size (issue: speed of the cutter).
//
// The same incision, measured in cells, in boxes of about 10 thousand, 100 thousand and 1 million
// tetrahedra (Kuhn split, 1 mm cells): a blade three cells long, tilted 30 degrees, enters the top
// surface from above, draws an incision twelve cells long at 0.01 mm per sample (10 mm/s at
// 1 kHz) and lifts out. The cost of a sample should depend on what the blade touches, not on the
// size of the mesh: the ratio of the 1-million to the 10-thousand p99 is the figure of merit.
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

#include "cutting/cut_engine.hpp"
#include "cutting/generators.hpp"

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
};

Result run(int n) {
  const double h = 1e-3;  // [m] cell size
  const double before = resident_bytes();
  TetMesh mesh = make_box({.min = Vec3::Zero(), .max = Vec3::Constant(n * h), .cells = {n, n, n}});
  CutEngine cutter(mesh);
  const double after = resident_bytes();
  const std::size_t tets = mesh.tet_count();

  // Incision along +x through the middle of the top face, between grid planes.
  const double y = (std::floor(n / 2.0) + 0.37) * h, top = n * h;
  const Vec3 back_offset = Vec3(-std::sin(0.5236), 0, std::cos(0.5236)) * (3 * h);
  const double x0 = (std::floor(n / 2.0) - 6 + 0.21) * h;
  auto blade = [&](const Vec3& tip) { return BladePose{tip + back_offset, tip, Vec3::Zero()}; };
  std::vector<Vec3> path;
  const double step = 1e-5;  // [m] per sample
  Vec3 tip(x0, y, top + 0.5 * h);
  for (; tip.z() > top - 1.3 * h; tip.z() -= step) path.push_back(tip);
  for (double x = x0; x < x0 + 12 * h; x += step) path.push_back(Vec3(x, y, tip.z()));
  for (Vec3 t(x0 + 12 * h, y, tip.z()); t.z() < top + 0.5 * h; t.z() += step) path.push_back(t);

  cutter.place(blade(path.front()));
  std::vector<double> us;
  us.reserve(path.size());
  for (std::size_t i = 1; i < path.size(); ++i) {
    const auto start = std::chrono::steady_clock::now();
    cutter.step(blade(path[i]));
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count());
  }
  std::vector<double> sorted = us;
  std::sort(sorted.begin(), sorted.end());
  auto at = [&](double q) { return sorted[static_cast<size_t>(q * static_cast<double>(sorted.size() - 1))]; };
  return {n,
          tets,
          us.size(),
          at(0.5),
          at(0.99),
          sorted.back(),
          (after - before) / static_cast<double>(tets),
          cutter.totals().edges_cut,
          mesh.tet_count()};
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
    std::printf("%10s %8s %10s %10s %10s %12s %10s\n", "tets", "samples", "p50 [us]", "p99 [us]", "max [us]",
                "bytes/tet", "edges cut");
  for (const int n : sizes) {
    const Result r = run(n);
    results.push_back(r);
    if (json)
      std::printf(
          "{\"tets\": %zu, \"samples\": %zu, \"p50_us\": %.3f, \"p99_us\": %.3f, \"max_us\": %.3f, "
          "\"bytes_per_tet\": %.1f, \"edges_cut\": %zu, \"tets_after\": %zu}\n",
          r.tets, r.samples, r.p50, r.p99, r.max, r.bytes_per_tet, r.edges_cut, r.tets_after);
    else
      std::printf("%10zu %8zu %10.1f %10.1f %10.1f %12.1f %10zu\n", r.tets, r.samples, r.p50, r.p99, r.max,
                  r.bytes_per_tet, r.edges_cut);
  }
  if (!json && results.size() >= 2)
    std::printf("p99 ratio largest/smallest mesh: %.2f\n", results.back().p99 / results.front().p99);
  return 0;
}
