// Prestressed soft tissue on the shared tetrahedral mesh (docs/tissue.md, paper section 7.2).
//
// Time integration: implicit Euler with one linearisation per step (Baraff & Witkin 1998; Müller &
// Gross 2004, section 5), lumped mass M, Rayleigh damping C = alpha M + beta K per region:
//   (M + dt C + dt^2 K) v1 = M v0 + dt (f(x0) + M g + f_ext),   x1 = x0 + dt v1,
// solved by conjugate gradients, stopped at ||b - A v|| <= tolerance ||b|| or at the iteration cap
// (a step stopped there is not applied but redone in halves: TissueSettings::max_halvings).
// K is the consistent tangent of the element forces (fem/element.hpp), with the twist modes of the
// stress: prestressed skin at 60 Hz then settles within a few steps (0.08 s in the bundled
// scenario; tests/sim/test_wound.cpp), and one linearisation a step is enough. With R held fixed
// in K it alternated between two mirrored shapes for as long as it ran.
// Fixed nodes have v = 0. The preconditioner is the two-level cycle of fem/two_level.hpp (or plain
// 3x3 block-Jacobi). The start is the scaled warm start v = s v0, s = (b . v0) / (v0 . A v0): the
// multiple of the last velocity nearest the solution in the energy norm (the 1-D Galerkin
// projection onto span{v0}). Motion that settles decays geometrically from step to step, and v0
// itself then overshoots the solution by the decay factor (right after a cut it was a worse start
// than zero); s = 1 for steady motion, s = 0 when v0 points away from the solution. After a cut
// that makes s = 0, v0 is kept outside the local solve's region (below) and zero inside it.
//
// The matrix is assembled row by row: each node row sums the blocks of its incident tetrahedra in
// slot order, so both threads write disjoint rows and every reduction is over fixed chunks in a
// fixed order: results are bit-identical run to run and for any thread count.
//
// Topology changes: the cutter edits the TetMesh and then notifies the model. Nothing is rebuilt
// globally; at the next step only the rows of the vertices of added or removed tetrahedra are
// rebuilt (their sparsity pattern and lumped mass), the nodes a cut created join the coarse
// aggregate of their first parent (the coarse factorisation is kept) and an aggregate the cut
// severed is split into its parts (see fem/two_level.hpp). New tetrahedra
// compute their rest data from their (interpolated) rest vertices and their region's material, and start
// their rotation from the tetrahedron they descend from (mesh.parent). See fem/element.hpp for the element
// models, prestress and the sliver remedy.
//
// Local solve after a cut: a topology change leaves the warm start wrong only near the rows it
// rebuilt (the released prestress pulls on the new crack faces; the rest of the state is still the
// last step's solution). Before the global solve those rows and local_rings rings of neighbours
// are solved with the velocities outside held, by CG preconditioned with symmetric block Gauss-
// Seidel: adaptive relaxation where the residual is (Rüde, "Fully adaptive multigrid methods",
// SIAM J. Numer. Anal. 30, 1993). What is left sits on the border of the region, smooth and far-
// reaching, which the two-level cycle removes in a few iterations; the wider the region, the less
// is left. During a progressive incision 0.3 mm deep (20 thousand tetrahedra) the six rings (about
// 700 nodes) took the residual of the warm start from about 1 to 0.001-0.004 of the right-hand side
// (co-rotational; 0.001-0.02 mass-spring), and a step after a cut then needed 2.8 cycle iterations
// on average instead of 14.2 (mass-spring: 6.4 instead of 16.6); during the 3 mm deep one of
// bench/bench_fem.cpp a step after a cut needs 5.1 CG iterations (mass-spring 14). Rings stop at
// local_fraction of the active nodes (small meshes); a change that reaches half of them (the first
// step, a severed part) is not local and is solved globally at once. The local solve changes the
// start, not the solution. Its sweeps run on two threads: two parts of the region that share no
// block are swept at once, then the interface between them (fem/local_solve.cpp). At a step whose cut
// severs a coarse aggregate, one thread splits it (fem/two_level.hpp) and then joins the local solve,
// whose region has severing_rings rings: during the incision of bench/bench_fem.cpp those steps
// (where the blade enters the next column of cells) took 1.5-1.8 times the step before them with
// six rings beside the split on one thread, 1.4-1.6 times with four rings and the handoff, and
// 1.3-1.45 with the split's update of the coarse operator. A coarse rebuild due at a step with a
// local solve runs beside it the same way.
//
// Passenger nodes: a free node none of whose elements reaches the rest quality support_quality (e.g.
// a cut node at the clamp distance from a vertex) has mass but no stiffness (its elements are inert)
// or stiffness the sliver remedy scaled by less than 1/100. The solve lets such a node fall freely
// or drift (in a run of random cuts one held by elements of q <= 7e-5 drifted 10 mm), and the cutter
// later builds elements on a node far from its neighbours. It is left out of the solve (its elements
// act on their other nodes like a prescribed node) and rides with the mean new velocity of its
// neighbours that carry stiffness (fixed ones count with velocity 0).
//
// Thread ownership: a TissueModel and its mesh belong to the simulation thread; calls are not
// thread-safe. The model runs its loops on its own team of settings().threads threads
// (fem/parallel.hpp), which sleep outside them.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "fem/block_matrix.hpp"
#include "fem/element.hpp"
#include "fem/material.hpp"
#include "fem/parallel.hpp"
#include "fem/two_level.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

enum class Preconditioner {
  BlockJacobi,  // 3x3 diagonal blocks of A
  TwoLevel,     // rigid-mode aggregates + block-Jacobi smoothing (fem/two_level.hpp)
};

struct TissueSettings {
  TissueKind kind = TissueKind::Corotational;
  double tolerance = 1e-3;   // CG stop: relative residual ||r|| / ||b|| [-]
  int max_iterations = 200;  // CG iteration cap
  // A step whose solve stops at the cap is redone as two steps of dt/2, at most this many halvings
  // deep; one that still stops there is held (fem/tissue.cpp, TissueModel::advance).
  int max_halvings = 3;
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);  // [m/s^2]
  double sliver_quality = 0.05;          // q_min of the sliver remedy (element.hpp) [-]
  double support_quality = 5e-4;         // a free node with no element this good is a passenger [-]
  int threads = 2;                       // worker threads in step()
  bool volume_springs = true;            // MassSpring: each element's volume term (fem/element.hpp)
  Preconditioner preconditioner = Preconditioner::TwoLevel;
  // With TwoLevel, CG starts on block-Jacobi and restarts from its iterate with the two-level cycle
  // after this many iterations (0: the cycle from the start, as for any step whose warm start has a
  // relative residual above 0.5).
  int two_level_after = 12;
  // The two-level preconditioner is rebuilt (aggregates and coarse factorisation) at the step after
  // one that needed more two-level iterations than this, or after the step in which cuts brought the
  // nodes added since the last build above coarse_rebuild_fraction of the active nodes. The nodes a
  // cut creates join the aggregate of their parent, and the aggregates along a deep incision would
  // grow to 5-10 times the median size (100-200 nodes at 20 thousand tetrahedra): one rigid motion
  // for the tissue around the crack tip, which deforms the most. An aggregate grown above
  // coarse_regroup_growth times the nodes it was built (or last split) with is split into pieces of
  // that size in the step's split (fem/two_level.hpp); with a smoothed prolongator, which is not
  // split, the preconditioner is regrouped instead at the next step (a rebuild that keeps the
  // smoother's lambda estimate).
  int coarse_rebuild_iterations = 40;
  double coarse_rebuild_fraction = 0.1;
  double coarse_regroup_growth = 2;
  TwoLevelOptions two_level = {};  // smoother and prolongator of the two-level cycle (fem/two_level.hpp)
  // After a topology change, the rows it rebuilt and local_rings rings of neighbours around them
  // (fewer where more would pass local_fraction of the active nodes) are solved first (CG with the
  // velocities outside held), to local_tolerance of their residual, in at most local_max_iterations
  // and at most the work of local_budget products with the whole matrix; 0 rings: off. See above.
  int local_rings = 6;
  // At a step whose cut severs a coarse aggregate the local solve shares the team with the split
  // (fem/two_level.hpp) and runs on one thread until it is done: its region then has at most this
  // many rings (see above).
  int severing_rings = 4;
  double local_fraction = 0.4;
  double local_tolerance = 1e-3;
  int local_max_iterations = 100;
  double local_budget = 16;
};

enum class StepStatus {
  Converged,     // relative residual reached the tolerance
  IterationCap,  // a solve stopped at the cap even max_halvings halvings down: that part of the
                 // step was not applied (positions kept, velocities zeroed); message says where
  NonFinite,     // NaN or inf met: nothing was written, the last good state is kept
};

struct StepStats {
  StepStatus status = StepStatus::Converged;
  int cg_iterations = 0;
  int cycle_iterations = 0;           // of those, preconditioned by the two-level cycle
  double initial_residual = 0;        // ||b - A v|| / ||b|| of the warm start [-]
  double residual = 0;                // final ||r|| / ||b|| [-]
  bool preconditioner_built = false;  // the two-level preconditioner was (re)built in this step
  double elastic_energy = 0;          // at the start of the step [J]
  double kinetic_energy = 0;          // at the end of the step [J]
  std::size_t strain_limited = 0;     // elements beyond the strain limit (element.hpp) at the start
  std::size_t local_nodes = 0;        // nodes of the local solve after a topology change (0: none)
  int local_iterations = 0;           // its CG iterations (not counted in cg_iterations)
  std::size_t aggregates_split = 0;   // coarse aggregates added by splitting those the cut severed
  int substeps = 1;                   // steps applied: more than 1 after a solve stopped at the cap
  std::string message;                // why, when status != Converged
  // Wall time of the step's stages [s], summed over substeps (where a step's time goes; not part
  // of any result, which stays bit-identical whatever these read).
  struct Seconds {
    double elements = 0;  // evaluate_elements: rotations, strains, stresses, forces
    double assembly = 0;  // the rows a cut changed, the matrix, the right-hand side, the step's plan
                          // (which finds the local solve's region) and the warm start
    double local = 0;     // the coarse preconditioner's split or rebuild, the local solve after a cut
    double solve = 0;     // conjugate gradients and the velocities applied
  } seconds;
};

class TissueModel {
 public:
  // materials[r] is the material of region r; every tetrahedron's region must have one. Throws
  // std::invalid_argument naming "materials[r].field" for a bad material.
  TissueModel(TetMesh& mesh, std::vector<Material> materials, TissueSettings settings = {});

  // Advances positions and velocities of the mesh by dt [s].
  // A solve that stops at the iteration cap is not applied (see TissueSettings::max_halvings).
  StepStats step(double dt);
  [[nodiscard]] const StepStats& last_step() const { return last_; }

  // ---- boundary conditions and loads ---------------------------------------------------------
  // A fixed node keeps its position (which the caller may set) and has zero velocity: a boundary
  // condition, which a node the cutter makes between fixed nodes inherits (on_nodes_added()).
  void set_fixed(NodeId n, bool fixed = true);
  [[nodiscard]] bool fixed(NodeId n) const;
  // A held node is prescribed as a fixed one, by a tool for as long as it holds it: never
  // inherited by the cutter's nodes, and not a boundary condition (a piece held only by a tool is
  // not anchored).
  void set_held(NodeId n, bool held = true);
  [[nodiscard]] bool held(NodeId n) const;
  // Fixed or held: the solve keeps its position.
  [[nodiscard]] bool prescribed(NodeId n) const { return fixed(n) || held(n); }
  // External force on a node, e.g. tool contact [N]; stays until changed or cleared.
  void set_external_force(NodeId n, const Vec3& f);
  void clear_external_forces();

  // ---- topology notifications (after the mesh was edited) -----------------------------------
  // Removed tetrahedra, by slot index (their handles are dead already).
  void on_tets_removed(std::span<const std::uint32_t> slots);
  void on_tets_added(std::span<const TetId> tets);
  // New nodes; parents[i] (if given) are the nodes node[i] was interpolated from: a node whose
  // parents are all fixed is fixed (a node on an edge between fixed nodes stays fixed).
  void on_nodes_added(std::span<const NodeId> nodes, std::span<const NodeParents> parents = {});

  // ---- queries -------------------------------------------------------------------------------
  // Elastic energy at the current positions [J].
  [[nodiscard]] double elastic_energy();
  [[nodiscard]] double kinetic_energy() const;
  // Internal elastic forces at the current positions, indexed by node slot [N].
  [[nodiscard]] std::vector<Vec3> internal_forces();
  // The force `nodes` press on whatever holds them where they are (e.g. a tool they stick to), at
  // the current positions: the sum over them of the elastic force of their elements, their weight
  // and their external force [N]; each node counted once. Evaluates only the nodes' elements.
  [[nodiscard]] Vec3 load_on_holder(std::span<const NodeId> nodes);
  [[nodiscard]] double mass(NodeId n) const;  // lumped [kg]
  [[nodiscard]] const TetRest& tet_rest(TetId t) const;
  [[nodiscard]] TissueSettings& settings() { return settings_; }
  [[nodiscard]] const std::vector<Material>& materials() const { return materials_; }

 private:
  struct Entry {  // one incident tetrahedron of a node row
    std::uint32_t tet;
    std::uint16_t local;                 // the node's local vertex index a in the tet
    std::uint16_t region;                // the tet's region: the row reads no per-tet array but the states
    std::array<std::uint32_t, 4> block;  // position in the row of the column of vertex b
  };

  void grow();
  void mark_tet_nodes(std::uint32_t t);
  void prescription_changed(std::uint32_t node);
  // The team of settings_.threads threads (made anew when that setting has changed).
  parallel::Team& team();
  void refresh();
  void rebuild_row(std::uint32_t i);
  // Forces, stiffness data and energy of every element; returns how many are beyond the strain limit.
  std::size_t evaluate_elements(double& energy);
  void assemble(double dt);
  // step() at halving depth `depth`, and one linearised solve, applied if it converged or, when
  // `last`, held if it did not (a non-converged solve otherwise writes nothing).
  StepStats advance(double dt, int depth);
  StepStats solve_step(double dt, bool last);
  // solve_step()'s pipeline: the case of the step (see plan_step), the warm start, the coarse
  // update beside the local solve, CG, and the velocities applied.
  struct StepPlan {
    bool two_level = false;        // settings_.preconditioner is the two-level one
    bool extend = false;           // after a cut: the preconditioner is extended by the new nodes
    bool changed = false;          // rows changed since the last applied solve, local_rings > 0
    bool severs = false;           // the cut severs a coarse aggregate: split it
    bool region = false;           // the change is local: its region is in local_
    bool rebuild = false;          // the preconditioner is due for a rebuild
    std::size_t active_count = 0;  // active nodes (counted only after a change)
  };
  StepPlan plan_step();
  bool warm_start(const StepPlan& plan, double& rr, double& b_norm);
  void split_coarse(const StepPlan& plan, parallel::Team& split_team, StepStats& st);
  void build_coarse(parallel::Team& build_team, std::vector<double>& build_partial, StepStats& st);
  void update_coarse_and_solve_locally(const StepPlan& plan, bool local, double target, StepStats& st);
  void conjugate_gradients(const StepPlan& plan, double target, double& rr, StepStats& st);
  void apply_velocities(double dt);
  double multiply(const std::vector<Vec3>& x, std::vector<Vec3>& y);
  // The region of the local solve (see above): the changed rows and `rings` rings of neighbours around
  // them, in local_ and in_local_; false if the change is not local. active_count: the active
  // nodes, which set the region's size and the solve's iteration cap.
  bool local_region(std::span<const std::uint32_t> changed, std::size_t active_count, int rings);
  // The local solve on that region, on `team` (the same result on any). Leaves r_ current; shares
  // no data with the coarse update, which may run beside it.
  void solve_locally(std::size_t active_count, double target, StepStats& st, parallel::Team& team);

  TetMesh& mesh_;
  std::vector<Material> materials_;
  TissueSettings settings_;
  StepStats last_;

  // Per tet slot.
  std::vector<TetRest> rest_;
  std::vector<Eigen::Quaterniond> rotation_;
  std::vector<std::array<std::uint32_t, 4>> tet_vertices_;  // as the model last saw them
  std::vector<int> tet_region_;
  std::vector<std::uint8_t> tet_on_;
  std::vector<CorotationalState> corot_;
  std::vector<MassSpringState> spring_;

  // Per node slot.
  // prescribed_ = fixed_ | held_, what the solve keeps in place.
  std::vector<std::uint8_t> fixed_, held_, prescribed_, active_, dirty_;
  std::vector<std::uint8_t> passenger_;  // free, but no element supports it (see above)
  std::vector<Vec3> external_;
  std::vector<double> mass_;
  std::vector<double> mass_damping_;                  // alpha M, lumped [kg/s]
  BlockRows rows_;                                    // A, one block row per node slot
  std::vector<std::vector<std::uint32_t>> row_cols_;  // the columns rebuild_row() finds, to place
  std::vector<std::vector<Entry>> entries_;           // per node slot: incident tets, sorted by slot
  TwoLevelPreconditioner coarse_;
  bool coarse_stale_ = true;     // rebuild before the next solve
  bool coarse_regroup_ = false;  // the same, keeping lambda
  // Steps since the coarse operator was last computed whole. A split updates it in part (fem/
  // two_level.hpp), unless it is older than this: its kept rows would then be of a matrix long
  // gone (a cut into tissue left to settle).
  int coarse_age_ = 0;
  static constexpr int kCoarseRefreshSteps = 30;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> born_;  // (node, first parent) since the last step
  std::vector<std::uint32_t> dirty_list_;
  std::vector<std::uint32_t> changed_;  // rows rebuilt since the last step, sorted
  bool coarse_has_changes_ = false;     // the coarse preconditioner took changed_ in already
  std::vector<std::uint32_t> local_;    // the nodes of the local solve, sorted
  std::vector<std::uint8_t> in_local_;
  // The groups of the local solve's sweeps (I0, I1, interface; see solve_locally) and their
  // couplings in the region: for the k-th node, links [start[2k], start[2k+1]) come before it in
  // the sweep order, [start[2k+1], start[2k+2]) after it.
  struct LocalLink {
    std::uint32_t col;
    const Mat3* block;
  };
  struct LocalGroup {
    std::vector<std::uint32_t> nodes;  // slot order
    std::vector<LocalLink> links;
    std::vector<std::uint32_t> start;
    // The couplings of the k-th node with y: those before it in the sweep order, and after it.
    [[nodiscard]] Vec3 lower(std::size_t k, const std::vector<Vec3>& y) const {
      return coupled(start[2 * k], start[2 * k + 1], y);
    }
    [[nodiscard]] Vec3 upper(std::size_t k, const std::vector<Vec3>& y) const {
      return coupled(start[2 * k + 1], start[2 * k + 2], y);
    }
    [[nodiscard]] Vec3 coupled(std::uint32_t begin, std::uint32_t end, const std::vector<Vec3>& y) const {
      Vec3 s = Vec3::Zero();
      for (std::uint32_t l = begin; l < end; ++l) s.noalias() += *links[l].block * y[links[l].col];
      return s;
    }
  };
  static constexpr std::size_t kMinHalf = 64;  // a region of fewer than 2 kMinHalf nodes is not split
  std::array<LocalGroup, 3> groups_;
  std::vector<std::uint8_t> group_of_;  // per node slot of the region: its group
  // The local solve's parts: the region's nodes in groups_ (the sweep order) with their
  // couplings; the residual r_i = ((D + L) r^)_i of the k-th node of a group; the update dv from
  // the CG's unknown, applied to v_ with r_ made current on the region and the ring around it.
  void group_local_region();
  [[nodiscard]] Vec3 local_residual(const LocalGroup& g, std::size_t k) const;
  void finish_local_solve(parallel::Team& team);
  // f(group, index) on the team: on the two interior groups at once, or on all three when they do
  // not depend on each other.
  template <class F>
  void for_interior_groups(parallel::Team& team, F&& f) {
    team.run(2, [&](std::size_t g) { f(groups_[g], g); });
  }
  template <class F>
  void for_all_groups(parallel::Team& team, F&& f) {
    team.run(3, [&](std::size_t g) { f(groups_[g], g); });
  }

  // Step scratch, sized to the node capacity (no allocation in the hot loops).
  std::vector<Vec3> b_, v_, r_, z_, p_, q_, dv_, t_;
  std::vector<Mat3> diag_inverse_;
  std::vector<double> stiffness_factor_;  // per region: dt beta + dt^2, the factor of K in A [s^2]
  std::vector<double> partial_;
  std::unique_ptr<parallel::Team> team_;
  // The loops of a split or rebuild on the worker that runs it beside the local solve, and the
  // rebuild's chunk sums.
  parallel::Team solo_{1};
  std::vector<double> solo_partial_;
};

}  // namespace scalpel
