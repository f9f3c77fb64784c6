// Sparse Cholesky factorisation of a symmetric positive definite matrix of dense 6 x 6 blocks: the
// coarse operator of the two-level preconditioner (fem/two_level.hpp), one block row per aggregate.
//
// The scalar simplicial factorisation (Eigen SimplicialLDLT) treats each of the 36 entries of a
// block on its own. Here everything works on whole blocks:
//   ordering  approximate minimum degree (Amestoy, Davis, Duff, SIAM J. Matrix Anal. Appl. 17,
//             1996; Eigen's AMDOrdering) on the graph of the blocks;
//   symbolic  the block structure of L by the elimination tree (Liu, "The role of elimination
//             trees in sparse factorization", SIAM J. Matrix Anal. Appl. 11, 1990): column j
//             holds the rows of A below the diagonal and those of its children; its parent is
//             its first row;
//   numeric   right-looking block Cholesky, A = L L^T with 6 x 6 blocks L_ij:
//               L_jj = chol(A_jj),  L_ij = A_ij L_jj^{-T},  A_ik -= L_ij L_kj^T  (i >= k > j).
// On a coarse operator like that of the 20-thousand-tetrahedron slab (bench_fem
// CoarseFactorisation: 128 aggregates, 768 unknowns) the same fill as scalar AMD costs 0.1 ms
// to order instead of 0.8, 0.8 ms to factorise instead of 2.3 and 0.04 ms to solve instead of 0.1.
// All loops run in a fixed order: results are bit-identical run to run.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

namespace scalpel {

class BlockCholesky {
 public:
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  struct Entry {  // one block A_IJ of block row I
    std::uint32_t col;
    Mat6 block;
  };

  // Orders the blocks and finds the structure of L from the structure of rows (rows[I] holds the
  // blocks of block row I, in any order; each row must hold its diagonal block). Allocates.
  void analyze(const std::vector<std::vector<Entry>>& rows);
  // The same, keeping the order of the last analyze(): the rows it saw keep their order and each
  // row added since (row size() + k) is eliminated right after row follows[k]. For a matrix that
  // grew by rows split off others, whose couplings are theirs: no reordering, about their fill.
  void analyze_following(const std::vector<std::vector<Entry>>& rows, std::span<const std::uint32_t> follows);
  // Whether rows has the structure analyze() saw (then factorize() may follow without it).
  [[nodiscard]] bool same_structure(const std::vector<std::vector<Entry>>& rows) const;
  // Numeric factorisation of rows, which must have the analysed structure. Returns false if the
  // matrix is not positive definite (solve() must then not be used).
  bool factorize(const std::vector<std::vector<Entry>>& rows);
  // x = A^{-1} x.
  void solve(Eigen::VectorXd& x) const;

  [[nodiscard]] std::size_t size() const { return position_.size(); }  // block rows
  [[nodiscard]] std::size_t fill() const;                              // blocks of L

 private:
  void symbolic(const std::vector<std::vector<Entry>>& rows, std::span<const std::uint32_t> original);

  std::vector<std::uint32_t> position_;  // block row I is eliminated as column position_[I]
  // Column j of L: the diagonal block at values_[start_[j]], then the blocks of rows_[j] (sorted
  // positions below j) in order.
  std::vector<std::vector<std::uint32_t>> rows_;
  std::vector<std::vector<std::uint32_t>> passed_;  // symbolic(): the rows each column receives
  std::vector<std::size_t> start_;
  std::vector<Mat6> values_;
  // The analysed structure, for same_structure(): the sorted block columns of each row of A
  // (pattern_cols_), row I at [pattern_[I], pattern_[I + 1]).
  std::vector<std::size_t> pattern_;
  std::vector<std::uint32_t> pattern_cols_;
  mutable Eigen::VectorXd work_;
};

}  // namespace scalpel
