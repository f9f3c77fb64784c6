#include "fem/two_level.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "fem/parallel.hpp"

namespace scalpel {

namespace {

// Orders the blocks of a row of Ac by column.
bool by_column(const BlockCholesky::Entry& l, const BlockCholesky::Entry& r) {
  return l.col < r.col;
}

Mat3 cross_matrix(const Vec3& d) {
  Mat3 m;
  m << 0, -d.z(), d.y(), d.z(), 0, -d.x(), -d.y(), d.x(), 0;
  return m;
}

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat36 = TwoLevelPreconditioner::Mat36;
using Mat6 = TwoLevelPreconditioner::Mat6;

// Adds `value` to the block keyed `key` (the member `Key` of an entry) in a short list kept in
// first-seen order.
template <auto Key, class Entry, class Block>
void accumulate(std::vector<Entry>& list, std::uint32_t key, const Block& value) {
  for (Entry& e : list)
    if (e.*Key == key) {
      e.block += value;
      return;
    }
  list.push_back({key, value});
}

// Row i of the rigid modes of an aggregate with centroid c: [ I3 | -[x_i - c]x ].
Mat36 rigid_row(const Vec3& xi, const Vec3& c) {
  Mat36 t;
  t.leftCols<3>().setIdentity();
  t.rightCols<3>() = -cross_matrix(xi - c);
  return t;
}

// Centroid c of the nodes and the map V L^{-1/2} that orthonormalises their rigid modes, from the
// eigenpairs (L, V) of sum T_i^T T_i; a direction with L < 1e-10 max L keeps a zero column (its
// coarse unknown decouples).
std::pair<Vec3, Mat6> rigid_basis(std::span<const std::uint32_t> nodes, std::span<const Vec3> x) {
  Vec3 c = Vec3::Zero();
  for (const std::uint32_t i : nodes) c += x[i];
  c /= static_cast<double>(nodes.size());
  Mat6 g = Mat6::Zero();
  for (const std::uint32_t i : nodes) {
    const Mat36 t = rigid_row(x[i], c);
    g.noalias() += t.transpose() * t;
  }
  const Eigen::SelfAdjointEigenSolver<Mat6> eig(g);
  const double top = eig.eigenvalues().maxCoeff();
  Mat6 t = Mat6::Zero();
  for (int m = 0; m < 6; ++m) {
    const double l = eig.eigenvalues()(m);
    if (l > 1e-10 * top) t.col(m) = eig.eigenvectors().col(m) / std::sqrt(l);
  }
  return {c, t};
}

// f(task, begin, end) over [0, n) in `tasks` ranges of about equal length, on the team (for loops
// over aggregates: too few for the node-sized chunks of parallel::for_chunks).
constexpr std::size_t kAggregateTasks = 16;
template <class F>
void for_ranges(parallel::Team& team, std::size_t n, F&& f) {
  team.run(kAggregateTasks,
           [&](std::size_t t) { f(t, t * n / kAggregateTasks, (t + 1) * n / kAggregateTasks); });
}

}  // namespace

void TwoLevelPreconditioner::reserve_nodes(std::size_t n) {
  if (aggregate_.size() >= n) return;
  aggregate_.resize(n, -1);
  prolongator_.resize(n);
  for (auto* v : {&residual_, &direction_, &next_, &offset_}) v->resize(n, Vec3::Zero());
  seen_.resize(n, 0);
  piece_of_.resize(n, -1);
}

// Largest Ritz value of D^{-1} A from the CG coefficients of block-Jacobi CG (Saad 2003, 6.7.3):
// the Lanczos matrix has T(j,j) = 1/alpha_j + beta_{j-1}/alpha_{j-1}, T(j,j+1) = sqrt(beta_j)/alpha_j.
void TwoLevelPreconditioner::estimate_lambda(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
                                             std::span<const std::uint8_t> active,
                                             std::vector<double>& partial, parallel::Team& team) {
  const std::size_t nn = a.size();
  std::vector<Vec3> r(nn), z(nn), p(nn), q(nn);
  // Chunk sums in chunk order, as everywhere in the solver: the estimate does not depend on the
  // thread count.
  double rz = parallel::reduce(team, nn, partial, [&](std::size_t i) {
    r[i] = active[i] ? Vec3(1.0, 0.5 + 0.5 * std::sin(static_cast<double>(i)), -1.0) : Vec3::Zero();
    z[i] = diag_inverse[i] * r[i];
    p[i] = z[i];
    return r[i].dot(z[i]);
  });
  std::vector<double> alpha, beta;
  for (int it = 0; it < 15 && rz > 0; ++it) {
    const double pq = multiply(a, active, p, q, partial, team);
    if (!(pq > 0)) break;
    const double al = rz / pq;
    const double rz_new = parallel::reduce(team, nn, partial, [&](std::size_t i) {
      r[i] -= al * q[i];
      z[i] = active[i] ? Vec3(diag_inverse[i] * r[i]) : Vec3::Zero();
      return r[i].dot(z[i]);
    });
    alpha.push_back(al);
    beta.push_back(rz_new / rz);
    rz = rz_new;
    const double b = beta.back();
    parallel::for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) p[i] = z[i] + b * p[i];
    });
  }
  const auto k = static_cast<Eigen::Index>(alpha.size());
  lambda_ = 0;
  if (k == 0) return;
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(k, k);
  for (Eigen::Index j = 0; j < k; ++j) {
    const auto uj = static_cast<std::size_t>(j);
    t(j, j) = 1.0 / alpha[uj] + (j > 0 ? beta[uj - 1] / alpha[uj - 1] : 0.0);
    if (j + 1 < k) t(j, j + 1) = t(j + 1, j) = std::sqrt(beta[uj]) / alpha[uj];
  }
  lambda_ =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(t, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
}

bool TwoLevelPreconditioner::build(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
                                   std::span<const std::uint8_t> active, std::span<const Vec3> x,
                                   std::vector<double>& partial, parallel::Team& team, bool estimate) {
  const std::size_t nn = a.size();
  aggregate_.assign(nn, -1);
  offset_.assign(nn, Vec3::Zero());
  prolongator_.resize(nn);
  for (std::vector<Entry>& row : prolongator_) row.clear();  // keeps their storage
  seen_.assign(nn, 0);
  piece_of_.assign(nn, -1);
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
  std::vector<std::vector<std::uint32_t>> nodes(na);
  for (std::uint32_t i = 0; i < nn; ++i)
    if (aggregate_[i] >= 0) nodes[static_cast<std::size_t>(aggregate_[i])].push_back(i);

  // Tentative prolongator: orthonormalised rigid modes per aggregate (each writes its own nodes).
  std::vector<Mat36>& tentative = tentative_;
  tentative.resize(nn);
  centre_.assign(na, Vec3::Zero());
  modes_.assign(na, Mat6::Zero());
  for_ranges(team, na, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t ag = begin; ag < end; ++ag) {
      const auto [c, t] = rigid_basis(nodes[ag], x);
      for (const std::uint32_t i : nodes[ag]) {
        offset_[i] = x[i] - c;
        tentative[i] = rigid_row(x[i], c) * t;
      }
      centre_[ag] = c;
      modes_[ag] = t;
    }
  });

  if (estimate || !(lambda_ > 0)) estimate_lambda(a, diag_inverse, active, partial, team);

  // Smoothed prolongator, row i: T_i - w D_i^{-1} sum_j A_ij T_j, blocks sorted by aggregate.
  const double w = lambda_ > 0 ? options_.prolongator_weight / lambda_ : 0.0;
  smoothed_ = w > 0;
  parallel::for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (aggregate_[i] < 0) continue;
      std::vector<Entry>& row = prolongator_[i];
      row.push_back({static_cast<std::uint32_t>(aggregate_[i]), tentative[i]});
      if (w > 0)
        for (std::size_t k = 0; k < a[i].cols.size(); ++k) {
          const std::uint32_t j = a[i].cols[k];
          if (!usable(j) || aggregate_[j] < 0) continue;
          accumulate<&Entry::aggregate>(row, static_cast<std::uint32_t>(aggregate_[j]),
                                        Mat36(-w * (diag_inverse[i] * (a[i].blocks[k] * tentative[j]))));
        }
      std::sort(row.begin(), row.end(),
                [](const Entry& l, const Entry& r) { return l.aggregate < r.aggregate; });
    }
  });
  members_.assign(na, {});
  for (std::uint32_t i = 0; i < nn; ++i)
    for (std::size_t k = 0; k < prolongator_[i].size(); ++k)
      members_[prolongator_[i][k].aggregate].push_back({i, static_cast<std::uint32_t>(k)});
  built_size_.resize(na);
  for (std::size_t ag = 0; ag < na; ++ag) built_size_[ag] = static_cast<std::uint32_t>(members_[ag].size());
  piece_size_ = built_size_;

  residual_.assign(nn, Vec3::Zero());
  direction_.assign(nn, Vec3::Zero());
  next_.assign(nn, Vec3::Zero());
  return galerkin(a, active, team);
}

// Block row I of Ac = P^T A P for the current P and A, sorted by column. ap: scratch.
void TwoLevelPreconditioner::coarse_row(std::size_t ag, std::span<const BlockRow> a,
                                        std::span<const std::uint8_t> active, std::vector<Entry>& ap,
                                        std::vector<BlockCholesky::Entry>& row) const {
  const std::size_t nn = a.size();
  const auto usable = [&](std::uint32_t j) { return j < nn && active[j]; };
  row.clear();
  const auto add = [&](std::uint32_t col, const Mat6& value) {
    accumulate<&BlockCholesky::Entry::col>(row, col, value);
  };
  // Block row I of Ac = sum over the members i of I of P(i, I)^T (A P)_i, with the row (A P)_i
  // summed per aggregate (with a smoothed P, once per aggregate a node belongs to: two to three
  // times). With P = T: P(i, I) = R_i V_I, R_i = rigid_row(x_i, c_I) = [ I3 | -[d_i]x ] with
  // d_i = offset_[i], so Ac_IJ = V_I^T W_IJ V_J with
  //   W_IJ = sum_{i in I} R_i^T Y_iJ,  Y_iJ = sum_{j in J} A_ij R_j = [ A_ij | -A_ij [d_j]x ],
  // and R_i^T Y = [ Y ; [d_i]x Y ]: half the products (all coarse rows of the 20-thousand-
  // tetrahedron slab of bench/bench_fem.cpp: 1.3-1.8 ms on one thread instead of 2.0-2.4).
  for (const Member& m : members_[ag]) {
    const std::uint32_t i = m.node;
    if (!active[i]) continue;
    ap.clear();
    for (std::size_t k = 0; k < a[i].cols.size(); ++k) {
      const std::uint32_t j = a[i].cols[k];
      if (!usable(j)) continue;
      const Mat3& aij = a[i].blocks[k];
      if (smoothed_) {
        for (const Entry& e : prolongator_[j])
          accumulate<&Entry::aggregate>(ap, e.aggregate, Mat36(aij * e.block));
      } else if (aggregate_[j] >= 0) {
        Mat36 y;
        y.leftCols<3>() = aij;
        y.rightCols<3>().noalias() = -aij * cross_matrix(offset_[j]);
        accumulate<&Entry::aggregate>(ap, static_cast<std::uint32_t>(aggregate_[j]), y);
      }
    }
    if (smoothed_) {
      const Mat36& pi = prolongator_[i][m.entry].block;
      for (const Entry& e : ap) add(e.aggregate, pi.transpose() * e.block);
    } else {
      const Mat3 di = cross_matrix(offset_[i]);
      for (const Entry& e : ap) {
        Mat6 w;
        w.topRows<3>() = e.block;
        w.bottomRows<3>().noalias() = di * e.block;
        add(e.aggregate, w);
      }
    }
  }
  if (!smoothed_)
    for (BlockCholesky::Entry& e : row) e.block = modes_[ag].transpose() * e.block * modes_[e.col];
  // A dropped direction (zero column of P) gets a unit diagonal: its coarse unknown decouples.
  add(static_cast<std::uint32_t>(ag), Mat6::Zero());
  for (BlockCholesky::Entry& e : row)
    if (e.col == ag)
      for (int k = 0; k < 6; ++k)
        if (e.block(k, k) == 0.0) e.block(k, k) = 1.0;
  std::sort(row.begin(), row.end(), by_column);
}

// Ac = P^T A P for the current P and A, and its factorisation.
bool TwoLevelPreconditioner::galerkin(std::span<const BlockRow> a, std::span<const std::uint8_t> active,
                                      parallel::Team& team) {
  const std::size_t na = members_.size();
  coarse_rows_.resize(na);
  ap_.resize(kAggregateTasks);
  for_ranges(team, na, [&](std::size_t task, std::size_t begin, std::size_t end) {
    for (std::size_t ag = begin; ag < end; ++ag) coarse_row(ag, a, active, ap_[task], coarse_rows_[ag]);
  });
  outdated_.assign(na, 0);
  if (!cholesky_.same_structure(coarse_rows_)) cholesky_.analyze(coarse_rows_);
  return factorize();
}

bool TwoLevelPreconditioner::factorize() {
  const std::size_t na = members_.size();
  rc_.setZero(static_cast<Eigen::Index>(6 * na));
  ec_.setZero(static_cast<Eigen::Index>(6 * na));
  factored_ = na > 0 && lambda_ > 0 && cholesky_.factorize(coarse_rows_);
  return factored_;
}

// The aggregates holding one of `nodes`, sorted.
std::vector<std::uint32_t> TwoLevelPreconditioner::touched(std::span<const std::uint32_t> nodes) const {
  std::vector<std::uint32_t> out;
  for (const std::uint32_t i : nodes)
    if (i < aggregate_.size() && aggregate_[i] >= 0) out.push_back(static_cast<std::uint32_t>(aggregate_[i]));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void TwoLevelPreconditioner::connected_parts(std::uint32_t ag, std::span<const BlockRow> a,
                                             std::span<const std::uint8_t> active, Parts& out) {
  // Connected parts of the active members over the current pattern (members_ in order: the parts
  // and their numbering do not depend on anything else). seen_ marks the visited ones.
  const std::size_t nn = a.size();
  out.parts.clear();
  out.rest.clear();
  for (const Member& m : members_[ag]) {
    const std::uint32_t s0 = m.node;
    if (!active[s0]) {
      out.rest.push_back(s0);
      continue;
    }
    if (seen_[s0]) continue;
    out.parts.emplace_back();
    out.stack.assign(1, s0);
    seen_[s0] = 1;
    while (!out.stack.empty()) {
      const std::uint32_t i = out.stack.back();
      out.stack.pop_back();
      out.parts.back().push_back(i);
      for (const std::uint32_t j : a[i].cols)
        if (j < nn && active[j] && !seen_[j] && aggregate_[j] == static_cast<std::int32_t>(ag)) {
          seen_[j] = 1;
          out.stack.push_back(j);
        }
    }
  }
  for (const auto& part : out.parts)
    for (const std::uint32_t i : part) seen_[i] = 0;
}

void TwoLevelPreconditioner::touch(std::span<const std::uint32_t> nodes) {
  for (const std::uint32_t ag : touched(nodes))
    if (ag < outdated_.size()) outdated_[ag] = 1;
}

bool TwoLevelPreconditioner::grown(std::uint32_t ag, const Parts& found, double growth) const {
  if (!(growth > 0)) return false;
  std::size_t n = 0;
  for (const auto& part : found.parts) n += part.size();
  return static_cast<double>(n) > growth * std::max<double>(1, piece_size_[ag]);
}

bool TwoLevelPreconditioner::severs(std::span<const BlockRow> a, std::span<const std::uint8_t> active,
                                    std::span<const std::uint32_t> nodes, double growth) {
  if (smoothed_ || members_.empty()) return false;
  reserve_nodes(a.size());
  Parts found;
  for (const std::uint32_t ag : touched(nodes)) {
    connected_parts(ag, a, active, found);
    if (grown(ag, found, growth)) grown_pieces(ag, a, found);
    if (found.parts.size() > 1) return true;
  }
  return false;
}

void TwoLevelPreconditioner::grown_pieces(std::uint32_t ag, std::span<const BlockRow> a, Parts& found) {
  const std::size_t size = std::max<std::size_t>(1, piece_size_[ag]);
  std::vector<std::vector<std::uint32_t>> pieces;
  // piece_of_ (by node; -1 outside the parts) marks the part's nodes, then their pieces.
  for (const auto& part : found.parts)
    for (const std::uint32_t i : part) piece_of_[i] = -2;
  for (const auto& part : found.parts) {
    if (part.size() <= size) {
      for (const std::uint32_t i : part) piece_of_[i] = static_cast<std::int32_t>(pieces.size());
      pieces.push_back(part);
      continue;
    }
    std::vector<std::uint32_t> sorted = part;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t first_piece = pieces.size();
    for (const std::uint32_t seed : sorted) {
      if (piece_of_[seed] != -2) continue;
      const auto id = static_cast<std::int32_t>(pieces.size());
      pieces.emplace_back(1, seed);
      piece_of_[seed] = id;
      std::vector<std::uint32_t>& piece = pieces.back();
      for (std::size_t k = 0; k < piece.size() && piece.size() < size; ++k)
        for (const std::uint32_t j : a[piece[k]].cols)
          if (j < piece_of_.size() && piece_of_[j] == -2 && piece.size() < size) {
            piece_of_[j] = id;
            piece.push_back(j);
          }
    }
    // Small pieces (what the larger ones left between them) join a neighbouring piece of the part.
    for (std::size_t p = first_piece; p < pieces.size(); ++p) {
      if (2 * pieces[p].size() >= size || pieces[p].empty()) continue;
      std::int32_t into = -1;
      for (const std::uint32_t i : pieces[p]) {
        for (const std::uint32_t j : a[i].cols)
          if (j < piece_of_.size() && piece_of_[j] >= static_cast<std::int32_t>(first_piece) &&
              piece_of_[j] != static_cast<std::int32_t>(p) &&
              pieces[static_cast<std::size_t>(piece_of_[j])].size() > 0) {
            into = piece_of_[j];
            break;
          }
        if (into >= 0) break;
      }
      if (into < 0) continue;
      auto& target = pieces[static_cast<std::size_t>(into)];
      for (const std::uint32_t i : pieces[p]) {
        piece_of_[i] = into;
        target.push_back(i);
      }
      pieces[p].clear();
    }
  }
  for (const auto& piece : pieces)
    for (const std::uint32_t i : piece) piece_of_[i] = -1;
  std::erase_if(pieces, [](const std::vector<std::uint32_t>& p) { return p.empty(); });
  found.parts = std::move(pieces);
}

std::size_t TwoLevelPreconditioner::split_severed(std::span<const BlockRow> a,
                                                  std::span<const std::uint8_t> active,
                                                  std::span<const std::uint32_t> nodes,
                                                  std::span<const Vec3> x, parallel::Team& team, bool whole,
                                                  double growth) {
  split_whole_ = false;
  if (smoothed_ || members_.empty()) return 0;
  reserve_nodes(a.size());
  const std::size_t before = members_.size();
  std::vector<std::uint32_t> follows;  // per added aggregate: the one it was split from
  Parts found;
  for (const std::uint32_t ag : touched(nodes)) {
    connected_parts(ag, a, active, found);
    if (grown(ag, found, growth)) grown_pieces(ag, a, found);
    auto& parts = found.parts;
    if (parts.size() < 2) continue;
    if (ag < outdated_.size()) outdated_[ag] = 1;  // its row is recomputed (below)
    // The inactive members have no coarse part: they stay with the first one.
    parts.front().insert(parts.front().end(), found.rest.begin(), found.rest.end());
    for (std::size_t k = 0; k < parts.size(); ++k) {
      const auto id = k == 0 ? ag : static_cast<std::uint32_t>(members_.size());
      if (k > 0) {
        members_.emplace_back();
        built_size_.emplace_back();
        piece_size_.push_back(piece_size_[ag]);
        centre_.emplace_back();
        modes_.emplace_back();
        follows.push_back(ag);
      }
      std::vector<std::uint32_t>& part = parts[k];
      std::sort(part.begin(), part.end());
      const auto [c, t] = rigid_basis(part, x);
      centre_[id] = c;
      modes_[id] = t;
      members_[id].clear();
      for (const std::uint32_t i : part) {
        aggregate_[i] = static_cast<std::int32_t>(id);
        offset_[i] = x[i] - c;
        prolongator_[i].assign(1, Entry{id, rigid_row(x[i], c) * t});
        members_[id].push_back({i, 0});
      }
      built_size_[id] = static_cast<std::uint32_t>(members_[id].size());
    }
  }
  const std::size_t made = members_.size() - before;
  if (made == 0) return 0;
  if (whole || coarse_rows_.size() != before || cholesky_.size() != before) {
    galerkin(a, active, team);
    split_whole_ = true;
    return made;
  }
  // Ac is updated, not recomputed: the block rows (and columns) of the parts, of the aggregates a
  // cut changed since their rows were computed (touch(), extend()) and of their neighbours are
  // recomputed from the current A; the others keep their (stale) values, as after extend(). The
  // ring of neighbours keeps fresh blocks of grown aggregates away from stale ones (mixed, they
  // need not be positive definite); a matrix that does not factorise is recomputed whole. The
  // elimination order is kept, each new part right after the aggregate it was split from.
  outdated_.resize(members_.size(), 1);
  std::vector<std::uint8_t> is_changed = outdated_;
  for (std::uint32_t ag = 0; ag < members_.size(); ++ag) {
    if (!outdated_[ag]) continue;
    for (const Member& m : members_[ag])
      for (const std::uint32_t j : a[m.node].cols)
        if (j < a.size() && active[j] && aggregate_[j] >= 0)
          is_changed[static_cast<std::uint32_t>(aggregate_[j])] = 1;
  }
  std::vector<std::uint32_t> changed;
  for (std::uint32_t ag = 0; ag < members_.size(); ++ag)
    if (is_changed[ag]) changed.push_back(ag);
  // The other rows coupled to those, before or after: their blocks in the recomputed columns are
  // replaced by the transposes of the recomputed rows.
  std::vector<std::uint32_t> border;
  for (const std::uint32_t ag : changed)
    if (ag < before)
      for (const BlockCholesky::Entry& e : coarse_rows_[ag])
        if (!is_changed[e.col]) border.push_back(e.col);
  coarse_rows_.resize(members_.size());
  ap_.resize(kAggregateTasks);
  for_ranges(team, changed.size(), [&](std::size_t task, std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k)
      coarse_row(changed[k], a, active, ap_[task], coarse_rows_[changed[k]]);
  });
  for (const std::uint32_t id : changed)
    for (const BlockCholesky::Entry& e : coarse_rows_[id])
      if (!is_changed[e.col]) border.push_back(e.col);
  std::sort(border.begin(), border.end());
  border.erase(std::unique(border.begin(), border.end()), border.end());
  for (const std::uint32_t j : border)
    std::erase_if(coarse_rows_[j], [&](const BlockCholesky::Entry& e) { return is_changed[e.col] != 0; });
  for (const std::uint32_t id : changed)
    for (const BlockCholesky::Entry& e : coarse_rows_[id])
      if (!is_changed[e.col]) coarse_rows_[e.col].push_back({id, e.block.transpose()});
  for (const std::uint32_t j : border) std::sort(coarse_rows_[j].begin(), coarse_rows_[j].end(), by_column);
  std::fill(outdated_.begin(), outdated_.end(), 0);
  cholesky_.analyze_following(coarse_rows_, follows);
  if (!factorize()) {
    galerkin(a, active, team);
    split_whole_ = true;
  }
  return made;
}

TwoLevelPreconditioner::Mat6 TwoLevelPreconditioner::coarse_block(std::size_t row, std::size_t col) const {
  if (row < coarse_rows_.size())
    for (const BlockCholesky::Entry& e : coarse_rows_[row])
      if (e.col == col) return e.block;
  return Mat6::Zero();
}

TwoLevelPreconditioner::Mat36 TwoLevelPreconditioner::prolongator_block(std::uint32_t node,
                                                                        std::size_t aggregate) const {
  if (node < prolongator_.size())
    for (const Entry& e : prolongator_[node])
      if (e.aggregate == aggregate) return e.block;
  return Mat36::Zero();
}

double TwoLevelPreconditioner::growth() const {
  double most = 0;
  for (std::size_t ag = 0; ag < members_.size(); ++ag)
    most = std::max(most, static_cast<double>(members_[ag].size()) / std::max<double>(1, built_size_[ag]));
  return most;
}

void TwoLevelPreconditioner::extend(std::uint32_t node, std::uint32_t parent, const Vec3& x) {
  if (parent >= aggregate_.size() || aggregate_[parent] < 0) return;
  reserve_nodes(static_cast<std::size_t>(node) + 1);
  if (aggregate_[node] >= 0) return;  // a reused slot keeps its place
  const auto ag = static_cast<std::uint32_t>(aggregate_[parent]);
  aggregate_[node] = aggregate_[parent];
  offset_[node] = x - centre_[ag];
  prolongator_[node].assign(1, Entry{ag, rigid_row(x, centre_[ag]) * modes_[ag]});
  members_[ag].push_back({node, 0});
  outdated_[ag] = 1;
  ++extended_;
}

// Chebyshev smoothing of degree m (Adams et al. 2003, with the three-term recurrence of Saad 2003,
// Algorithm 12.1): z += sum_k d_k, res tracks r - A z. From zero, the last pass leaves res = r - A z
// for the coarse correction, so degree m costs m products with A either way.
void TwoLevelPreconditioner::smooth(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
                                    std::span<const std::uint8_t> active, const std::vector<Vec3>& r,
                                    std::vector<Vec3>& z, bool from_zero, parallel::Team& team) {
  const std::size_t nn = a.size();
  const int m = std::max(1, options_.smoothing_degree);
  const double hi = smoothing_upper(), lo = hi / std::max(options_.smoothing_range, 1.5);
  const double theta = 0.5 * (hi + lo), delta = 0.5 * (hi - lo), sigma = theta / delta;
  std::vector<Vec3>& res = residual_;
  std::vector<Vec3>* d = &direction_;
  std::vector<Vec3>* dn = &next_;
  parallel::for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (!active[i]) {
        res[i].setZero();
        (*d)[i].setZero();
        // Not after the first pass: other rows read z_i then (times a zero block), and it is 0.
        if (from_zero) z[i].setZero();
        continue;
      }
      res[i] = from_zero ? r[i] : Vec3(r[i] - row_product(a[i], z));
      (*d)[i] = (diag_inverse[i] * res[i]) / theta;
      if (from_zero) z[i].setZero();
    }
  });
  double rho = 1.0 / sigma;
  for (int k = 1; k <= m; ++k) {
    const bool last = k == m;
    if (last && !from_zero) {
      parallel::for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) z[i] += (*d)[i];
      });
      break;
    }
    const double rho_next = 1.0 / (2.0 * sigma - rho);
    const double c1 = rho_next * rho, c2 = 2.0 * rho_next / delta;
    parallel::for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        if (!active[i]) {
          (*dn)[i].setZero();
          continue;
        }
        res[i] -= row_product(a[i], *d);
        z[i] += (*d)[i];
        if (!last) (*dn)[i] = c1 * (*d)[i] + c2 * (diag_inverse[i] * res[i]);
      }
    });
    std::swap(d, dn);
    rho = rho_next;
  }
}

void TwoLevelPreconditioner::coarse_correct(std::span<const std::uint8_t> active, const std::vector<Vec3>& r,
                                            std::vector<Vec3>& z, parallel::Team& team) {
  const std::size_t na = members_.size();
  parallel::for_chunks(team, na, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t ag = begin; ag < end; ++ag) {
      Vec6 s = Vec6::Zero();
      for (const Member& m : members_[ag])
        if (m.node < active.size() && active[m.node])
          s.noalias() += prolongator_[m.node][m.entry].block.transpose() * r[m.node];
      rc_.segment<6>(static_cast<Eigen::Index>(6 * ag)) = s;
    }
  });
  ec_ = rc_;
  cholesky_.solve(ec_);
  const std::size_t nn = std::min(z.size(), prolongator_.size());
  parallel::for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (!active[i]) continue;
      for (const Entry& e : prolongator_[i])
        z[i].noalias() += e.block * ec_.segment<6>(6 * static_cast<Eigen::Index>(e.aggregate));
    }
  });
}

void TwoLevelPreconditioner::apply(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
                                   std::span<const std::uint8_t> active, const std::vector<Vec3>& r,
                                   std::vector<Vec3>& z, parallel::Team& team) {
  reserve_nodes(a.size());
  smooth(a, diag_inverse, active, r, z, true, team);
  if (!factored_) return;  // the smoother alone: still symmetric positive definite
  coarse_correct(active, residual_, z, team);
  smooth(a, diag_inverse, active, r, z, false, team);
}

}  // namespace scalpel
