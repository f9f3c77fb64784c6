// The local solve after a topology change (fem/tissue.hpp, docs/tissue.md): the region around the
// rows a cut changed, and CG on it with the rest of the tissue held, before the global solve.
#include <algorithm>
#include <cmath>

#include "fem/parallel.hpp"
#include "fem/tissue.hpp"

namespace scalpel {

using parallel::chunk_count;
using parallel::for_chunks;
using parallel::sum;

bool TissueModel::local_region(std::span<const std::uint32_t> changed, std::size_t active_count, int rings) {
  const std::size_t nn = rows_.size();
  in_local_.assign(nn, 0);
  local_.clear();
  for (const std::uint32_t i : changed)
    if (i < nn && active_[i] && !in_local_[i]) {
      in_local_[i] = 1;
      local_.push_back(i);
    }
  // A change that reaches half of the tissue (the first step, a severed part) is not local.
  if (local_.empty() || 2 * local_.size() > active_count) return false;
  // Rings are added while the region stays within local_fraction of the active nodes (the first
  // ring always).
  const auto cap = static_cast<std::size_t>(settings_.local_fraction * static_cast<double>(active_count));
  for (int ring = 0, begin = 0; ring < rings; ++ring) {
    const auto end = static_cast<int>(local_.size());
    for (int k = begin; k < end; ++k)
      for (const std::uint32_t j : rows_[local_[static_cast<std::size_t>(k)]].cols)
        if (active_[j] && !in_local_[j]) {
          in_local_[j] = 1;
          local_.push_back(j);
        }
    if (local_.size() > cap && ring > 0) {  // drop this ring
      for (auto k = static_cast<std::size_t>(end); k < local_.size(); ++k) in_local_[local_[k]] = 0;
      local_.resize(static_cast<std::size_t>(end));
      break;
    }
    begin = end;
  }
  return true;
}

// CG on the rows of local_ (the nodes within local_rings of a changed row), with v outside them
// held: v_L += A_LL^{-1} r_L approximately; r_ is kept current everywhere. The preconditioner is
// symmetric block Gauss-Seidel on A_LL, M = (D + L) D^{-1} (D + U) (SSOR with omega = 1: Saad,
// "Iterative Methods for Sparse Linear Systems", 2nd ed., section 10.2): on the skin slab it needs
// about 19 iterations where block-Jacobi needed 48, whatever the size of the region, and in
// Eisenstat's form an iteration costs about what a block-Jacobi one does.
void TissueModel::solve_locally(std::size_t active_count, double target, StepStats& st,
                                parallel::Team& team) {
  const std::size_t nn = rows_.size();
  group_of_.resize(nn);
  // An iteration costs about one product with A_LL: a sweep each way, each over half of the blocks.
  const int max_iterations =
      std::min(settings_.local_max_iterations,
               static_cast<int>(settings_.local_budget * static_cast<double>(active_count) /
                                static_cast<double>(local_.size())));
  st.local_nodes = local_.size();

  group_local_region();
  const auto diag = [&](const std::uint32_t i) -> const Mat3& { return rows_[i].blocks[rows_[i].diag]; };
  std::array<double, 3> sum_a{}, sum_b{};  // per group, added in group order
  const auto total = [](const std::array<double, 3>& v) { return v[0] + v[1] + v[2]; };

  // Eisenstat's form ("Efficient implementation of a class of preconditioned conjugate gradient
  // methods", SIAM J. Sci. Stat. Comput. 2, 1981): CG with the preconditioner D on
  // A^ = (D + L)^{-1} A (D + U)^{-1}, the same iterates as CG with M, where
  // A = (D + L) + (D + U) - D makes a product with A^ one sweep each way:
  //   A^ p = t + (D + L)^{-1} (p - D t),  t = (D + U)^{-1} p.
  // Unknown x^ = (D + U) dv, residual r^ = (D + L)^{-1} r.
  const auto residuals = [&](const LocalGroup& g, std::size_t h) {
    double sum = 0;
    for (std::size_t k = 0; k < g.nodes.size(); ++k) sum += local_residual(g, k).squaredNorm();
    sum_a[h] = sum;
  };
  // r^ = (D + L)^{-1} r, then p = D r^; sums ||r||^2 and r^ . D r^.
  const auto start = [&](const LocalGroup& g, std::size_t h) {
    double rl = 0, rz = 0;
    for (std::size_t k = 0; k < g.nodes.size(); ++k) {
      const std::uint32_t i = g.nodes[k];
      rl += r_[i].squaredNorm();
      z_[i] = diag_inverse_[i] * (r_[i] - g.lower(k, z_));
      dv_[i].setZero();  // dv_ holds x^ until the end
      p_[i] = diag(i) * z_[i];
      rz += z_[i].dot(p_[i]);
    }
    sum_a[h] = rl;
    sum_b[h] = rz;
  };
  for_interior_groups(team, start);
  start(groups_[2], 2);
  double rl = total(sum_a), rz = total(sum_b);
  const double stop = std::max(settings_.local_tolerance * std::sqrt(rl), target);
  // The true residual costs half a product: it is evaluated when rz, scaled by the ratio
  // ||r||^2 / rz last seen, says the stop may be reached, and every eighth iteration.
  double ratio = rz > 0 ? rl / rz : 0;
  int it = 0;
  double beta = 0;
  // p = t + beta p (t holds D r^ of the last iteration) and t = (D + U)^{-1} p, backwards.
  const auto backward = [&](const LocalGroup& g) {
    for (std::size_t k = g.nodes.size(); k-- > 0;) {
      const std::uint32_t i = g.nodes[k];
      if (it > 0) p_[i] = t_[i] + beta * p_[i];
      t_[i] = diag_inverse_[i] * (p_[i] - g.upper(k, t_));
    }
  };
  // q = (D + L)^{-1} (p - D t), forwards; sums p . (q + t) = p . A^ p.
  const auto forward = [&](const LocalGroup& g, std::size_t h) {
    double pq = 0;
    for (std::size_t k = 0; k < g.nodes.size(); ++k) {
      const std::uint32_t i = g.nodes[k];
      q_[i] = diag_inverse_[i] * (p_[i] - diag(i) * t_[i] - g.lower(k, q_));
      pq += p_[i].dot(q_[i] + t_[i]);
    }
    sum_a[h] = pq;
  };
  while (std::sqrt(rl) > stop && it < max_iterations) {
    backward(groups_[2]);
    for_interior_groups(team, [&](const LocalGroup& g, std::size_t h) {
      backward(g);
      forward(g, h);
    });
    forward(groups_[2], 2);
    const double pq = total(sum_a);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    for_all_groups(team, [&](const LocalGroup& g, std::size_t h) {
      double sum = 0;
      for (const std::uint32_t i : g.nodes) {
        dv_[i] += alpha * p_[i];
        z_[i] -= alpha * (q_[i] + t_[i]);
        t_[i] = diag(i) * z_[i];  // the preconditioned residual D r^, for rz and p
        sum += z_[i].dot(t_[i]);
      }
      sum_b[h] = sum;
    });
    const double rz_new = total(sum_b);
    ++it;
    if (ratio * rz_new <= stop * stop || it % 8 == 0) {
      for_all_groups(team, residuals);
      rl = total(sum_a);
      ratio = rz_new > 0 ? rl / rz_new : 0;
    }
    beta = rz_new / rz;
    rz = rz_new;
  }
  st.local_iterations = it;
  finish_local_solve(team);
}

// The sweeps on two threads: the region is split at the median along the longest side of its
// bounding box into H0 and H1, and the nodes are ordered I0 = H0, I1 = the nodes of H1 with no
// neighbour in H0, then the interface G = the rest of H1, each group in slot order. No block
// couples I0 and I1, so a sweep over them runs on both threads at once; G (12 per cent of the
// region during the incision of bench/bench_fem.cpp) is swept alone. Gauss-Seidel in this order
// needs as many iterations as in slot order (21.7 against 21.5 there, mass-spring 32.9 against
// 32.9).
void TissueModel::group_local_region() {
  const auto& x = mesh_.positions();
  std::sort(local_.begin(), local_.end());
  for (auto& group : groups_) group.nodes.clear();
  if (local_.size() < 2 * kMinHalf) {
    groups_[2].nodes = local_;  // too small to share: all of it swept alone
    for (const std::uint32_t i : local_) group_of_[i] = 2;
  } else {
    Eigen::AlignedBox3d box;
    for (const std::uint32_t i : local_) box.extend(x[i]);
    Eigen::Index axis = 0;
    box.sizes().maxCoeff(&axis);
    std::vector<std::uint32_t>& order = groups_[2].nodes;  // scratch
    order = local_;
    const auto less = [&](std::uint32_t a, std::uint32_t b) {
      return x[a][axis] < x[b][axis] || (x[a][axis] == x[b][axis] && a < b);
    };
    // Split so that I0 and I1 come out the same size: at the median, then moved by half the
    // interface that split gave.
    const auto split = [&](std::size_t h0) {
      const auto middle = order.begin() + static_cast<std::ptrdiff_t>(h0);
      std::nth_element(order.begin(), middle, order.end(), less);
      for (const std::uint32_t i : local_) group_of_[i] = 1;
      for (auto k = order.begin(); k != middle; ++k) group_of_[*k] = 0;
      std::size_t interface = 0;
      for (const std::uint32_t i : local_)
        if (group_of_[i] == 1)
          for (const std::uint32_t j : rows_[i].cols)
            if (in_local_[j] && group_of_[j] == 0) {
              group_of_[i] = 2;
              ++interface;
              break;
            }
      return interface;
    };
    split((local_.size() - split(local_.size() / 2)) / 2);
    order.clear();
    for (const std::uint32_t i : local_) groups_[group_of_[i]].nodes.push_back(i);
  }
  // Each node's couplings in the region, before it in that order (lower) and after it (upper).
  const auto before = [&](std::uint32_t i, std::uint32_t j) {
    return group_of_[j] < group_of_[i] || (group_of_[j] == group_of_[i] && j < i);
  };
  for (LocalGroup& group : groups_) {
    group.links.clear();
    group.start.clear();
    for (const std::uint32_t i : group.nodes) {
      const BlockRow& row = rows_[i];
      group.start.push_back(static_cast<std::uint32_t>(group.links.size()));
      for (std::size_t k = 0; k < row.cols.size(); ++k)
        if (k != row.diag && in_local_[row.cols[k]] && before(i, row.cols[k]))
          group.links.push_back({row.cols[k], &row.blocks[k]});
      group.start.push_back(static_cast<std::uint32_t>(group.links.size()));
      for (std::size_t k = 0; k < row.cols.size(); ++k)
        if (k != row.diag && in_local_[row.cols[k]] && !before(i, row.cols[k]))
          group.links.push_back({row.cols[k], &row.blocks[k]});
    }
    group.start.push_back(static_cast<std::uint32_t>(group.links.size()));
  }
}

Vec3 TissueModel::local_residual(const LocalGroup& g, std::size_t k) const {
  const std::uint32_t i = g.nodes[k];
  return Vec3(rows_[i].blocks[rows_[i].diag] * z_[i] + g.lower(k, z_));
}

void TissueModel::finish_local_solve(parallel::Team& team) {
  // dv = (D + U)^{-1} x^ in place, backwards; r_L = (D + L) r^.
  const auto unknown = [&](const LocalGroup& g) {
    for (std::size_t k = g.nodes.size(); k-- > 0;) {
      const std::uint32_t i = g.nodes[k];
      dv_[i] = diag_inverse_[i] * (dv_[i] - g.upper(k, dv_));
    }
  };
  unknown(groups_[2]);
  for_interior_groups(team, [&](const LocalGroup& g, std::size_t) { unknown(g); });
  for_all_groups(team, [&](const LocalGroup& g, std::size_t) {
    for (std::size_t k = 0; k < g.nodes.size(); ++k) r_[g.nodes[k]] = local_residual(g, k);
  });
  // r_L is current; the ring just outside L sees the update through its columns in L.
  for (const std::uint32_t i : local_) v_[i] += dv_[i];
  for (const std::uint32_t i : local_)
    for (const std::uint32_t j : rows_[i].cols)
      if (active_[j] && !in_local_[j]) {
        in_local_[j] = 2;  // updated once
        const BlockRow& row = rows_[j];
        for (std::size_t b = 0; b < row.cols.size(); ++b)
          if (in_local_[row.cols[b]] == 1) r_[j].noalias() -= row.blocks[b] * dv_[row.cols[b]];
      }
}

}  // namespace scalpel
