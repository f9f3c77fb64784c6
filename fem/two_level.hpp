// Two-level preconditioner for the tissue solve (docs/tissue.md): a coarse space of aggregates of
// nodes that move rigidly, between two passes of a Chebyshev (by default: weighted block-Jacobi)
// smoother.
//
// Why: with dt = 1/60 s the system A = M + dt C + dt^2 K is dominated by dt^2 K (dt^2 k / m ~ 1e4
// for a millimetre element of skin), so A is as ill-conditioned as the stiffness itself. Block-
// Jacobi removes the error only locally; the smooth, long-range error (a whole region of the slab
// moving as one, as when a cut releases the prestress) takes O(1/h) iterations. The coarse space
// holds those motions and removes them at once.
//
// Coarse space: the aggregates of smoothed aggregation (Vanek, Mandel, Brezina, "Algebraic multigrid
// by smoothed aggregation for second and fourth order elliptic problems", Computing 56, 1996,
// section 3: phase 1 takes each node whose neighbours are all free together with them, phase 2
// attaches leftovers to the neighbouring aggregate they have most links to, phase 3 groups what
// remains). On aggregate I the tentative prolongator holds the six rigid modes of linear elasticity
// at the node positions x_i,
//   T_i = [ I3 | -[x_i - c_I]x ]  (3 x 6, c_I the centroid of the aggregate),
// orthonormalised per aggregate: T_i V L^{-1/2} from the eigenpairs (L, V) of sum T_i^T T_i; a
// direction with L < 1e-10 max L (the rotation about the line of a collinear aggregate) is dropped
// and its coarse unknown decoupled. With prolongator_weight = omega_p > 0 the tentative prolongator
// is smoothed by one damped Jacobi step (ibid., omega_p = 4/3):
//   P = (I - omega_p / lambda D^{-1} A) T,  lambda ~ lambda_max(D^{-1} A),
// which lowers the energy of the coarse basis functions (fewer iterations) but couples each node to
// the aggregates of its neighbours: P, Ac and its factor are two to three times larger. The default
// keeps P = T: on the skin slab of bench/bench_fem.cpp a 12 mm incision made at once then needs 15
// iterations instead of 17 (bench_fem AfterCut/24/0/3), and a rebuild costs about 1.5 times as
// much. The coarse operator is the Galerkin product
//   Ac = P^T A P  (6 x 6 blocks, one block row per aggregate),
// factorised by a sparse Cholesky factorisation on its blocks (fem/block_cholesky.hpp).
//
// Smoother: S = q(D^{-1} A) D^{-1}, the Chebyshev polynomial of degree m (Adams, Brezina, Hu,
// Tuminaro, "Parallel multigrid smoothing: polynomial versus Gauss-Seidel", J. Comput. Phys. 188,
// 2003, section 4) that damps the eigenvalues of D^{-1} A (D the 3x3 diagonal blocks of A) in
// [hi / range, hi], hi = 1.1 lambda. Degree 1 is block-Jacobi with the weight 1 / theta,
// theta = (hi + hi / range) / 2. lambda is the largest Ritz value of 15 block-Jacobi CG steps on a
// fixed vector (Lanczos from the CG coefficients: Saad, "Iterative Methods for Sparse Linear
// Systems", 2nd ed., section 6.7.3; PETSc's Chebyshev smoother takes the same [0.1, 1.1] lambda).
// A Ritz value approaches lambda_max from below, within a few per cent after 15 steps; 1.1 covers it.
// Degree 4 halves the iterations after that incision (9 instead of 17, AfterCut/24/0/2) but not
// the time: each costs 8 products with A instead of 2.
//
// Preconditioner: the symmetric two-grid cycle (Trottenberg, Oosterlee, Schüller, "Multigrid",
// Academic Press 2001, section 2.4; as a CG preconditioner: Tatebe, 1993):
//   z1 = S r,  z2 = z1 + P Ac^{-1} P^T (r - A z1),  z = z2 + S (r - A z2).
// S is symmetric, so B = (that map) is symmetric, and it is positive definite when
// 0 < lambda q(lambda) < 2 on the spectrum of D^{-1} A (for range = 10 and m = 1 or 2: up to
// 1.1 hi = 1.21 lambda) and Ac > 0, so B is a valid CG preconditioner however stale Ac is.
// That is what makes a cut cheap: the nodes a cut creates join the aggregate of their parent node
// (extend(), with the tentative row) and the coarse operator is kept; build() is only needed when
// the preconditioner has grown too stale (the caller watches the iteration count and growth()).
// One thing a cut does that a stale coarse operator cannot absorb: it severs an aggregate, whose
// one set of rigid modes then ties the two sides of the crack together (the smallest eigenvalues
// of the preconditioned matrix drop, to 0.01-0.02 during a deep incision against 0.035-0.05 with fresh
// aggregates). split_severed() gives each connected part its own rigid modes and updates Ac: the
// block rows of the parts, of the aggregates cuts changed since their rows were computed and of
// their neighbours are recomputed (a fifth of the rows), the elimination order is kept and Ac
// refactorised. At 7 of the 80 cut steps of the 3 mm deep incision of bench/bench_fem.cpp that
// takes 1.3-1.6 ms on one thread (the factorisation 0.8-1.1 of it), where recomputing all rows
// and reordering took 2.5-3.3. The caller asks for all rows when Ac is old: a 12 mm cut made in
// one frame 140 steps after the last build then needs 17 cycle iterations instead of 19. With
// the split a step after a cut needs 11.6 iterations instead of 14.1 (mass-spring), 4.8 instead
// of 5.1 (co-rotational). A cycle costs 2 m products with A; the smoother's vector updates are
// fused into those row loops.
//
// The same split divides an aggregate that the nodes of cuts grew (extend()) past a given multiple
// of its size into connected pieces of that size: the crack tip's aggregates would otherwise hold
// the tissue that deforms the most in one rigid motion, and be rebuilt with everything else.
//
// Everything is deterministic: aggregates are grown in node slot order, every sum has a fixed order
// and the parallel loops write disjoint data, so results do not depend on the thread count.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "fem/block_cholesky.hpp"
#include "fem/block_matrix.hpp"

namespace scalpel {

struct TwoLevelOptions {
  int smoothing_degree = 1;       // Chebyshev degree m >= 1 (1: weighted block-Jacobi) [-]
  double smoothing_range = 10;    // the smoother damps [hi / range, hi] of D^{-1} A, range > 1 [-]
  double prolongator_weight = 0;  // omega_p (4/3 in smoothed aggregation); 0 keeps P = T [-]
};

class TwoLevelPreconditioner {
 public:
  using Mat36 = Eigen::Matrix<double, 3, 6>;
  using Mat6 = Eigen::Matrix<double, 6, 6>;

  explicit TwoLevelPreconditioner(TwoLevelOptions options = {}) : options_(options) {}
  // Takes effect at the next build() (the prolongator) and apply() (the smoother).
  void set_options(const TwoLevelOptions& options) { options_ = options; }

  // Aggregates the active nodes over the block pattern of a, builds the prolongator from the rigid
  // modes at positions x (by node slot) and factorises Ac = P^T A P. Allocates: for start-up and
  // for rebuilds. Returns false if Ac could not be factorised (apply() then only smooths).
  // partial holds the chunk sums of multiply().
  // estimate = false keeps the lambda of the last build (if there was one).
  bool build(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
             std::span<const std::uint8_t> active, std::span<const Vec3> x, std::vector<double>& partial,
             parallel::Team& team, bool estimate = true);

  // Splits each aggregate holding one of `nodes` (the rows a cut rebuilt) that the current
  // pattern of a no longer connects into its connected parts, each with the rigid modes of its own
  // nodes at x, and then updates Ac (above): where it recomputes blocks they are those of
  // P^T A P, the others are kept; with whole = true it recomputes all. With growth > 0 a part that
  // the nodes cuts created (extend()) made larger than growth times the aggregate's size at build()
  // (that of the aggregate it was split from, for a part) is divided too, into connected pieces of
  // about that size (grown_pieces()).
  // Returns the number of aggregates added. Not when build() smoothed the prolongator (returns 0).
  // Allocates.
  std::size_t split_severed(std::span<const BlockRow> a, std::span<const std::uint8_t> active,
                            std::span<const std::uint32_t> nodes, std::span<const Vec3> x,
                            parallel::Team& team, bool whole = false, double growth = 0);

  // The rows of A of `nodes` changed (a cut rebuilt them): the block rows of Ac of their aggregates
  // are out of date (split_severed() recomputes those).
  void touch(std::span<const std::uint32_t> nodes);

  // Whether split_severed() would split an aggregate (without changing anything).
  bool severs(std::span<const BlockRow> a, std::span<const std::uint8_t> active,
              std::span<const std::uint32_t> nodes, double growth = 0);

  // A node born after build() joins the aggregate of `parent`, with that aggregate's rigid modes
  // evaluated at x. Ac is kept (stale, still positive definite).
  void extend(std::uint32_t node, std::uint32_t parent, const Vec3& x);

  // z = B r (the cycle above); diag_inverse[i] = D_i^{-1}. Inactive nodes get 0. Allocates only
  // when the node count has grown since the last call.
  void apply(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
             std::span<const std::uint8_t> active, const std::vector<Vec3>& r, std::vector<Vec3>& z,
             parallel::Team& team);

  // Estimate of lambda_max(D^{-1} A) (a Ritz value: from below) and the upper end of the interval
  // the smoother damps.
  [[nodiscard]] double lambda_estimate() const { return lambda_; }
  [[nodiscard]] double smoothing_upper() const { return 1.1 * lambda_; }
  [[nodiscard]] bool factored() const { return factored_; }
  [[nodiscard]] std::size_t aggregate_count() const { return members_.size(); }
  [[nodiscard]] std::size_t coarse_size() const { return 6 * members_.size(); }
  // Nodes added by extend() since build().
  [[nodiscard]] std::size_t extended() const { return extended_; }
  // Whether the last split_severed() recomputed all of Ac (asked to, or its update did not
  // factorise).
  [[nodiscard]] bool split_whole() const { return split_whole_; }
  // The largest number of nodes an aggregate holds over the number it was built (or split) with.
  [[nodiscard]] double growth() const;
  // Whether build() smoothed the prolongator (then split_severed() splits nothing).
  [[nodiscard]] bool smoothed() const { return smoothed_; }
  // Aggregate of node slot i, -1 if none.
  [[nodiscard]] std::int32_t aggregate(std::uint32_t i) const {
    return i < aggregate_.size() ? aggregate_[i] : -1;
  }
  [[nodiscard]] const TwoLevelOptions& options() const { return options_; }
  // Block (I, J) of Ac as last computed and block (i, I) of P (zero outside their patterns).
  [[nodiscard]] Mat6 coarse_block(std::size_t row, std::size_t col) const;
  [[nodiscard]] Mat36 prolongator_block(std::uint32_t node, std::size_t aggregate) const;

 private:
  struct Entry {  // one block P(i, I) of a node row of the prolongator
    std::uint32_t aggregate;
    Mat36 block;
  };
  struct Member {  // node i has a block in column I of P, at prolongator_[i][entry]
    std::uint32_t node, entry;
  };

  void estimate_lambda(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
                       std::span<const std::uint8_t> active, std::vector<double>& partial,
                       parallel::Team& team);
  void smooth(std::span<const BlockRow> a, std::span<const Mat3> diag_inverse,
              std::span<const std::uint8_t> active, const std::vector<Vec3>& r, std::vector<Vec3>& z,
              bool from_zero, parallel::Team& team);
  void coarse_correct(std::span<const std::uint8_t> active, const std::vector<Vec3>& r, std::vector<Vec3>& z,
                      parallel::Team& team);
  void coarse_row(std::size_t ag, std::span<const BlockRow> a, std::span<const std::uint8_t> active,
                  std::vector<Entry>& ap, std::vector<BlockCholesky::Entry>& row) const;
  bool galerkin(std::span<const BlockRow> a, std::span<const std::uint8_t> active, parallel::Team& team);
  bool factorize();  // of coarse_rows_, as analysed
  void reserve_nodes(std::size_t n);
  struct Parts {
    std::vector<std::vector<std::uint32_t>> parts;  // connected parts of the active members
    std::vector<std::uint32_t> rest;                // inactive members
    std::vector<std::uint32_t> stack;
  };
  [[nodiscard]] std::vector<std::uint32_t> touched(std::span<const std::uint32_t> nodes) const;
  // Whether aggregate ag's active members (found) outnumber growth times its piece size.
  [[nodiscard]] bool grown(std::uint32_t ag, const Parts& found, double growth) const;
  // Divides each part of `found` larger than the aggregate's piece size into connected pieces of
  // about that size: grown breadth-first from its lowest unassigned node, a piece under half that
  // size joined to the piece of its first neighbour in order (so the pieces may be fewer than two).
  void grown_pieces(std::uint32_t ag, std::span<const BlockRow> a, Parts& found);
  void connected_parts(std::uint32_t ag, std::span<const BlockRow> a, std::span<const std::uint8_t> active,
                       Parts& out);

  TwoLevelOptions options_;
  bool factored_ = false;
  double lambda_ = 0;
  std::size_t extended_ = 0;
  // Per node slot: aggregate (of the tentative prolongator) and row of P, sorted by aggregate.
  std::vector<std::int32_t> aggregate_;
  std::vector<std::vector<Entry>> prolongator_;
  bool smoothed_ = false;     // P was smoothed at build(); else P = T
  bool split_whole_ = false;  // see split_whole()
  std::vector<Vec3> offset_;  // per node slot: x_i - c_I when its row of T was made
  // Per aggregate: the nodes with a block in its column of P (slot order, then extend() order),
  // centroid, orthonormalising map V L^{-1/2}.
  std::vector<std::vector<Member>> members_;
  std::vector<std::uint32_t> built_size_;  // per aggregate: its member count at build() or split
  // Per aggregate: the member count at build() of the aggregate it was split from (or its own):
  // the size of the pieces a grown one is divided into, so that the slivers a cut leaves do not
  // make ever smaller pieces.
  std::vector<std::uint32_t> piece_size_;
  // Per aggregate: its members or their rows of A changed since its block row of Ac was computed.
  std::vector<std::uint8_t> outdated_;
  std::vector<Vec3> centre_;
  std::vector<Mat6> modes_;
  // Build scratch: tentative prolongator rows by node slot, block rows of Ac, and per task over
  // aggregates one row of A P.
  std::vector<Mat36> tentative_;
  std::vector<std::vector<BlockCholesky::Entry>> coarse_rows_;
  std::vector<std::vector<Entry>> ap_;
  BlockCholesky cholesky_;  // of Ac
  Eigen::VectorXd rc_, ec_;
  // Smoother work vectors, by node slot.
  std::vector<Vec3> residual_, direction_, next_;
  std::vector<std::uint8_t> seen_;      // split_severed(): visited nodes (all 0 between calls)
  std::vector<std::int32_t> piece_of_;  // grown_pieces(): piece of a node (all -1 between calls)
};

}  // namespace scalpel
