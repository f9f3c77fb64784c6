#include "fem/two_level.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "fem/parallel.hpp"

namespace scalpel {

namespace {

Mat3 cross_matrix(const Vec3& d) {
  Mat3 m;
  m << 0, -d.z(), d.y(), d.z(), 0, -d.x(), -d.y(), d.x(), 0;
  return m;
}

using Vec6 = Eigen::Matrix<double, 6, 1>;

}  // namespace

bool TwoLevelPreconditioner::build(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
                                   std::span<const std::uint8_t> active, std::span<const Vec3> x,
                                   std::vector<Vec3>& scratch, std::vector<double>& partial, int threads) {
  const std::size_t nn = a.size();
  aggregate_.assign(nn, -1);
  p_.assign(nn, Mat36::Zero());
  extended_ = 0;
  const auto usable = [&](std::uint32_t j) { return j < nn && active[j]; };

  // Phase 1: a free node whose active neighbours are all free founds an aggregate with them.
  std::int32_t count = 0;
  for (std::uint32_t i = 0; i < nn; ++i) {
    if (!active[i] || aggregate_[i] >= 0) continue;
    bool free = true;
    for (const std::uint32_t j : a[i].cols) free = free && !(usable(j) && aggregate_[j] >= 0);
    if (!free) continue;
    for (const std::uint32_t j : a[i].cols)
      if (usable(j)) aggregate_[j] = count;
    aggregate_[i] = count++;
  }
  // Phase 2: a leftover joins the phase-1 aggregate it has most neighbours in (lowest id on ties).
  const std::vector<std::int32_t> phase1 = aggregate_;
  for (std::uint32_t i = 0; i < nn; ++i) {
    if (!active[i] || phase1[i] >= 0) continue;
    std::int32_t best = -1;
    int best_links = 0;
    for (const std::uint32_t j : a[i].cols) {
      if (!usable(j) || phase1[j] < 0) continue;
      int links = 0;
      for (const std::uint32_t k : a[i].cols) links += (usable(k) && phase1[k] == phase1[j]) ? 1 : 0;
      if (links > best_links || (links == best_links && phase1[j] < best)) {
        best = phase1[j];
        best_links = links;
      }
    }
    aggregate_[i] = best;
  }
  // Phase 3: what is still free (no aggregated neighbour) groups with its free neighbours.
  for (std::uint32_t i = 0; i < nn; ++i) {
    if (!active[i] || aggregate_[i] >= 0) continue;
    for (const std::uint32_t j : a[i].cols)
      if (usable(j) && aggregate_[j] < 0) aggregate_[j] = count;
    aggregate_[i] = count++;
  }

  const auto na = static_cast<std::size_t>(count);
  nodes_.assign(na, {});
  for (std::uint32_t i = 0; i < nn; ++i)
    if (aggregate_[i] >= 0) nodes_[static_cast<std::size_t>(aggregate_[i])].push_back(i);

  // Orthonormalised rigid modes per aggregate.
  centre_.assign(na, Vec3::Zero());
  modes_.assign(na, Mat6::Zero());
  dropped_.assign(na, {});
  for (std::size_t ag = 0; ag < na; ++ag) {
    Vec3 c = Vec3::Zero();
    for (const std::uint32_t i : nodes_[ag]) c += x[i];
    c /= static_cast<double>(nodes_[ag].size());
    Mat6 g = Mat6::Zero();
    for (const std::uint32_t i : nodes_[ag]) {
      p_[i].leftCols<3>().setIdentity();
      p_[i].rightCols<3>() = -cross_matrix(x[i] - c);
      g.noalias() += p_[i].transpose() * p_[i];
    }
    const Eigen::SelfAdjointEigenSolver<Mat6> eig(g);
    const double top = eig.eigenvalues().maxCoeff();
    Mat6 t = Mat6::Zero();
    for (int m = 0; m < 6; ++m) {
      const double l = eig.eigenvalues()(m);
      if (l > 1e-10 * top)
        t.col(m) = eig.eigenvectors().col(m) / std::sqrt(l);
      else
        dropped_[ag][static_cast<std::size_t>(m)] = true;
    }
    for (const std::uint32_t i : nodes_[ag]) p_[i] = (p_[i] * t).eval();
    centre_[ag] = c;
    modes_[ag] = t;
  }

  // Coarse pattern: aggregates coupled by a block of A.
  nbr_start_.assign(na + 1, 0);
  nbr_.clear();
  std::vector<std::uint32_t> list;
  for (std::size_t ag = 0; ag < na; ++ag) {
    list.clear();
    for (const std::uint32_t i : nodes_[ag])
      for (const std::uint32_t j : a[i].cols)
        if (usable(j) && aggregate_[j] >= 0) list.push_back(static_cast<std::uint32_t>(aggregate_[j]));
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    nbr_.insert(nbr_.end(), list.begin(), list.end());
    nbr_start_[ag + 1] = static_cast<std::uint32_t>(nbr_.size());
  }
  blocks_.assign(nbr_.size(), Mat6::Zero());

  // Block row I of Ac = sum over i in I, j in row i of P_i^T A_ij P_j; aggregates in parallel.
  parallel::for_chunks(threads, na, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t ag = begin; ag < end; ++ag) {
      const std::uint32_t nb = nbr_start_[ag], ne = nbr_start_[ag + 1];
      for (const std::uint32_t i : nodes_[ag]) {
        const BlockRow& row = a[i];
        for (std::size_t k = 0; k < row.cols.size(); ++k) {
          const std::uint32_t j = row.cols[k];
          if (!usable(j) || aggregate_[j] < 0) continue;
          const auto jg = static_cast<std::uint32_t>(aggregate_[j]);
          const auto pos = std::lower_bound(nbr_.begin() + nb, nbr_.begin() + ne, jg) - nbr_.begin();
          const Mat36 t = row.blocks[k] * p_[j];
          blocks_[static_cast<std::size_t>(pos)].noalias() += p_[i].transpose() * t;
        }
      }
      for (std::uint32_t k = nb; k < ne; ++k)
        if (nbr_[k] == ag)
          for (int m = 0; m < 6; ++m)
            if (dropped_[ag][static_cast<std::size_t>(m)]) blocks_[k](m, m) = 1.0;
    }
  });

  // Ac with full 6x6 blocks; column 6J+b holds rows 6I+a for I in nbr(J), value Ac(J, I)(b, a).
  const auto dim = static_cast<Eigen::Index>(6 * na);
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(36 * nbr_.size());
  for (std::size_t jg = 0; jg < na; ++jg)
    for (std::uint32_t k = nbr_start_[jg]; k < nbr_start_[jg + 1]; ++k)
      for (int b = 0; b < 6; ++b)
        for (int c = 0; c < 6; ++c)
          triplets.emplace_back(static_cast<Eigen::Index>(6 * nbr_[k]) + c,
                                static_cast<Eigen::Index>(6 * jg) + b, blocks_[k](b, c));
  ac_.resize(dim, dim);
  ac_.setFromTriplets(triplets.begin(), triplets.end());
  ldlt_.compute(ac_);
  rc_.setZero(dim);
  ec_.setZero(dim);

  // omega from lambda_max(D^{-1} A), 15 power iterations from a fixed start.
  std::vector<Vec3> u(nn, Vec3::Zero());
  std::vector<Vec3>& w = scratch;
  for (std::size_t i = 0; i < nn; ++i)
    if (active[i]) u[i] = Vec3(1.0, 0.5 + 0.5 * std::sin(static_cast<double>(i)), -1.0);
  double lambda = 0;
  for (int it = 0; it < 15; ++it) {
    multiply(a, active, u, w, partial, threads);
    double uu = 0, wn = 0;
    for (std::size_t i = 0; i < nn; ++i) {
      w[i] = diag_inverse[i] * w[i];
      uu += u[i].squaredNorm();
      wn += w[i].squaredNorm();
    }
    if (!(uu > 0) || !(wn > 0)) break;
    lambda = std::sqrt(wn / uu);
    for (std::size_t i = 0; i < nn; ++i) u[i] = w[i] / std::sqrt(wn);
  }
  omega_ = lambda > 0 ? std::min(1.0, 1.2 / lambda) : 0.5;
  factored_ = na > 0 && ldlt_.info() == Eigen::Success && (ldlt_.vectorD().array() > 0).all();
  return factored_;
}

void TwoLevelPreconditioner::extend(std::uint32_t node, std::uint32_t parent, const Vec3& x) {
  if (parent >= aggregate_.size() || aggregate_[parent] < 0) return;
  if (node >= aggregate_.size()) {
    aggregate_.resize(node + 1, -1);
    p_.resize(node + 1, Mat36::Zero());
  }
  if (aggregate_[node] >= 0) return;  // a reused slot keeps its place
  const auto ag = static_cast<std::size_t>(aggregate_[parent]);
  aggregate_[node] = aggregate_[parent];
  Mat36 b;
  b.leftCols<3>().setIdentity();
  b.rightCols<3>() = -cross_matrix(x - centre_[ag]);
  p_[node] = b * modes_[ag];
  nodes_[ag].push_back(node);
  ++extended_;
}

void TwoLevelPreconditioner::coarse_correct(std::span<const std::uint8_t> active, const std::vector<Vec3>& r,
                                            std::vector<Vec3>& z, int threads) {
  const std::size_t na = nodes_.size();
  parallel::for_chunks(threads, na, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t ag = begin; ag < end; ++ag) {
      Vec6 s = Vec6::Zero();
      for (const std::uint32_t i : nodes_[ag])
        if (i < active.size() && active[i]) s.noalias() += p_[i].transpose() * r[i];
      rc_.segment<6>(static_cast<Eigen::Index>(6 * ag)) = s;
    }
  });
  ec_ = ldlt_.solve(rc_);
  const std::size_t nn = std::min(z.size(), aggregate_.size());
  parallel::for_chunks(threads, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      if (active[i] && aggregate_[i] >= 0)
        z[i].noalias() += p_[i] * ec_.segment<6>(6 * static_cast<Eigen::Index>(aggregate_[i]));
  });
}

void TwoLevelPreconditioner::apply(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
                                   std::span<const std::uint8_t> active, const std::vector<Vec3>& r,
                                   std::vector<Vec3>& z, std::vector<Vec3>& scratch,
                                   std::vector<double>& partial, int threads) {
  const std::size_t nn = a.size();
  std::vector<Vec3>& t = scratch;
  parallel::for_chunks(threads, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      z[i] = active[i] ? Vec3(omega_ * (diag_inverse[i] * r[i])) : Vec3::Zero();
  });
  if (!factored_) return;  // one smoothing sweep: still symmetric positive definite
  multiply(a, active, z, t, partial, threads);
  parallel::for_chunks(threads, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) t[i] = r[i] - t[i];
  });
  coarse_correct(active, t, z, threads);
  multiply(a, active, z, t, partial, threads);
  parallel::for_chunks(threads, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      if (active[i]) z[i] += omega_ * (diag_inverse[i] * (r[i] - t[i]));
  });
}

}  // namespace scalpel
