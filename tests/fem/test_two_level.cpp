#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>

#include "fem/block_cholesky.hpp"
#include "fem/element.hpp"
#include "fem/two_level.hpp"
#include "mesh/generators.hpp"

using namespace scalpel;

namespace {

// A team of 1 to 4 threads, kept for the whole test run.
parallel::Team& team(int threads) {
  static std::array<std::unique_ptr<parallel::Team>, 5> teams;
  auto& t = teams.at(static_cast<std::size_t>(threads));
  if (!t) t = std::make_unique<parallel::Team>(threads);
  return *t;
}

// Room for the per-chunk sums of multiply() (chunks of 256 rows).
std::vector<double> partials(std::size_t n) {
  return std::vector<double>(n / 256 + 1, 0.0);
}

// A = m I + h K of a co-rotational box at rest (skin-like: h K dominates, as in a tissue step),
// nodes on z = 0 fixed. Block rows as the tissue model assembles them.
struct System {
  TetMesh mesh;
  BlockRows a;
  std::vector<std::uint8_t> active;
  std::vector<Mat3> diag_inverse;
};

System make_system(std::array<int, 3> cells, double stiffness_scale = 1.0) {
  System s;
  s.mesh = make_box({.max = Vec3(0.03, 0.03, 0.01), .cells = cells});
  const std::size_t nn = s.mesh.node_capacity();
  s.active.assign(nn, 0);
  for (const NodeId n : s.mesh.nodes()) s.active[n.index] = s.mesh.rest(n).z() > 1e-12 ? 1 : 0;
  std::vector<std::vector<std::uint32_t>> cols(nn);
  for (std::uint32_t i = 0; i < nn; ++i) cols[i].push_back(i);
  for (const TetId t : s.mesh.tets())
    for (const std::uint32_t i : s.mesh.tet_vertex_indices(t.index))
      for (const std::uint32_t j : s.mesh.tet_vertex_indices(t.index)) cols[i].push_back(j);
  s.a.grow(nn);
  for (std::uint32_t i = 0; i < nn; ++i) {
    std::sort(cols[i].begin(), cols[i].end());
    cols[i].erase(std::unique(cols[i].begin(), cols[i].end()), cols[i].end());
    s.a.set(i, cols[i]);
  }
  Material mat;
  mat.young = 50e3 * stiffness_scale;
  const double h = 1.0 / 3600;  // dt^2 [s^2]
  for (const TetId t : s.mesh.tets()) {
    const auto v = s.mesh.tet_vertex_indices(t.index);
    std::array<Vec3, 4> x;
    for (size_t k = 0; k < 4; ++k) x[k] = s.mesh.rest_positions()[v[k]];
    const TetRest rest = make_tet_rest(x, mat, 0.05);
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    CorotationalState st;
    evaluate_corotational(rest, x, q, st);
    for (int p = 0; p < 4; ++p) {
      const BlockRow& row = s.a[v[static_cast<size_t>(p)]];
      const std::span<Mat3> blocks = s.a.blocks(v[static_cast<size_t>(p)]);
      blocks[row.diag].diagonal().array() += mat.density * rest.mass_volume / 4;
      for (int b = 0; b < 4; ++b) {
        const auto k =
            std::find(row.cols.begin(), row.cols.end(), v[static_cast<size_t>(b)]) - row.cols.begin();
        if (s.active[v[static_cast<size_t>(b)]])
          blocks[static_cast<std::size_t>(k)] += h * corotational_block(st, p, b);
      }
    }
  }
  s.diag_inverse.assign(nn, Mat3::Identity());
  for (std::uint32_t i = 0; i < nn; ++i) {
    if (!s.active[i]) {
      for (Mat3& blk : s.a.blocks(i)) blk.setZero();
      continue;
    }
    s.diag_inverse[i] = s.a[i].blocks[s.a[i].diag].inverse();
  }
  return s;
}

std::vector<Vec3> random_vector(const System& s, std::mt19937& rng) {
  std::normal_distribution<double> n;
  std::vector<Vec3> v(s.a.size(), Vec3::Zero());
  for (std::size_t i = 0; i < v.size(); ++i)
    if (s.active[i]) v[i] = Vec3(n(rng), n(rng), n(rng));
  return v;
}

double dot(const std::vector<Vec3>& x, const std::vector<Vec3>& y) {
  double d = 0;
  for (std::size_t i = 0; i < x.size(); ++i) d += x[i].dot(y[i]);
  return d;
}

// The default cycle and the smoothed-aggregation one with a degree-2 Chebyshev smoother.
const TwoLevelOptions kSmoothed{.smoothing_degree = 2, .prolongator_weight = 4.0 / 3.0};
const std::array<TwoLevelOptions, 2> kVariants = {TwoLevelOptions{}, kSmoothed};

struct Cycle {
  TwoLevelPreconditioner pre;
  std::vector<double> partial;
  Cycle(const System& s, int threads, TwoLevelOptions options = {})
      : pre(options), partial(partials(s.a.size())) {
    REQUIRE(pre.build(s.a, s.diag_inverse, s.active, s.mesh.positions(), partial, team(threads)));
  }
  std::vector<Vec3> apply(const System& s, const std::vector<Vec3>& r, int threads) {
    std::vector<Vec3> z(r.size(), Vec3::Zero());
    pre.apply(s.a, s.diag_inverse, s.active, r, z, team(threads));
    return z;
  }
};

// lambda_max(D^{-1} A) by 400 power iterations.
double lambda_max(const System& s) {
  std::vector<Vec3> u(s.a.size(), Vec3::Zero()), w(s.a.size(), Vec3::Zero());
  std::mt19937 rng(1);
  std::normal_distribution<double> n;
  for (std::size_t i = 0; i < u.size(); ++i)
    if (s.active[i]) u[i] = Vec3(n(rng), n(rng), n(rng));
  std::vector<double> partial = partials(u.size());
  double lambda = 0;
  for (int it = 0; it < 400; ++it) {
    multiply(s.a, s.active, u, w, partial, team(1));
    double uu = 0, wn = 0;
    for (std::size_t i = 0; i < u.size(); ++i) {
      w[i] = s.diag_inverse[i] * w[i];
      uu += u[i].squaredNorm();
      wn += w[i].squaredNorm();
    }
    lambda = std::sqrt(wn / uu);
    for (std::size_t i = 0; i < u.size(); ++i) u[i] = w[i] / std::sqrt(wn);
  }
  return lambda;
}

// Preconditioned CG from zero on A v = b to ||r|| <= 1e-6 ||b||; returns the iteration count.
template <class Precondition>
int pcg(const System& s, const std::vector<Vec3>& b, Precondition precondition) {
  const std::size_t n = b.size();
  std::vector<Vec3> v(n, Vec3::Zero()), r = b, q(n, Vec3::Zero());
  std::vector<double> partial = partials(n);
  std::vector<Vec3> z = precondition(r), p = z;
  double rz = dot(r, z);
  const double target = 1e-6 * std::sqrt(dot(b, b));
  int it = 0;
  while (std::sqrt(dot(r, r)) > target && it < 2000) {
    const double pq = multiply(s.a, s.active, p, q, partial, team(1));
    const double alpha = rz / pq;
    for (std::size_t i = 0; i < n; ++i) {
      v[i] += alpha * p[i];
      r[i] -= alpha * q[i];
    }
    z = precondition(r);
    const double rz_new = dot(r, z);
    for (std::size_t i = 0; i < n; ++i) p[i] = z[i] + (rz_new / rz) * p[i];
    rz = rz_new;
    ++it;
  }
  return it;
}

// P^T A P summed block by block over the rows of A, block (I, J) at [I * na + J], as Ac holds it
// (a dropped direction: unit diagonal).
std::vector<TwoLevelPreconditioner::Mat6> galerkin_product(const System& s,
                                                           const TwoLevelPreconditioner& pre) {
  using Mat36 = TwoLevelPreconditioner::Mat36;
  using Mat6 = TwoLevelPreconditioner::Mat6;
  const std::size_t na = pre.aggregate_count(), nn = s.a.size();
  std::vector<std::vector<std::pair<std::size_t, Mat36>>> p(nn);
  for (std::uint32_t i = 0; i < nn; ++i)
    for (std::size_t ag = 0; ag < na; ++ag)
      if (const Mat36 b = pre.prolongator_block(i, ag); !b.isZero(0)) p[i].emplace_back(ag, b);
  std::vector<Mat6> product(na * na, Mat6::Zero());
  for (std::uint32_t i = 0; i < nn; ++i) {
    if (!s.active[i]) continue;
    for (std::size_t k = 0; k < s.a[i].cols.size(); ++k) {
      const std::uint32_t j = s.a[i].cols[k];
      if (!s.active[j]) continue;
      for (const auto& [ai, pi] : p[i])
        for (const auto& [aj, pj] : p[j]) product[ai * na + aj] += pi.transpose() * s.a[i].blocks[k] * pj;
    }
  }
  for (std::size_t ag = 0; ag < na; ++ag)
    for (int k = 0; k < 6; ++k)
      if (product[ag * na + ag](k, k) == 0.0) product[ag * na + ag](k, k) = 1.0;
  return product;
}

// Ac against galerkin_product().
void check_galerkin(const System& s, const TwoLevelPreconditioner& pre) {
  const std::size_t na = pre.aggregate_count();
  const std::vector<TwoLevelPreconditioner::Mat6> expected = galerkin_product(s, pre);
  double scale = 0;
  for (const auto& e : expected) scale = std::max(scale, e.cwiseAbs().maxCoeff());
  REQUIRE(scale > 0);
  double worst = 0;
  for (std::size_t ai = 0; ai < na; ++ai)
    for (std::size_t aj = 0; aj < na; ++aj)
      worst = std::max(worst, (pre.coarse_block(ai, aj) - expected[ai * na + aj]).cwiseAbs().maxCoeff());
  CHECK(worst <= 1e-12 * scale);
}

}  // namespace

TEST_CASE("two-level: the coarse operator is the Galerkin product P^T A P") {
  const System s = make_system({6, 6, 2});
  for (const TwoLevelOptions& options : kVariants) {
    Cycle c(s, 2, options);
    check_galerkin(s, c.pre);
  }
}

TEST_CASE("two-level: aggregates cover the active nodes and the smoother bound covers the spectrum") {
  const System s = make_system({6, 6, 2});
  Cycle c(s, 1);
  CHECK(c.pre.aggregate_count() > 1);
  CHECK(c.pre.aggregate_count() < s.mesh.node_count() / 4);
  for (std::uint32_t i = 0; i < s.a.size(); ++i)
    CHECK((c.pre.aggregate(i) >= 0) == static_cast<bool>(s.active[i]));
  // The Lanczos estimate is a Ritz value (from below) and close; the smoother's upper end covers
  // lambda_max, which keeps the cycle positive definite.
  const double lambda = lambda_max(s);
  CAPTURE(lambda);
  CAPTURE(c.pre.lambda_estimate());
  CHECK(c.pre.lambda_estimate() <= lambda * (1 + 1e-9));
  CHECK(c.pre.lambda_estimate() >= 0.95 * lambda);
  CHECK(c.pre.smoothing_upper() >= lambda);
}

namespace {

// u . B w == w . B u and u . B u > 0 for `count` random pairs, B the cycle on `threads` threads.
void check_symmetric_positive(const System& s, Cycle& c, int threads, unsigned seed, int count) {
  std::mt19937 rng(seed);
  for (int k = 0; k < count; ++k) {
    const std::vector<Vec3> u = random_vector(s, rng), w = random_vector(s, rng);
    const std::vector<Vec3> bu = c.apply(s, u, threads), bw = c.apply(s, w, threads);
    CHECK(std::abs(dot(u, bw) - dot(w, bu)) <= 1e-10 * std::sqrt(dot(u, bu) * dot(w, bw)));
    CHECK(dot(u, bu) > 0);
  }
}

}  // namespace

TEST_CASE("two-level: the cycle is symmetric positive definite") {
  const System s = make_system({6, 6, 2});
  for (const TwoLevelOptions& options : kVariants) {
    Cycle c(s, 2, options);
    check_symmetric_positive(s, c, 2, 3, 10);
  }
}

TEST_CASE("two-level: the coarse correction is exact on the coarse space") {
  // For r = A P e the coarse step alone gives back P e; the cycle must then reduce the A-norm error
  // of a rigid-mode field far more than one smoothing step does.
  const System s = make_system({6, 6, 2});
  Cycle c(s, 1);
  std::vector<Vec3> x(s.a.size(), Vec3::Zero()), r(s.a.size(), Vec3::Zero());
  for (const NodeId n : s.mesh.nodes())
    if (s.active[n.index]) x[n.index] = Vec3(0, 0, 1) + Vec3(0.3, 0, 0).cross(s.mesh.rest(n));  // smooth
  std::vector<double> partial = partials(s.a.size());
  const double xax = multiply(s.a, s.active, x, r, partial, team(1));
  const std::vector<Vec3> z = c.apply(s, r, 1);
  std::vector<Vec3> e(x.size()), ae(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) e[i] = x[i] - z[i];
  const double eae = multiply(s.a, s.active, e, ae, partial, team(1));
  CHECK(eae < 0.05 * xax);
}

TEST_CASE("two-level: CG needs far fewer iterations than with block-Jacobi") {
  const System s = make_system({12, 12, 4});
  Cycle c(s, 2);
  std::mt19937 rng(5);
  const std::vector<Vec3> b = random_vector(s, rng);
  const int jacobi = pcg(s, b, [&](const std::vector<Vec3>& r) {
    std::vector<Vec3> z(r.size());
    for (std::size_t i = 0; i < r.size(); ++i)
      z[i] = s.active[i] ? Vec3(s.diag_inverse[i] * r[i]) : Vec3::Zero();
    return z;
  });
  const int two_level = pcg(s, b, [&](const std::vector<Vec3>& r) { return c.apply(s, r, 2); });
  Cycle smoothed(s, 2, kSmoothed);
  const int two_level_smoothed =
      pcg(s, b, [&](const std::vector<Vec3>& r) { return smoothed.apply(s, r, 2); });
  CAPTURE(jacobi);
  CAPTURE(two_level);
  CAPTURE(two_level_smoothed);
  CHECK(two_level < 2000);
  CHECK(3 * two_level < jacobi);
  // A smoothed prolongator and a degree-2 smoother take fewer (costlier) iterations.
  CHECK(two_level_smoothed < two_level);
}

TEST_CASE("two-level: a stale cycle extended by new nodes stays positive definite") {
  // The cycle is built on a softer material, then applied to the stiffer matrix: still SPD.
  // With a softer material lambda_max(D^{-1} A) is about the same (both scale with the modulus
  // against the same mass), so the smoother bound still holds.
  const System soft = make_system({6, 6, 2}, 0.2);
  const System s = make_system({6, 6, 2});
  for (const TwoLevelOptions& options : kVariants) {
    Cycle c(soft, 1, options);
    check_symmetric_positive(s, c, 1, 9, 5);
    // A node extended into its parent's aggregate takes part in the coarse correction.
    const std::uint32_t parent = s.mesh.nodes().back().index;
    const auto node = static_cast<std::uint32_t>(s.a.size());
    c.pre.extend(node, parent, s.mesh.positions()[parent]);
    CHECK(c.pre.aggregate(node) == c.pre.aggregate(parent));
    CHECK(c.pre.extended() == 1);
  }
}

TEST_CASE("two-level: growth() reports the most grown aggregate, and a rebuild may keep lambda") {
  const System s = make_system({6, 6, 2});
  Cycle c(s, 1);
  CHECK(c.pre.growth() == 1.0);
  const std::uint32_t parent = s.mesh.nodes().back().index;
  std::size_t size = 0;
  for (std::uint32_t i = 0; i < s.a.size(); ++i)
    size += c.pre.aggregate(i) == c.pre.aggregate(parent) ? 1 : 0;
  REQUIRE(size > 0);
  const auto first = static_cast<std::uint32_t>(s.a.size());
  for (std::uint32_t k = 0; k < size; ++k) c.pre.extend(first + k, parent, s.mesh.positions()[parent]);
  CHECK(c.pre.growth() == doctest::Approx(2.0));  // no other aggregate grew
  // A rebuild starts over; with estimate = false it keeps lambda, here on a stiffer matrix.
  const System stiff = make_system({6, 6, 2}, 3.0);
  const double lambda = c.pre.lambda_estimate();
  REQUIRE(c.pre.build(stiff.a, stiff.diag_inverse, stiff.active, stiff.mesh.positions(), c.partial, team(2),
                      false));
  CHECK(c.pre.growth() == 1.0);
  CHECK(c.pre.extended() == 0);
  CHECK(c.pre.lambda_estimate() == lambda);
  Cycle fresh(stiff, 2);
  CHECK(fresh.pre.lambda_estimate() != lambda);
  // Everything else is what a fresh build gives.
  std::mt19937 rng(5);
  const std::vector<Vec3> r = random_vector(stiff, rng);
  CHECK(c.pre.aggregate_count() == fresh.pre.aggregate_count());
  const std::vector<Vec3> z = c.apply(stiff, r, 2), zf = fresh.apply(stiff, r, 2);
  double gap = 0, norm = 0;
  for (std::size_t i = 0; i < z.size(); ++i) {
    gap = std::max(gap, (z[i] - zf[i]).norm());
    norm = std::max(norm, zf[i].norm());
  }
  CAPTURE(gap);
  CHECK(gap > 0);  // the smoother weight differs
  CHECK(gap < 0.5 * norm);
}

namespace {

// CG on s from a random right-hand side needs fewer iterations with the split cycle than with the
// kept one.
void check_fewer_iterations(const System& s, Cycle& split, Cycle& kept, unsigned seed) {
  std::mt19937 rng(seed);
  const std::vector<Vec3> b = random_vector(s, rng);
  const int with_split = pcg(s, b, [&](const std::vector<Vec3>& r) { return split.apply(s, r, 1); });
  const int without = pcg(s, b, [&](const std::vector<Vec3>& r) { return kept.apply(s, r, 1); });
  CAPTURE(with_split);
  CAPTURE(without);
  CHECK(with_split < without);
}

constexpr double kCutPlane = 0.0169;  // [m] between two planes of nodes

// s cut through along x = kCutPlane: the couplings across the plane are removed (A keeps its two
// diagonal parts, so it stays positive definite) and every block is multiplied by `scale` (A
// changes everywhere from step to step). changed: the rows that lost a coupling.
System cut_system(const System& s, double scale, std::vector<std::uint32_t>& changed) {
  System cut = s;
  const auto side = [&](std::uint32_t i) { return cut.mesh.positions()[i].x() > kCutPlane; };
  changed.clear();
  for (std::uint32_t i = 0; i < cut.a.size(); ++i) {
    const BlockRow& row = cut.a[i];
    std::vector<std::uint32_t> kept;
    std::vector<Mat3> kept_blocks;
    for (std::size_t k = 0; k < row.cols.size(); ++k)
      if (side(row.cols[k]) == side(i)) {
        kept.push_back(row.cols[k]);
        kept_blocks.push_back(scale * row.blocks[k]);
      }
    if (kept.size() != row.cols.size()) changed.push_back(i);
    cut.a.set(i, kept);
    std::copy(kept_blocks.begin(), kept_blocks.end(), cut.a.blocks(i).begin());
    if (cut.active[i]) cut.diag_inverse[i] = row.blocks[row.diag].inverse();
  }
  return cut;
}

}  // namespace

TEST_CASE("two-level: an aggregate a cut severs is split into its parts") {
  // A cut through the box: aggregates grown before straddle it.
  const System s = make_system({8, 8, 2});
  std::vector<std::uint32_t> changed;
  const System cut = cut_system(s, 1.0, changed);
  const auto side = [&](std::uint32_t i) { return cut.mesh.positions()[i].x() > kCutPlane; };
  const auto straddling = [&](const TwoLevelPreconditioner& pre) {
    int count = 0;
    for (std::uint32_t i = 0; i < cut.a.size(); ++i)
      for (std::uint32_t j = i + 1; j < cut.a.size(); ++j)
        count +=
            (cut.active[i] && cut.active[j] && pre.aggregate(i) == pre.aggregate(j) && side(i) != side(j))
                ? 1
                : 0;
    return count;
  };
  std::vector<std::uint32_t> all(cut.a.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;

  Cycle split(s, 1), kept(s, 1);
  REQUIRE(straddling(split.pre) > 0);
  const std::size_t before = split.pre.aggregate_count();
  CHECK(split.pre.severs(cut.a, cut.active, all));
  CHECK(split.pre.aggregate_count() == before);  // a query: nothing split yet
  const std::size_t made = split.pre.split_severed(cut.a, cut.active, all, cut.mesh.positions(), team(1));
  CHECK(made > 0);
  CHECK(split.pre.aggregate_count() == before + made);
  CHECK(straddling(split.pre) == 0);
  CHECK(split.pre.factored());
  check_galerkin(cut, split.pre);
  check_symmetric_positive(cut, split, 1, 11, 5);
  // Each side then has its own rigid motions in the coarse space: CG converges faster than with
  // the severed aggregates kept.
  check_fewer_iterations(cut, split, kept, 9);
  // Nothing left to split; a smoothed prolongator is left alone.
  CHECK_FALSE(split.pre.severs(cut.a, cut.active, all));
  CHECK(split.pre.split_severed(cut.a, cut.active, all, cut.mesh.positions(), team(1)) == 0);
  // What counts is the prolongator built, not the options set for the next build.
  Cycle smoothed(s, 1, kSmoothed);
  smoothed.pre.set_options({});
  CHECK_FALSE(smoothed.pre.severs(cut.a, cut.active, all));
  CHECK(smoothed.pre.split_severed(cut.a, cut.active, all, cut.mesh.positions(), team(1)) == 0);
  kept.pre.set_options(kSmoothed);
  CHECK(kept.pre.severs(cut.a, cut.active, all));
}

TEST_CASE("two-level: an aggregate the nodes of cuts grew is split into connected pieces of its size") {
  // Built with the nodes beyond x = 1.2 cm inactive; then they join the aggregates of their
  // neighbours (extend(), as the nodes a cut creates join their parent's): the aggregates along
  // that plane grow to hold the whole far side.
  const System s = make_system({12, 12, 2});
  System partial = s;
  const auto far = [&](std::uint32_t i) { return s.mesh.rest_positions()[i].x() > 0.012; };
  for (std::uint32_t i = 0; i < partial.a.size(); ++i)
    if (far(i)) partial.active[i] = 0;
  const auto grow = [&](TwoLevelPreconditioner& pre) {
    for (bool added = true; added;) {
      added = false;
      for (std::uint32_t i = 0; i < s.a.size(); ++i) {
        if (!s.active[i] || pre.aggregate(i) >= 0) continue;
        for (const std::uint32_t j : s.a[i].cols)
          if (pre.aggregate(j) >= 0) {
            pre.extend(i, j, s.mesh.positions()[i]);
            added = true;
            break;
          }
      }
    }
  };
  Cycle split(partial, 1), kept(partial, 1);
  grow(split.pre);
  grow(kept.pre);
  const auto sizes = [&](const TwoLevelPreconditioner& pre) {
    std::vector<std::size_t> n(pre.aggregate_count(), 0);
    for (std::uint32_t i = 0; i < s.a.size(); ++i)
      if (pre.aggregate(i) >= 0) ++n[static_cast<std::size_t>(pre.aggregate(i))];
    return n;
  };
  const std::vector<std::size_t> built = sizes(Cycle(partial, 1).pre);
  const std::size_t largest_built = *std::max_element(built.begin(), built.end());
  const std::vector<std::size_t> grown = sizes(split.pre);
  REQUIRE(*std::max_element(grown.begin(), grown.end()) > 3 * largest_built);

  std::vector<std::uint32_t> all(s.a.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  CHECK_FALSE(split.pre.severs(s.a, s.active, all));  // connected: no split without a growth limit
  CHECK(split.pre.severs(s.a, s.active, all, 2.0));
  const std::size_t before = split.pre.aggregate_count();
  const std::size_t made =
      split.pre.split_severed(s.a, s.active, all, s.mesh.positions(), team(1), false, 2.0);
  CHECK(made > 0);
  CHECK(split.pre.aggregate_count() == before + made);
  CHECK_FALSE(split.pre.severs(s.a, s.active, all, 2.0));
  // Pieces of about the size the aggregates were built with (a small rest joins a neighbour), each
  // connected over the pattern of A.
  const std::vector<std::size_t> pieces = sizes(split.pre);
  CHECK(*std::max_element(pieces.begin(), pieces.end()) <= 3 * largest_built / 2);
  for (std::size_t ag = 0; ag < split.pre.aggregate_count(); ++ag) {
    std::vector<std::uint32_t> members;
    for (std::uint32_t i = 0; i < s.a.size(); ++i)
      if (s.active[i] && split.pre.aggregate(i) == static_cast<std::int32_t>(ag)) members.push_back(i);
    if (members.empty()) continue;
    std::vector<std::uint8_t> reached(s.a.size(), 0);
    std::vector<std::uint32_t> stack{members.front()};
    reached[members.front()] = 1;
    std::size_t count = 0;
    while (!stack.empty()) {
      const std::uint32_t i = stack.back();
      stack.pop_back();
      ++count;
      for (const std::uint32_t j : s.a[i].cols)
        if (s.active[j] && !reached[j] && split.pre.aggregate(j) == static_cast<std::int32_t>(ag)) {
          reached[j] = 1;
          stack.push_back(j);
        }
    }
    CAPTURE(ag);
    CHECK(count == members.size());
  }
  CHECK(split.pre.factored());
  check_galerkin(s, split.pre);
  check_symmetric_positive(s, split, 1, 23, 5);
  // The far side has rigid motions of its own again: CG converges faster than with the grown
  // aggregates kept.
  check_fewer_iterations(s, split, kept, 29);
}

TEST_CASE("two-level: a split recomputes the coarse operator near the cut and keeps it elsewhere") {
  // The cut of the test above on a larger box, reported by the rows it changed only, with A
  // changed a little everywhere.
  const System s = make_system({16, 16, 2});
  std::vector<std::uint32_t> changed;
  const System cut = cut_system(s, 1.001, changed);
  Cycle c(s, 1);
  const std::size_t before = c.pre.aggregate_count();
  std::vector<TwoLevelPreconditioner::Mat6> old(before * before);
  for (std::size_t i = 0; i < before; ++i)
    for (std::size_t j = 0; j < before; ++j) old[i * before + j] = c.pre.coarse_block(i, j);
  REQUIRE(c.pre.split_severed(cut.a, cut.active, changed, cut.mesh.positions(), team(2)) > 0);
  REQUIRE(c.pre.factored());
  CHECK_FALSE(c.pre.split_whole());
  const std::size_t na = c.pre.aggregate_count();

  // Recomputed: the aggregates holding a changed row (among them the parts) and those coupled to
  // their members. Their blocks are those of P^T A P for the cut A, the others those of before.
  std::vector<std::uint8_t> recomputed(na, 0);
  for (const std::uint32_t i : changed)
    if (cut.active[i]) recomputed[static_cast<std::size_t>(c.pre.aggregate(i))] = 1;
  const std::vector<std::uint8_t> holding = recomputed;
  for (std::uint32_t i = 0; i < cut.a.size(); ++i)
    if (cut.active[i] && holding[static_cast<std::size_t>(c.pre.aggregate(i))])
      for (const std::uint32_t j : cut.a[i].cols)
        if (cut.active[j]) recomputed[static_cast<std::size_t>(c.pre.aggregate(j))] = 1;
  const std::vector<TwoLevelPreconditioner::Mat6> fresh = galerkin_product(cut, c.pre);
  double scale = 0;
  for (const auto& e : fresh) scale = std::max(scale, e.cwiseAbs().maxCoeff());
  int kept = 0, coupled_kept = 0, fresh_count = 0;
  double worst = 0, asymmetry = 0;
  for (std::size_t i = 0; i < na; ++i)
    for (std::size_t j = 0; j < na; ++j) {
      const TwoLevelPreconditioner::Mat6 block = c.pre.coarse_block(i, j);
      asymmetry = std::max(asymmetry, (block - c.pre.coarse_block(j, i).transpose()).cwiseAbs().maxCoeff());
      if (recomputed[i] || recomputed[j]) {
        worst = std::max(worst, (block - fresh[i * na + j]).cwiseAbs().maxCoeff());
        ++fresh_count;
      } else {
        CHECK(block == old[i * before + j]);
        ++kept;
        coupled_kept += (i != j && !block.isZero(0)) ? 1 : 0;
      }
    }
  CAPTURE(fresh_count);
  CAPTURE(kept);
  CHECK(worst <= 1e-12 * scale);
  CHECK(asymmetry <= 1e-12 * scale);
  CHECK(coupled_kept > 0);  // the box is large enough to keep some blocks
  check_symmetric_positive(cut, c, 1, 17, 5);
  // Asked for the whole operator (the caller's choice when Ac is old), every block is recomputed.
  Cycle whole(s, 1);
  REQUIRE(whole.pre.split_severed(cut.a, cut.active, changed, cut.mesh.positions(), team(2), true) > 0);
  CHECK(whole.pre.factored());
  CHECK(whole.pre.split_whole());
  check_galerkin(cut, whole.pre);
}

TEST_CASE("two-level: a split whose updated coarse operator does not factorise recomputes it whole") {
  // A a thousand times stiffer everywhere since the build: the recomputed blocks no longer fit the
  // kept ones. The split then recomputes every block.
  const System s = make_system({16, 16, 2});
  std::vector<std::uint32_t> changed;
  const System cut = cut_system(s, 1000.0, changed);
  Cycle c(s, 1);
  REQUIRE(c.pre.split_severed(cut.a, cut.active, changed, cut.mesh.positions(), team(2)) > 0);
  CHECK(c.pre.factored());
  CHECK(c.pre.split_whole());  // the caller counts the age of Ac from here
  check_galerkin(cut, c.pre);
  check_symmetric_positive(cut, c, 1, 19, 5);
}

TEST_CASE("two-level: the cycle is bit-identical for one and two threads") {
  const System s = make_system({10, 10, 3});
  for (const TwoLevelOptions& options : kVariants) {
    Cycle c1(s, 1, options), c2(s, 2, options);
    std::mt19937 rng(13);
    const std::vector<Vec3> r = random_vector(s, rng);
    CHECK(c1.pre.lambda_estimate() == c2.pre.lambda_estimate());
    CHECK(c1.apply(s, r, 1) == c2.apply(s, r, 2));
  }
}

TEST_CASE("block Cholesky: solves a matrix of 6 x 6 blocks, with the fill of scalar AMD") {
  // An SPD matrix of dense 6 x 6 blocks on a 12 x 12 grid of blocks, as the coarse operator is.
  constexpr int kSide = 12, kBlocks = kSide * kSide, n = 6 * kBlocks;
  using Mat6 = BlockCholesky::Mat6;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<std::vector<BlockCholesky::Entry>> rows(kBlocks);
  const auto link = [&](int i, int j, double diagonal) {
    Mat6 m;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) m(r, c) = 0.1 * u(rng);
    if (i == j) {
      m = (m + m.transpose()).eval();
      m.diagonal().array() += diagonal;  // diagonally dominant: positive definite
      rows[static_cast<std::size_t>(i)].push_back({static_cast<std::uint32_t>(i), m});
      return;
    }
    rows[static_cast<std::size_t>(i)].push_back({static_cast<std::uint32_t>(j), m});
    rows[static_cast<std::size_t>(j)].push_back({static_cast<std::uint32_t>(i), m.transpose()});
  };
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) {
      const int b = y * kSide + x;
      if (x + 1 < kSide) link(b, b + 1, 0);
      link(b, b, 10.0);
      if (y + 1 < kSide) link(b, b + kSide, 0);
    }
  // The scalar matrix of block rows.
  const auto scalar = [](const std::vector<std::vector<BlockCholesky::Entry>>& block_rows) {
    std::vector<Eigen::Triplet<double>> entries;
    for (std::size_t i = 0; i < block_rows.size(); ++i)
      for (const auto& e : block_rows[i])
        for (int r = 0; r < 6; ++r)
          for (int c = 0; c < 6; ++c)
            entries.emplace_back(6 * static_cast<int>(i) + r, 6 * static_cast<int>(e.col) + c, e.block(r, c));
    const auto size = 6 * static_cast<Eigen::Index>(block_rows.size());
    Eigen::SparseMatrix<double> m(size, size);
    m.setFromTriplets(entries.begin(), entries.end());
    return m;
  };
  const Eigen::SparseMatrix<double> a = scalar(rows);

  BlockCholesky chol;
  chol.analyze(rows);
  CHECK(chol.same_structure(rows));
  REQUIRE(chol.factorize(rows));
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
  Eigen::VectorXd x = b;
  chol.solve(x);
  CHECK((a * x - b).norm() < 1e-12 * b.norm());

  // As sparse as Eigen's factor with AMD on the scalar unknowns, far sparser than without an
  // ordering (L's scalars: 36 per block below the diagonal, 15 below the diagonal of each diagonal
  // block; Eigen's LDL^T keeps a unit diagonal).
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> amd(a);
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> natural(
      a);
  const auto scalars = static_cast<Eigen::Index>(36 * (chol.fill() - chol.size()) + 15 * chol.size());
  CAPTURE(scalars);
  CAPTURE(amd.matrixL().nestedExpression().nonZeros());
  CAPTURE(natural.matrixL().nestedExpression().nonZeros());
  CHECK(scalars <= 5 * amd.matrixL().nestedExpression().nonZeros() / 4);
  CHECK(scalars < natural.matrixL().nestedExpression().nonZeros());

  // New values on the same structure: factorize() alone.
  for (auto& row : rows)
    for (auto& e : row) e.block *= 2.0;
  CHECK(chol.same_structure(rows));
  REQUIRE(chol.factorize(rows));
  x = b;
  chol.solve(x);
  CHECK((2.0 * (a * x) - b).norm() < 1e-12 * b.norm());

  // Row 40 split in two, as a coarse aggregate severed by a cut: the new row 144 takes its links
  // to the right and below, and comes right after row 40 in the kept elimination order.
  {
    auto split_rows = rows;
    const std::uint32_t from = 40, added = kBlocks;
    split_rows.emplace_back();
    auto& source = split_rows[from];
    for (std::size_t k = 0; k < source.size();) {
      const std::uint32_t col = source[k].col;
      if (col == from + 1 || col == from + kSide) {
        split_rows[added].push_back({col, source[k].block});
        for (auto& e : split_rows[col])
          if (e.col == from) e.col = added;
        source.erase(source.begin() + static_cast<std::ptrdiff_t>(k));
      } else {
        ++k;
      }
    }
    split_rows[added].push_back({added, Mat6(10.0 * Mat6::Identity())});
    const std::size_t fill = chol.fill();
    BlockCholesky kept = chol;
    const std::array<std::uint32_t, 1> follows = {from};
    kept.analyze_following(split_rows, follows);
    CHECK(kept.same_structure(split_rows));
    REQUIRE(kept.factorize(split_rows));
    const Eigen::SparseMatrix<double> split_a = scalar(split_rows);
    const Eigen::VectorXd sb = Eigen::VectorXd::LinSpaced(n + 6, 1.0, -1.0);
    Eigen::VectorXd sx = sb;
    kept.solve(sx);
    CHECK((split_a * sx - sb).norm() < 1e-12 * sb.norm());
    CAPTURE(fill);
    CAPTURE(kept.fill());
    CHECK(kept.fill() <= fill + fill / 10);  // about the fill of the order it kept
  }

  // A new block changes the structure; an indefinite matrix is refused.
  link(0, kBlocks - 1, 0);
  CHECK_FALSE(chol.same_structure(rows));
  REQUIRE(rows[0][1].col == 0);
  rows[0][1].block.diagonal().array() -= 100.0;  // the diagonal block of row 0, now indefinite
  chol.analyze(rows);
  CHECK_FALSE(chol.factorize(rows));
}
