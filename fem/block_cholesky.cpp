#include "fem/block_cholesky.hpp"

#include <algorithm>

#include <Eigen/Cholesky>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

namespace scalpel {

namespace {

// The sorted block columns of each row, as one list with row offsets.
void structure_of(const std::vector<std::vector<BlockCholesky::Entry>>& rows,
                  std::vector<std::size_t>& offset, std::vector<std::uint32_t>& cols) {
  offset.assign(1, 0);
  cols.clear();
  for (const auto& row : rows) {
    const std::size_t begin = cols.size();
    for (const auto& e : row) cols.push_back(e.col);
    std::sort(cols.begin() + static_cast<std::ptrdiff_t>(begin), cols.end());
    offset.push_back(cols.size());
  }
}

}  // namespace

void BlockCholesky::analyze(const std::vector<std::vector<Entry>>& rows) {
  const std::size_t n = rows.size();
  // Approximate minimum degree on the graph of the blocks. Eigen's ordering functors return the
  // inverse permutation: entry p is the row eliminated p-th.
  std::vector<Eigen::Triplet<double, int>> links;
  for (std::size_t i = 0; i < n; ++i)
    for (const Entry& e : rows[i]) links.emplace_back(static_cast<int>(e.col), static_cast<int>(i), 1.0);
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> graph(static_cast<Eigen::Index>(n),
                                                          static_cast<Eigen::Index>(n));
  graph.setFromTriplets(links.begin(), links.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> order;
  if (n > 0) Eigen::AMDOrdering<int>()(graph, order);
  std::vector<std::uint32_t> original(n);  // the row eliminated p-th
  for (std::size_t p = 0; p < n; ++p)
    original[p] = static_cast<std::uint32_t>(order.indices()(static_cast<Eigen::Index>(p)));
  symbolic(rows, original);
}

void BlockCholesky::analyze_following(const std::vector<std::vector<Entry>>& rows,
                                      std::span<const std::uint32_t> follows) {
  const std::size_t kept = position_.size();
  if (rows.size() != kept + follows.size()) {
    analyze(rows);
    return;
  }
  std::vector<std::uint32_t> was(kept);
  for (std::size_t i = 0; i < kept; ++i) was[position_[i]] = static_cast<std::uint32_t>(i);
  // The added rows after the row they follow, in index order: sorted by (position of that row, index).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> added;
  for (std::size_t k = 0; k < follows.size(); ++k)
    added.emplace_back(position_[follows[k]], static_cast<std::uint32_t>(kept + k));
  std::sort(added.begin(), added.end());
  std::vector<std::uint32_t> original;
  original.reserve(rows.size());
  std::size_t next = 0;
  for (std::uint32_t p = 0; p < kept; ++p) {
    original.push_back(was[p]);
    for (; next < added.size() && added[next].first == p; ++next) original.push_back(added[next].second);
  }
  symbolic(rows, original);
}

// Structure of L for the elimination order original (the row eliminated p-th).
void BlockCholesky::symbolic(const std::vector<std::vector<Entry>>& rows,
                             std::span<const std::uint32_t> original) {
  const std::size_t n = rows.size();
  structure_of(rows, pattern_, pattern_cols_);
  position_.resize(n);
  for (std::size_t p = 0; p < n; ++p) position_[original[p]] = static_cast<std::uint32_t>(p);
  // Structure of L by the elimination tree: column j holds the rows of A below the diagonal and
  // those its children pass up; its parent is its first row.
  // The lists keep their storage from the last analysis (a split re-analyses often).
  rows_.resize(n);
  passed_.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    rows_[j].clear();
    passed_[j].clear();
  }
  start_.assign(n, 0);
  std::size_t count = 0;
  for (std::uint32_t j = 0; j < n; ++j) {
    std::vector<std::uint32_t>& r = rows_[j];
    for (const Entry& e : rows[original[j]])
      if (position_[e.col] > j) r.push_back(position_[e.col]);
    r.insert(r.end(), passed_[j].begin(), passed_[j].end());
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
    if (!r.empty()) passed_[r.front()].insert(passed_[r.front()].end(), r.begin() + 1, r.end());
    start_[j] = count;
    count += 1 + r.size();
  }
  values_.resize(count);  // factorize() sets them
  work_.setZero(static_cast<Eigen::Index>(6 * n));
}

bool BlockCholesky::same_structure(const std::vector<std::vector<Entry>>& rows) const {
  std::vector<std::size_t> offset;
  std::vector<std::uint32_t> cols;
  structure_of(rows, offset, cols);
  return offset == pattern_ && cols == pattern_cols_;
}

bool BlockCholesky::factorize(const std::vector<std::vector<Entry>>& rows) {
  const std::size_t n = rows_.size();
  std::fill(values_.begin(), values_.end(), Mat6::Zero());
  // Lower triangle of A into the columns of L: A_IJ is the block (position J, position I) of
  // column position I when J comes later, transposed.
  for (std::size_t i = 0; i < n && i < rows.size(); ++i) {
    const std::uint32_t p = position_[i];
    for (const Entry& e : rows[i]) {
      const std::uint32_t q = position_[e.col];
      if (q == p) {
        values_[start_[p]] = e.block;
      } else if (q > p) {
        const auto& r = rows_[p];
        const auto k = static_cast<std::size_t>(std::lower_bound(r.begin(), r.end(), q) - r.begin());
        values_[start_[p] + 1 + k] = e.block.transpose();
      }
    }
  }
  for (std::size_t j = 0; j < n; ++j) {
    Mat6& diagonal = values_[start_[j]];
    const Eigen::LLT<Mat6> llt(diagonal);
    if (llt.info() != Eigen::Success) return false;
    diagonal = llt.matrixL();
    const std::vector<std::uint32_t>& r = rows_[j];
    const std::size_t col = start_[j] + 1;
    for (std::size_t a = 0; a < r.size(); ++a) {  // L_ij = A_ij L_jj^{-T}
      Mat6 t = values_[col + a].transpose();
      diagonal.triangularView<Eigen::Lower>().solveInPlace(t);
      values_[col + a] = t.transpose();
    }
    // A_ik -= L_ij L_kj^T for the rows i >= k of column j; the rows of column j below k are
    // rows of column k (the elimination tree), so one forward walk finds their blocks.
    for (std::size_t a = 0; a < r.size(); ++a) {
      const std::uint32_t k = r[a];
      const Mat6& lk = values_[col + a];
      values_[start_[k]].noalias() -= lk * lk.transpose();
      const std::vector<std::uint32_t>& rk = rows_[k];
      std::size_t s = 0;
      for (std::size_t b = a + 1; b < r.size(); ++b) {
        while (rk[s] < r[b]) ++s;
        values_[start_[k] + 1 + s].noalias() -= values_[col + b] * lk.transpose();
      }
    }
  }
  return true;
}

void BlockCholesky::solve(Eigen::VectorXd& x) const {
  const std::size_t n = rows_.size();
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  const auto at = [](std::size_t block) { return static_cast<Eigen::Index>(6 * block); };
  for (std::size_t i = 0; i < n; ++i) work_.segment<6>(at(position_[i])) = x.segment<6>(at(i));
  for (std::size_t j = 0; j < n; ++j) {  // L y = b
    values_[start_[j]].triangularView<Eigen::Lower>().solveInPlace(work_.segment<6>(at(j)));
    const Vec6 yj = work_.segment<6>(at(j));
    for (std::size_t a = 0; a < rows_[j].size(); ++a)
      work_.segment<6>(at(rows_[j][a])).noalias() -= values_[start_[j] + 1 + a] * yj;
  }
  for (std::size_t j = n; j-- > 0;) {  // L^T x = y
    Vec6 s = work_.segment<6>(at(j));
    for (std::size_t a = 0; a < rows_[j].size(); ++a)
      s.noalias() -= values_[start_[j] + 1 + a].transpose() * work_.segment<6>(at(rows_[j][a]));
    values_[start_[j]].transpose().triangularView<Eigen::Upper>().solveInPlace(s);
    work_.segment<6>(at(j)) = s;
  }
  for (std::size_t i = 0; i < n; ++i) x.segment<6>(at(i)) = work_.segment<6>(at(position_[i]));
}

std::size_t BlockCholesky::fill() const {
  return values_.size();
}

}  // namespace scalpel
