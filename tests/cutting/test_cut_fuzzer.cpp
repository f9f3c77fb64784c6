// A trajectory fuzzer of the cutter, with the recursive continuation on (paper sections 5-6):
// seeded generators of blade motions the hand-made tests never make (tumbling blades, crossings
// along grid planes, blades longer than the mesh, tremor through curved meshes) on structured and
// gmsh meshes. After every step: invariants 1-5 (docs/invariants.md). After every stroke whose
// swept surface is a union of planes through the whole mesh: the pieces and volumes of the original
// mesh clipped by those planes, exactly; after a stroke that cannot free a piece: one piece. A
// failure is minimised to a short sample list and printed in the form of tests/data/fuzz/, where
// each file, with a comment on what it broke and why, becomes a regression test.
//
// CI runs a short budget. The long run, e.g. ten thousand trajectories of each kind:
//   SCALPEL_FUZZ_BUDGET=10000 ./build/release/tests/scalpel_tests -tc='fuzz*'
// SCALPEL_FUZZ_SEED changes the seeds; SCALPEL_FUZZ_FIRST=K starts at trajectory K (with
// SCALPEL_FUZZ_BUDGET=1: the one a failure names).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cutting/cut_engine.hpp"
#include "mesh/generators.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "mesh/topology.hpp"
#include "mesh/validate.hpp"
#include "trajectory_support.hpp"

using namespace scalpel;
using testing::Rng;
using testing::rotate;
using testing::Scene;

namespace {

std::size_t env_size(const char* name, std::size_t fallback) {
  const char* v = std::getenv(name);
  return v ? static_cast<std::size_t>(std::strtoull(v, nullptr, 10)) : fallback;
}

Scene box(int cells) {
  Scene s;
  s.name = "box " + std::to_string(cells) + "^3";
  s.tag = "box " + std::to_string(cells);
  s.mesh = make_box({.cells = {cells, cells, cells}});
  s.volume = 1.0;
  s.lo = Vec3::Zero();
  s.hi = Vec3::Ones();
  s.h = 1.0 / cells;
  return s;
}

Scene gmsh_box() {
  Scene s = testing::gmsh_scene("gmsh box with inclusion", SCALPEL_TEST_MSH22);
  s.tag = "gmsh";
  return s;
}

Scene gmsh_sphere() {
  Scene s = testing::gmsh_scene("gmsh sphere", SCALPEL_TEST_SPHERE);
  s.tag = "sphere";
  return s;
}

struct Sample {
  bool place = false;  // a new stroke: the blade is put here without cutting
  BladePose pose;
};

// A plane n.x = d; a through-stroke sweeps all of it that lies in the mesh.
struct Plane {
  Vec3 n;
  double d;
};

// What a trajectory's strokes predict of the pieces once they are done.
struct Expectation {
  std::vector<Plane> planes;  // through-cuts: the pieces are the mesh clipped by all of them
  double tolerance = 1e-9;    // on each piece's volume, relative to the mesh's
  bool one_piece = false;     // no stroke can free a piece
};

struct Trajectory {
  std::vector<Sample> samples;
  Expectation expect;
};

// ---- the exact reference: the original mesh clipped by planes --------------------------------

using Tet = std::array<Vec3, 4>;

double volume_of(const Tet& t) {
  return signed_volume(t[0], t[1], t[2], t[3]);
}

// The part of tetrahedron t with n.x - d of sign `side` (+1 or -1), as tetrahedra.
void clip(const Tet& t, const Plane& p, int side, std::vector<Tet>& out) {
  std::array<double, 4> s{};
  std::vector<int> in, off;
  for (int i = 0; i < 4; ++i) {
    s[static_cast<size_t>(i)] = side * (p.n.dot(t[static_cast<size_t>(i)]) - p.d);
    (s[static_cast<size_t>(i)] >= 0 ? in : off).push_back(i);
  }
  auto cut = [&](int a, int b) {
    const double sa = s[static_cast<size_t>(a)], sb = s[static_cast<size_t>(b)];
    return Vec3(t[static_cast<size_t>(a)] +
                sa / (sa - sb) * (t[static_cast<size_t>(b)] - t[static_cast<size_t>(a)]));
  };
  auto push = [&](const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
    Tet x{a, b, c, d};
    if (volume_of(x) < 0) std::swap(x[0], x[1]);
    out.push_back(x);
  };
  const auto T = [&](int i) { return t[static_cast<size_t>(in[static_cast<size_t>(i)])]; };
  const auto I = [&](int i) { return in[static_cast<size_t>(i)]; };
  const auto O = [&](int i) { return off[static_cast<size_t>(i)]; };
  switch (in.size()) {
    case 4:
      out.push_back(t);
      break;
    case 3: {  // a prism: the three inside corners and their cuts towards the outside one
      const Vec3 a = T(0), b = T(1), c = T(2);
      const Vec3 ab = cut(I(0), O(0)), bb = cut(I(1), O(0)), cb = cut(I(2), O(0));
      push(a, b, c, cb);
      push(a, b, cb, bb);
      push(a, ab, bb, cb);
      break;
    }
    case 2: {  // a wedge between the inside edge and the four cut points
      const Vec3 a = T(0), b = T(1);
      const Vec3 a0 = cut(I(0), O(0)), a1 = cut(I(0), O(1)), b0 = cut(I(1), O(0)), b1 = cut(I(1), O(1));
      push(a, b, a0, a1);
      push(b, a0, a1, b1);
      push(b, a0, b0, b1);
      break;
    }
    case 1:
      push(T(0), cut(I(0), O(0)), cut(I(0), O(1)), cut(I(0), O(2)));
      break;
    default:
      break;
  }
}

// Rest volumes of the regions the planes cut the original mesh into (each sign pattern), the empty
// ones left out, in ascending order.
std::vector<double> clipped_volumes(const TetMesh& original, const std::vector<Plane>& planes) {
  std::vector<double> out;
  for (std::uint32_t pattern = 0; pattern < (1u << planes.size()); ++pattern) {
    double v = 0;
    for (const TetId id : original.tets()) {
      const auto nodes = original.tet_nodes(id);
      std::vector<Tet> parts{{original.rest(nodes[0]), original.rest(nodes[1]), original.rest(nodes[2]),
                              original.rest(nodes[3])}};
      for (std::size_t k = 0; k < planes.size(); ++k) {
        std::vector<Tet> next;
        for (const Tet& t : parts) clip(t, planes[k], (pattern >> k) & 1u ? 1 : -1, next);
        parts.swap(next);
      }
      for (const Tet& t : parts) v += std::abs(volume_of(t));
    }
    if (v > 0) out.push_back(v);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---- trajectory generators -----------------------------------------------------------------

enum class Kind {
  Tumble,
  GridCrossing,
  ThroughCrossing,
  ShallowCrossing,
  PartialCrossing,
  Tremor,
  TipAlongBottom,
  TremorAcross,
  Count
};

std::string kind_name(Kind k) {
  switch (k) {
    case Kind::Tumble:
      return "tumbling blade";
    case Kind::GridCrossing:
      return "through-cuts crossing along grid planes";
    case Kind::ThroughCrossing:
      return "through-cuts crossing at random angles (over 10.5 degrees)";
    case Kind::ShallowCrossing:
      return "through-cuts crossing at 10-40 degrees";
    case Kind::PartialCrossing:
      return "partial-depth incisions crossing";
    case Kind::Tremor:
      return "through-cut with tremor";
    case Kind::TipAlongBottom:
      return "a tip running along the bottom face";
    case Kind::TremorAcross:
      return "through-cut with tremor across its plane";
    default:
      return "?";
  }
}

// A stroke through the whole mesh in plane p: a blade along `along` (in the plane), longer than the
// mesh, swept in the plane across all of it in steps of `step`. tremor(k) displaces the blade.
void through_stroke(const Scene& s, const Plane& p, const Vec3& along, double step, std::vector<Sample>& out,
                    const std::function<Vec3(int)>& tremor = {}) {
  const Vec3 centre = 0.5 * (s.lo + s.hi);
  const double reach = (s.hi - s.lo).norm();
  const Vec3 on = centre - (p.n.dot(centre) - p.d) * p.n;  // centre projected onto the plane
  const Vec3 d = (along - along.dot(p.n) * p.n).normalized();
  const Vec3 move = p.n.cross(d).normalized();
  const int n = static_cast<int>(std::ceil(2.0 * reach / step));
  for (int k = 0; k <= n; ++k) {
    Vec3 c = on + (-reach + 2.0 * reach * k / n) * move;
    if (tremor) c += tremor(k);
    out.push_back({k == 0, {c - 1.5 * reach * d, c + 1.5 * reach * d, move}});
  }
}

// An incision from above in plane p whose tip stays `depth` below the top, over the whole mesh.
void partial_stroke(const Scene& s, const Plane& p, double depth, double step, std::vector<Sample>& out) {
  const Vec3 centre = 0.5 * (s.lo + s.hi);
  const double reach = (s.hi - s.lo).norm();
  Vec3 down = Vec3(0, 0, -1) + p.n.z() * p.n;  // straight down, projected into the plane
  down.normalize();
  const Vec3 move = p.n.cross(down).normalized();
  Vec3 on = centre - (p.n.dot(centre) - p.d) * p.n;
  on += ((s.hi.z() - depth) - on.z()) / down.z() * down;  // the tip at height top - depth
  const int n = static_cast<int>(std::ceil(2.0 * reach / step));
  for (int k = 0; k <= n; ++k) {
    const Vec3 tip = on + (-reach + 2.0 * reach * k / n) * move;
    out.push_back({k == 0, {tip - 1.5 * reach * down, tip, move}});
  }
}

Trajectory make(Kind kind, const Scene& s, Rng& rng) {
  Trajectory t;
  const Vec3 centre = 0.5 * (s.lo + s.hi), size = s.hi - s.lo;
  const double step = 0.1 * s.h;
  switch (kind) {
    case Kind::Tumble: {  // a random rotation and translation every sample, the blade through the mesh
      Vec3 c = centre + Vec3(rng.range(-0.3, 0.3) * size.x(), rng.range(-0.3, 0.3) * size.y(),
                             rng.range(-0.3, 0.3) * size.z());
      Vec3 d = rng.unit(), v = rng.unit();
      const double length = rng.range(0.5, 1.5) * size.norm();
      const int n = static_cast<int>(env_size("SCALPEL_FUZZ_TUMBLE_SAMPLES", 600));
      for (int k = 0; k < n; ++k) {
        v = (v + 0.3 * rng.unit()).normalized();
        c += 0.05 * s.h * v;
        for (int i = 0; i < 3; ++i) {  // stay around the mesh
          if (c[i] < s.lo[i]) v[i] = std::abs(v[i]);
          if (c[i] > s.hi[i]) v[i] = -std::abs(v[i]);
        }
        d = rotate(d, rng.unit(), rng.range(0.0, 0.06)).normalized();
        t.samples.push_back({k == 0, {c - 0.5 * length * d, c + 0.5 * length * d, Vec3::Zero()}});
      }
      break;
    }
    case Kind::GridCrossing: {  // x = c and y = c on grid planes, blades tilted in their plane
      const int cells = static_cast<int>(std::lround(1.0 / s.h));
      const double x =
          s.lo.x() + s.h * static_cast<double>(1 + rng.next() % static_cast<std::uint64_t>(cells - 1));
      const double y =
          s.lo.y() + s.h * static_cast<double>(1 + rng.next() % static_cast<std::uint64_t>(cells - 1));
      const Plane a{Vec3(1, 0, 0), x}, b{Vec3(0, 1, 0), y};
      const double tilt_a = rng.range(-0.5, 0.5), tilt_b = rng.range(-0.5, 0.5);
      through_stroke(s, a, Vec3(0, std::sin(tilt_a), std::cos(tilt_a)), step, t.samples);
      through_stroke(s, b, Vec3(std::sin(tilt_b), 0, std::cos(tilt_b)), step, t.samples);
      t.expect.planes = {a, b};
      // Cut nodes keep CutOptions::min_edge_param of an edge from the grid nodes the planes run
      // through: each section is that far off its plane.
      t.expect.tolerance = 4 * CutOptions{}.min_edge_param * s.h;
      break;
    }
    // Planes at least CutOptions::along_cut_angle_deg apart: closer, a second stroke meeting the
    // first is taken for a blade retracing it (docs/state_machine.md, "Retracing an opened cut"),
    // which joins the wedge between them to the first cut's pieces by design.
    case Kind::ThroughCrossing: {
      const double resolved = std::cos((CutOptions{}.along_cut_angle_deg + 0.5) * M_PI / 180);
      for (int k = 0; k < 2; ++k) {
        Vec3 n;
        do {
          n = rng.unit();
          n.z() *= 0.4;  // steep planes: the blade enters from the side as well as from above
          n.normalize();
        } while (k == 1 && std::abs(n.dot(t.expect.planes[0].n)) > resolved);
        const Plane p{
            n, n.dot(centre + Vec3(rng.range(-0.25, 0.25) * size.x(), rng.range(-0.25, 0.25) * size.y(), 0))};
        through_stroke(s, p, rng.unit(), step, t.samples);
        t.expect.planes.push_back(p);
      }
      break;
    }
    // The second plane turned by 10-40 degrees about a line in the first.
    case Kind::ShallowCrossing: {
      Vec3 n = rng.unit();
      n.z() *= 0.4;
      n.normalize();
      const Vec3 at = centre + Vec3(rng.range(-0.25, 0.25) * size.x(), rng.range(-0.25, 0.25) * size.y(), 0);
      const Vec3 axis = (rng.unit().cross(n)).normalized();
      const Vec3 m = rotate(n, axis, rng.range(10.5, 40) * M_PI / 180 * (rng.uniform() < 0.5 ? 1 : -1));
      for (const Vec3& normal : {n, m}) {
        const Plane p{normal, normal.dot(at)};
        through_stroke(s, p, rng.unit(), step, t.samples);
        t.expect.planes.push_back(p);
      }
      break;
    }
    case Kind::PartialCrossing: {
      const double angle = rng.range(0, M_PI);
      for (int k = 0; k < 2; ++k) {
        const double a = angle + k * rng.range(0.5, 2.6);
        const Vec3 n(std::cos(a), std::sin(a), rng.range(-0.2, 0.2));
        const Plane p{n.normalized(), n.normalized().dot(centre + Vec3(rng.range(-0.2, 0.2) * size.x(),
                                                                       rng.range(-0.2, 0.2) * size.y(), 0))};
        partial_stroke(s, p, rng.range(0.2, 0.7) * size.z(), step, t.samples);
      }
      t.expect.one_piece = true;
      break;
    }
    case Kind::TipAlongBottom: {  // a cut from above whose tip runs in the bottom face: it severs
      Vec3 n = rng.unit();
      n.z() *= 0.4;
      n.normalize();
      const Plane p{
          n, n.dot(centre + Vec3(rng.range(-0.25, 0.25) * size.x(), rng.range(-0.25, 0.25) * size.y(), 0))};
      partial_stroke(s, p, size.z(), step, t.samples);
      for (Sample& x : t.samples) x.pose.tip.z() = s.lo.z();  // exactly, not within rounding
      t.expect.planes = {p};
      break;
    }
    case Kind::Tremor:          // 8-12 Hz tremor of about one edge length at 1 kHz, in the plane only
    case Kind::TremorAcross: {  // the same, and across the plane too: a wavy sheet, still one cut
      Vec3 n = rng.unit();
      n.z() *= 0.3;
      n.normalize();
      const Plane p{n, n.dot(centre)};
      const Vec3 u = n.cross(Vec3(0, 0, 1)).normalized(), w = n.cross(u);
      const double f1 = rng.range(8, 12) * 2 * M_PI / 1000, f2 = rng.range(8, 12) * 2 * M_PI / 1000;
      const double amp = rng.range(0.3, 1.0) * s.h;
      const double f3 = kind == Kind::TremorAcross ? rng.range(8, 12) * 2 * M_PI / 1000 : 0.0;
      const double across = kind == Kind::TremorAcross ? rng.range(0.1, 0.3) * s.h : 0.0;
      through_stroke(s, p, w, 0.02 * s.h, t.samples, [&](int k) {
        return Vec3(amp * (std::sin(f1 * k) * u + std::cos(f2 * k) * w) + across * std::sin(f3 * k) * n);
      });
      t.expect.planes = {p};
      if (across > 0) {
        // The sheet stays within `across` of the plane: each piece within that slab's volume, at
        // most `across` times a section's area (under half the bounding box's surface).
        const Vec3 e = s.hi - s.lo;
        const double half_surface = e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
        t.expect.tolerance = across * half_surface / s.volume;
      }
      break;
    }
    default:
      break;
  }
  return t;
}

// ---- running and checking --------------------------------------------------------------------

struct Outcome {
  std::optional<std::size_t> failed_at;  // the sample at which a check failed (samples.size(): at the end)
  std::string why;
  double refinement = 0;  // live tetrahedra made per cut original tetrahedron
};

// Bound on refinement: a cut original tetrahedron holds at most this many live tetrahedra.
constexpr double kMaxRefinement = 60.0;

Outcome run(const Scene& s, const Trajectory& t) {
  Outcome o;
  TetMesh mesh = s.mesh;
  CutEngine cutter(mesh);
  const std::size_t original = mesh.tet_count();
  auto fail = [&](std::size_t i, std::string why) {
    o.failed_at = i;
    o.why = std::move(why);
    return o;
  };
  for (std::size_t i = 0; i < t.samples.size(); ++i) {
    if (t.samples[i].place) {
      cutter.place(t.samples[i].pose);
      continue;
    }
    try {
      cutter.step(t.samples[i].pose);
    } catch (const std::exception& e) {
      return fail(i, e.what());
    }
    const auto report = validate_local(mesh, cutter.changes().touched_nodes, {.reference_volume = s.volume});
    if (!report.ok()) return fail(i, report.summary());
    const std::string faithful = cutter.check_faithful(1e-9 * s.h);
    if (!faithful.empty()) return fail(i, "invariant 5: " + faithful);
    const std::size_t cut = cutter.totals().coarse_tets_cut;
    if (cut > 0) {
      const double made =
          static_cast<double>(mesh.tet_count()) - static_cast<double>(original - std::min(original, cut));
      o.refinement = std::max(o.refinement, made / static_cast<double>(cut));
      if (o.refinement > kMaxRefinement)
        return fail(i,
                    "refinement: " + std::to_string(o.refinement) + " live tetrahedra per cut original one");
    }
  }
  const std::size_t end = t.samples.size();
  // Every change of state the engine made is a sequence of events of the table's machine.
  const CutTable& table = default_cut_table();
  const std::string unreached = unreached_transitions(table, cutter.totals().state_transitions);
  if (!unreached.empty())
    return fail(end, "state machine: no sequence of the table's events makes\n" + unreached);
  const auto report = validate(mesh, {.reference_volume = s.volume});
  if (!report.ok()) return fail(end, report.summary());
  const Components pieces = connected_components(mesh);
  if (t.expect.one_piece && pieces.count() != 1) {
    std::ostringstream why;
    why << pieces.count() << " pieces where no piece can come free; volumes";
    for (const double v : pieces.rest_volume) why << ' ' << v;
    return fail(end, why.str());
  }
  if (!t.expect.planes.empty()) {
    const std::vector<double> want = clipped_volumes(s.mesh, t.expect.planes);
    std::vector<double> got = pieces.rest_volume;
    std::sort(got.begin(), got.end());
    bool ok = got.size() == want.size();
    for (std::size_t k = 0; ok && k < got.size(); ++k)
      ok = std::abs(got[k] - want[k]) <= t.expect.tolerance * s.volume;
    if (!ok) {
      std::ostringstream why;
      why.precision(12);
      why << "pieces: got";
      for (const double v : got) why << ' ' << v;
      why << "; the planes cut the mesh into";
      for (const double v : want) why << ' ' << v;
      return fail(end, why.str());
    }
  }
  return o;
}

// Minimises a trajectory that fails during its strokes: its prefix up to the failure, then samples
// dropped in ever smaller blocks while it still fails during its strokes (the first sample stays a
// placement). A failure of the end check is left as it is: dropping samples changes the pieces.
Trajectory minimise(const Scene& s, Trajectory t, std::size_t failed_at) {
  if (failed_at >= t.samples.size()) return t;
  t.samples.resize(failed_at + 1);
  t.expect = {};
  auto fails_in_strokes = [&](const Trajectory& x) {
    const Outcome o = run(s, x);
    return o.failed_at && *o.failed_at < x.samples.size();
  };
  for (std::size_t block = t.samples.size() / 2; block >= 1; block /= 2) {
    for (std::size_t at = 1; at + block <= t.samples.size();) {
      Trajectory shorter = t;
      shorter.samples.erase(shorter.samples.begin() + static_cast<std::ptrdiff_t>(at),
                            shorter.samples.begin() + static_cast<std::ptrdiff_t>(at + block));
      if (fails_in_strokes(shorter)) {
        t = std::move(shorter);
      } else {
        at += block;
      }
    }
  }
  return t;
}

// A minimised failure as a regression file (tests/data/fuzz/): a line `mesh box N`, `mesh gmsh` or `mesh
// sphere`, then one line per sample: `place` or `step`, the back, the tip and the cutting direction.
std::string listing(const Scene& s, const Trajectory& t) {
  std::ostringstream out;
  out.precision(17);
  out << "mesh " << s.tag << '\n';
  for (const Sample& x : t.samples)
    out << (x.place ? "place " : "step  ") << x.pose.back.transpose() << "  " << x.pose.tip.transpose()
        << "  " << x.pose.cutting_direction.transpose() << '\n';
  return out.str();
}

// What a run of trajectories found.
struct Campaign {
  std::size_t failures = 0;
  std::size_t wrong_pieces = 0;  // of them: the strokes kept the invariants, the pieces are wrong
  double worst = 0;              // live tetrahedra per cut original tetrahedron, at most
  std::string shown;             // the first three failures, minimised where they fail in a stroke
};

// Trajectories first .. first + budget - 1 of a kind and seed.
Campaign campaign(const Scene& s, Kind kind, std::size_t first, std::size_t budget, std::uint64_t seed) {
  Campaign c;
  std::ostringstream shown;
  for (std::size_t i = first; i < first + budget; ++i) {
    Rng rng{seed ^ (static_cast<std::uint64_t>(kind) << 40) ^ i};
    const Trajectory t = make(kind, s, rng);
    const Outcome o = run(s, t);
    c.worst = std::max(c.worst, o.refinement);
    if (!o.failed_at) continue;
    if (*o.failed_at == t.samples.size() && o.why.rfind("pieces: ", 0) == 0) ++c.wrong_pieces;
    if (++c.failures > 3) continue;  // counted; the first three are shown
    shown << '\n' << s.name << ", " << kind_name(kind) << ", trajectory " << i << " (seed " << seed << "): ";
    if (*o.failed_at < t.samples.size()) {
      const Trajectory small = minimise(s, t, *o.failed_at);
      const Outcome again = run(s, small);
      shown << "sample " << *o.failed_at << " of " << t.samples.size() << ": " << o.why << "\nminimised to "
            << small.samples.size() << " samples (fails at " << again.failed_at.value_or(0) << ": "
            << again.why << "):\n"
            << listing(s, small);
    } else {
      shown << "after its " << t.samples.size() << " samples: " << o.why;
    }
  }
  c.shown = shown.str();
  return c;
}

// A campaign sized by SCALPEL_FUZZ_BUDGET, SCALPEL_FUZZ_FIRST and SCALPEL_FUZZ_SEED: no failure.
void fuzz(const Scene& s, Kind kind, std::size_t fallback_budget, std::uint64_t seed) {
  const std::size_t budget = env_size("SCALPEL_FUZZ_BUDGET", fallback_budget);
  seed ^= env_size("SCALPEL_FUZZ_SEED", 0);
  const Campaign c = campaign(s, kind, env_size("SCALPEL_FUZZ_FIRST", 0), budget, seed);
  MESSAGE(s.name << ", " << kind_name(kind) << ": " << budget << " trajectories, " << c.failures
                 << " failures, at most " << c.worst << " live tetrahedra per cut original tetrahedron");
  CHECK_MESSAGE(c.failures == 0, c.shown);
}

// Reads a regression file written by listing(); throws naming the file and line.
std::pair<Scene, Trajectory> read_listing(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open");
  std::optional<Scene> scene;
  Trajectory t;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string where = path.string() + ":" + std::to_string(number) + ": ";
    if (line.empty() || line[0] == '#') continue;
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "mesh") {
      std::string kind;
      int cells = 0;
      words >> kind;
      if (scene) throw std::runtime_error(where + "a second `mesh` line");
      if (kind == "gmsh") {
        scene = gmsh_box();
      } else if (kind == "sphere") {
        scene = gmsh_sphere();
      } else if (kind == "box" && (words >> cells) && cells > 0 && (words >> std::ws).eof()) {
        scene = box(cells);
      } else {
        throw std::runtime_error(where + "mesh: expected `box N`, `gmsh` or `sphere`");
      }
      continue;
    }
    Sample x;
    x.place = word == "place";
    BladePose& p = x.pose;
    if ((word != "place" && word != "step") || !scene ||
        !(words >> p.back.x() >> p.back.y() >> p.back.z() >> p.tip.x() >> p.tip.y() >> p.tip.z() >>
          p.cutting_direction.x() >> p.cutting_direction.y() >> p.cutting_direction.z()) ||
        !(words >> std::ws).eof())
      throw std::runtime_error(where + "expected `place` or `step` and nine numbers after a `mesh` line");
    t.samples.push_back(x);
  }
  if (!scene) throw std::runtime_error(path.string() + ": no `mesh` line");
  if (t.samples.empty()) throw std::runtime_error(path.string() + ": no samples");
  return {std::move(*scene), std::move(t)};
}

}  // namespace

// Every failure the fuzzer has found, minimised, replays with invariants 1-5 after every step
// (each file says what it broke and why).
TEST_CASE("fuzz: the minimised failures found so far stay fixed") {
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(SCALPEL_TEST_DATA_DIR "/fuzz"))
    if (e.path().extension() == ".txt") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  REQUIRE(!files.empty());
  for (const auto& f : files) {
    CAPTURE(f.filename().string());
    try {
      const auto [scene, trajectory] = read_listing(f);
      const Outcome o = run(scene, trajectory);
      CHECK_MESSAGE(!o.failed_at, "sample " << o.failed_at.value_or(0) << ": " << o.why);
    } catch (const std::exception& e) {
      FAIL_CHECK(e.what());
    }
  }
}

TEST_CASE("fuzz: tumbling blades through a 3x3x3 box" * doctest::test_suite("slow")) {
  fuzz(box(3), Kind::Tumble, 2, 0xf022);
}
TEST_CASE("fuzz: through-cuts crossing along grid planes" * doctest::test_suite("slow")) {
  fuzz(box(4), Kind::GridCrossing, 4, 0xf023);
}
TEST_CASE("fuzz: partial-depth incisions crossing, box") {
  fuzz(box(3), Kind::PartialCrossing, 4, 0xf025);
}
TEST_CASE("fuzz: through-cut with tremor, box") {
  fuzz(box(3), Kind::Tremor, 2, 0xf026);
}
// A second through-cut crossing the first at a small angle, which near their meeting line lies
// within the tolerances meant for the blade's own tremble (docs/state_machine.md, re-crossing the
// same cut): a cut node of an earlier stroke is the same cut only within 2 degrees.
TEST_CASE("fuzz: through-cuts crossing at random angles, box" * doctest::test_suite("slow")) {
  fuzz(box(3), Kind::ThroughCrossing, 4, 0xf024);
}
TEST_CASE("fuzz: through-cuts crossing at 10-40 degrees, box" * doctest::test_suite("slow")) {
  fuzz(box(3), Kind::ShallowCrossing, 6, 0xf028);
}
TEST_CASE("fuzz: through-cuts crossing at random angles, gmsh" * doctest::test_suite("slow")) {
  fuzz(gmsh_box(), Kind::ThroughCrossing, 4, 0xf027);
}
// Physiological tremor through a curved gmsh mesh (the blade's plane meets its tetrahedra at every
// angle), and crossings there.
TEST_CASE("fuzz: through-cut with tremor, gmsh sphere" * doctest::test_suite("slow")) {
  fuzz(gmsh_sphere(), Kind::Tremor, 4, 0xf029);
}
// A known failure (README, "Not yet"): tremor across the blade's plane while the in-plane tremor
// reverses the blade leaves holes in the section (2-edge and 5-edge end states in its middle,
// tetrahedra the plane crosses left uncut), so the mesh is not severed: 15 of 30 trajectories on
// this box, 20 of 30 on the gmsh sphere, every step valid; none without the in-plane tremor. This pins the
// failure to what it is (wrong pieces, every step valid) on fixed trajectories: it fails once the cause is
// mended, and then becomes a fuzz() case.
TEST_CASE("fuzz: tremor across its plane with reversals leaves the box unsevered (known failure)") {
  const Campaign c = campaign(box(3), Kind::TremorAcross, 5, 3, 0xf02e);
  MESSAGE(c.failures << " of 3 trajectories with wrong pieces:" << c.shown);
  CHECK(c.failures >= 1);
  CHECK(c.wrong_pieces == c.failures);
}
TEST_CASE("fuzz: through-cuts crossing at random angles, gmsh sphere" * doctest::test_suite("slow")) {
  fuzz(gmsh_sphere(), Kind::ThroughCrossing, 4, 0xf02a);
}
TEST_CASE("fuzz: a tip running along the bottom face severs, box") {
  fuzz(box(3), Kind::TipAlongBottom, 4, 0xf02b);
}
TEST_CASE("fuzz: a tip running along the bottom face severs, gmsh" * doctest::test_suite("slow")) {
  fuzz(gmsh_box(), Kind::TipAlongBottom, 4, 0xf02c);
}
