// Two-level preconditioner for the tissue solve (DESIGN section 6): a coarse space of aggregates of
// nodes that move rigidly, between two sweeps of l1 block-Jacobi smoothing.
//
// Why: with dt = 1/60 s the system A = M + dt C + dt^2 K is dominated by dt^2 K (dt^2 k / m ~ 1e4
// for a millimetre element of skin), so A is as ill-conditioned as the stiffness itself. Block-
// Jacobi removes the error only locally; the smooth, long-range error (a whole region of the slab
// moving as one, as when a cut releases the prestress) takes O(1/h) iterations. The coarse space
// holds those motions and removes them at once.
//
// Coarse space: the aggregates of smoothed aggregation, without the smoothing of the prolongator
// (Vanek, Mandel, Brezina, "Algebraic multigrid by smoothed aggregation for second and fourth order
// elliptic problems", Computing 56, 1996, section 3: phase 1 takes each node whose neighbours are
// all free together with them, phase 2 attaches leftovers to the neighbouring aggregate they have
// most links to, phase 3 groups what remains). On aggregate I the tentative prolongator holds the
// six rigid modes of linear elasticity at the node positions x_i,
//   B_i = [ I3 | -[x_i - c_I]x ]  (3 x 6, c_I the centroid of the aggregate),
// orthonormalised per aggregate: P_i = B_i V L^{-1/2} from the eigenpairs (L, V) of sum B_i^T B_i;
// a direction with L < 1e-10 max L (the rotation about the line of a collinear aggregate) is dropped
// and its coarse unknown decoupled. The coarse operator is the Galerkin product
//   Ac = P^T A P  (6 x 6 blocks, one block row per aggregate),
// factorised by a sparse LDL^T (Eigen SimplicialLDLT, AMD ordering).
//
// Smoother: damped block-Jacobi M = D / omega (D the 3x3 diagonal blocks of A). The two-grid cycle
// below is positive definite iff 2M - A > 0, i.e. omega < 2 / lambda_max(D^{-1} A). build()
// estimates lambda_max by 15 power iterations (from a fixed start: deterministic) and takes
// omega = min(1, 1.2 / lambda); power iteration approaches lambda_max from below, and the margin
// 2 / 1.2 covers an estimate up to 40% short. (The l1 smoother of Baker, Falgout, Kolev, Yang, SISC
// 2011, needs no estimate but cost 1.6x the iterations here.)
//
// Preconditioner: the symmetric two-grid cycle V(1,1) (Trottenberg, Oosterlee, Schüller,
// "Multigrid", Academic Press 2001, section 2.4; as a CG preconditioner: Tatebe, 1993):
//   z1 = M^{-1} r,  z2 = z1 + P Ac^{-1} P^T (r - A z1),  z = z2 + M^{-1} (r - A z2).
// B = (that map) is symmetric, and positive definite when 2M - A > 0 and Ac > 0, so B is a
// valid CG preconditioner however stale Ac is. That is what makes a cut cheap: the nodes a cut
// creates join the aggregate of their parent node (extend()) and the coarse operator is kept;
// build() and factor() are only needed when the preconditioner has grown too stale (the caller
// watches the iteration count).
//
// Everything is deterministic: aggregates are grown in node slot order, every sum has a fixed order
// and the parallel loops write disjoint data, so results do not depend on the thread count.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "fem/block_matrix.hpp"

namespace scalpel {

class TwoLevelPreconditioner {
 public:
  using Mat36 = Eigen::Matrix<double, 3, 6>;
  using Mat6 = Eigen::Matrix<double, 6, 6>;

  // Aggregates the active nodes over the block pattern of a, builds the prolongator from the rigid
  // modes at positions x (by node slot) and factorises Ac = P^T A P. Allocates: for start-up and
  // for rebuilds. Returns false if Ac could not be factorised (apply() then only smooths).
  bool build(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
             std::span<const std::uint8_t> active, std::span<const Vec3> x, std::vector<Vec3>& scratch,
             std::vector<double>& partial, int threads);

  // A node born after build() joins the aggregate of `parent`, with that aggregate's rigid modes
  // evaluated at x. Ac is kept (stale, still positive definite).
  void extend(std::uint32_t node, std::uint32_t parent, const Vec3& x);

  // z = B r (the V(1,1) cycle above); diag_inverse[i] = D_i^{-1}. Inactive nodes get 0.
  // scratch is a vector of the size of r; partial holds the chunk sums of multiply().
  void apply(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
             std::span<const std::uint8_t> active, const std::vector<Vec3>& r, std::vector<Vec3>& z,
             std::vector<Vec3>& scratch, std::vector<double>& partial, int threads);

  // Weight omega of the block-Jacobi smoother M = D / omega.
  [[nodiscard]] double omega() const { return omega_; }
  [[nodiscard]] bool factored() const { return factored_; }
  [[nodiscard]] std::size_t aggregate_count() const { return nodes_.size(); }
  [[nodiscard]] std::size_t coarse_size() const { return 6 * nodes_.size(); }
  // Nodes added by extend() since build().
  [[nodiscard]] std::size_t extended() const { return extended_; }
  // Aggregate of node slot i, -1 if none.
  [[nodiscard]] std::int32_t aggregate(std::uint32_t i) const {
    return i < aggregate_.size() ? aggregate_[i] : -1;
  }

 private:
  void coarse_correct(std::span<const std::uint8_t> active, const std::vector<Vec3>& r, std::vector<Vec3>& z,
                      int threads);

  bool factored_ = false;
  double omega_ = 0.5;
  std::size_t extended_ = 0;
  // Per node slot.
  std::vector<std::int32_t> aggregate_;
  std::vector<Mat36> p_;
  // Per aggregate: its nodes (slot order, then extend() order), neighbour aggregates (sorted, with
  // itself) as CSR, centroid, orthonormalising map V L^{-1/2} and dropped directions.
  std::vector<std::vector<std::uint32_t>> nodes_;
  std::vector<std::uint32_t> nbr_start_, nbr_;
  std::vector<Vec3> centre_;
  std::vector<Mat6> modes_;
  std::vector<std::array<bool, 6>> dropped_;
  std::vector<Mat6> blocks_;  // Ac(I, nbr_[k]) at k
  Eigen::SparseMatrix<double> ac_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt_;
  Eigen::VectorXd rc_, ec_;
};

}  // namespace scalpel
