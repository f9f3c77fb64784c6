#include "fem/tissue.hpp"

#include "fem/parallel.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

namespace scalpel {

using parallel::chunk_count;
using parallel::for_chunks;
using parallel::sum;

TissueModel::TissueModel(TetMesh& mesh, std::vector<Material> materials, TissueSettings settings)
    : mesh_(mesh), materials_(std::move(materials)), settings_(settings) {
  for (std::size_t r = 0; r < materials_.size(); ++r)
    if (const auto err = validate_material(materials_[r]))
      throw std::invalid_argument("materials[" + std::to_string(r) + "]." + err->field + ": " + err->message);
  if (materials_.size() > std::numeric_limits<std::uint16_t>::max())  // Entry::region
    throw std::invalid_argument("materials: " + std::to_string(materials_.size()) +
                                " regions, at most 65535");
  if (settings_.threads < 1) settings_.threads = 1;
  stiffness_factor_.resize(materials_.size());
  grow();
  const std::vector<TetId> tets = mesh_.tets();
  on_tets_added(tets);
  for (std::uint32_t i = 0; i < mesh_.node_capacity(); ++i)
    if (!dirty_[i]) {
      dirty_[i] = 1;
      dirty_list_.push_back(i);
    }
  // Every row's columns, entries and mass now, at load, not in the first step's frame (12 ms at 20
  // thousand tetrahedra). Rows whose nodes are fixed or held later are rebuilt at the next step;
  // support_quality changed through settings() reaches only rows rebuilt after the change.
  refresh();
}

namespace {

// Resizes v to n, reserving twice n when it must move: the first grow (at construction) leaves room
// for the slots cuts add, so the first cut does not copy every array of the model in its frame
// (7.6 ms at 20 thousand tetrahedra). Room not yet used is address space only.
template <class V, class... Fill>
void grow_to(V& v, std::size_t n, const Fill&... fill) {
  if (v.size() >= n) return;
  if (v.capacity() < n) v.reserve(2 * n);
  v.resize(n, fill...);
}

}  // namespace

void TissueModel::grow() {
  const std::size_t nt = mesh_.tet_capacity();
  if (rest_.size() < nt) {
    grow_to(rest_, nt);
    grow_to(rotation_, nt, Eigen::Quaterniond::Identity());
    grow_to(tet_vertices_, nt);
    grow_to(tet_region_, nt, 0);
    grow_to(tet_on_, nt, std::uint8_t{0});
    if (settings_.kind == TissueKind::Corotational)
      grow_to(corot_, nt);
    else
      grow_to(spring_, nt);
  }
  const std::size_t nn = mesh_.node_capacity();
  if (fixed_.size() < nn) {
    for (auto* v : {&fixed_, &held_, &prescribed_, &active_, &passenger_, &dirty_})
      grow_to(*v, nn, std::uint8_t{0});
    grow_to(external_, nn, Vec3::Zero());
    grow_to(mass_, nn, 0.0);
    grow_to(mass_damping_, nn, 0.0);
    rows_.grow(nn);
    grow_to(row_cols_, nn);
    grow_to(entries_, nn);
    for (auto* v : {&b_, &v_, &r_, &z_, &p_, &q_, &dv_, &t_}) grow_to(*v, nn, Vec3::Zero());
    grow_to(diag_inverse_, nn, Mat3::Identity());
  }
  const std::size_t chunks = std::max(chunk_count(nn), chunk_count(nt));
  if (partial_.size() < 3 * chunks) partial_.resize(3 * chunks, 0.0);
  if (solo_partial_.size() < 3 * chunks) solo_partial_.resize(3 * chunks, 0.0);
}

void TissueModel::mark_tet_nodes(std::uint32_t t) {
  for (const std::uint32_t n : tet_vertices_[t])
    if (n < dirty_.size() && !dirty_[n]) {
      dirty_[n] = 1;
      dirty_list_.push_back(n);
    }
}

void TissueModel::on_tets_removed(std::span<const std::uint32_t> slots) {
  for (const std::uint32_t t : slots) {
    if (t >= tet_on_.size() || !tet_on_[t]) continue;
    tet_on_[t] = 0;
    mark_tet_nodes(t);
  }
}

void TissueModel::on_tets_added(std::span<const TetId> tets) {
  grow();
  std::array<Vec3, 4> x;
  for (const TetId id : tets) {
    const std::uint32_t t = id.index;
    if (tet_on_[t]) mark_tet_nodes(t);  // slot reused without a removal notice
    const int region = mesh_.region(id);
    if (region < 0 || static_cast<std::size_t>(region) >= materials_.size())
      throw std::out_of_range("tissue: tetrahedron " + std::to_string(t) + " has region " +
                              std::to_string(region) + " without a material");
    tet_vertices_[t] = mesh_.tet_vertex_indices(t);
    for (size_t a = 0; a < 4; ++a) x[a] = mesh_.rest_positions()[tet_vertices_[t][a]];
    rest_[t] = make_tet_rest(x, materials_[static_cast<std::size_t>(region)], settings_.sliver_quality);
    if (!settings_.volume_springs) rest_[t].volume_k = 0;  // edge springs alone
    tet_region_[t] = region;
    // The rotation starts from the ancestor's slot (the parent itself, or a sibling that reused it).
    const std::uint32_t p = mesh_.parent(id);
    rotation_[t] = (p != t && p < rotation_.size()) ? rotation_[p] : Eigen::Quaterniond::Identity();
    tet_on_[t] = 1;
    mark_tet_nodes(t);
  }
}

void TissueModel::on_nodes_added(std::span<const NodeId> nodes, std::span<const NodeParents> parents) {
  grow();
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    const std::uint32_t n = nodes[k].index;
    bool fix = false;
    if (k < parents.size() && parents[k].count > 0) {
      fix = true;
      for (int j = 0; j < parents[k].count; ++j) {
        const std::uint32_t pj = parents[k].parents[static_cast<size_t>(j)].index;
        fix = fix && pj < fixed_.size() && fixed_[pj];
      }
    }
    fixed_[n] = fix ? 1 : 0;
    held_[n] = 0;
    prescribed_[n] = fixed_[n];
    external_[n].setZero();
    if (k < parents.size() && parents[k].count > 0) born_.emplace_back(n, parents[k].parents[0].index);
    if (!dirty_[n]) {
      dirty_[n] = 1;
      dirty_list_.push_back(n);
    }
  }
}

void TissueModel::set_fixed(NodeId n, bool fix) {
  if (!mesh_.alive(n)) throw std::invalid_argument("tissue: set_fixed on a dead node");
  grow();
  fixed_[n.index] = fix ? 1 : 0;
  prescription_changed(n.index);
}

bool TissueModel::fixed(NodeId n) const {
  return n.index < fixed_.size() && fixed_[n.index];
}

void TissueModel::set_held(NodeId n, bool hold) {
  if (!mesh_.alive(n)) throw std::invalid_argument("tissue: set_held on a dead node");
  grow();
  held_[n.index] = hold ? 1 : 0;
  prescription_changed(n.index);
}

// The node's row changes with whether the solve keeps it in place.
void TissueModel::prescription_changed(std::uint32_t i) {
  prescribed_[i] = fixed_[i] | held_[i];
  if (!dirty_[i]) {
    dirty_[i] = 1;
    dirty_list_.push_back(i);
  }
}

bool TissueModel::held(NodeId n) const {
  return n.index < held_.size() && held_[n.index];
}

void TissueModel::set_external_force(NodeId n, const Vec3& f) {
  if (!mesh_.alive(n)) throw std::invalid_argument("tissue: external force on a dead node");
  grow();
  external_[n.index] = f;
}

void TissueModel::clear_external_forces() {
  std::fill(external_.begin(), external_.end(), Vec3::Zero());
}

double TissueModel::mass(NodeId n) const {
  return n.index < mass_.size() ? mass_[n.index] : 0.0;
}

const TetRest& TissueModel::tet_rest(TetId t) const {
  if (!mesh_.alive(t) || t.index >= tet_on_.size() || !tet_on_[t.index])
    throw std::invalid_argument("tissue: unknown tetrahedron");
  return rest_[t.index];
}

// Row i's columns (into row_cols_[i], placed by refresh()), incident elements, mass and state.
void TissueModel::rebuild_row(std::uint32_t i) {
  std::vector<std::uint32_t>& cols = row_cols_[i];
  std::vector<Entry>& entries = entries_[i];
  cols.clear();
  entries.clear();
  mass_[i] = 0;
  mass_damping_[i] = 0;
  active_[i] = 0;
  passenger_[i] = 0;
  if (!mesh_.node_slot_alive(i)) return;
  std::vector<std::uint32_t> tets;
  for (const std::uint32_t t : mesh_.node_tets(mesh_.node_handle(i)))
    if (t < tet_on_.size() && tet_on_[t]) tets.push_back(t);
  std::sort(tets.begin(), tets.end());
  cols.push_back(i);
  for (const std::uint32_t t : tets)
    for (const std::uint32_t n : tet_vertices_[t]) cols.push_back(n);
  std::sort(cols.begin(), cols.end());
  cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
  const auto col_of = [&](std::uint32_t n) {
    return static_cast<std::uint32_t>(std::lower_bound(cols.begin(), cols.end(), n) - cols.begin());
  };
  bool supported = false;
  for (const std::uint32_t t : tets) {
    supported = supported || rest_[t].quality >= settings_.support_quality;
    Entry e{t, 0, static_cast<std::uint16_t>(tet_region_[t]), {}};
    for (std::uint16_t a = 0; a < 4; ++a) {
      const std::uint32_t n = tet_vertices_[t][a];
      if (n == i) e.local = a;
      e.block[static_cast<size_t>(a)] = col_of(n);
    }
    entries.push_back(e);
    const Material& m = materials_[static_cast<std::size_t>(tet_region_[t])];
    mass_[i] += m.density * rest_[t].mass_volume / 4.0;
    mass_damping_[i] += m.damping_mass * m.density * rest_[t].mass_volume / 4.0;
  }
  const bool free = !prescribed_[i] && mass_[i] > 0;
  active_[i] = (free && supported) ? 1 : 0;
  passenger_[i] = (free && !supported) ? 1 : 0;
}

void TissueModel::refresh() {
  grow();
  std::sort(dirty_list_.begin(), dirty_list_.end());
  // Each row is its own: the threads share the rows a cut dirtied (a few hundred to thousands).
  for_chunks(team(), dirty_list_.size(), [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      rebuild_row(dirty_list_[k]);
      dirty_[dirty_list_[k]] = 0;
    }
  });
  // Placed one by one, in row order (BlockRows).
  for (const std::uint32_t i : dirty_list_) rows_.set(i, row_cols_[i]);
  const auto middle = static_cast<std::ptrdiff_t>(changed_.size());
  changed_.insert(changed_.end(), dirty_list_.begin(), dirty_list_.end());
  std::inplace_merge(changed_.begin(), changed_.begin() + middle, changed_.end());
  changed_.erase(std::unique(changed_.begin(), changed_.end()), changed_.end());
  dirty_list_.clear();
#ifdef SCALPEL_VALIDATE
  for (std::uint32_t t = 0; t < tet_on_.size(); ++t)
    if (static_cast<bool>(tet_on_[t]) != mesh_.tet_slot_alive(t) ||
        (tet_on_[t] && tet_vertices_[t] != mesh_.tet_vertex_indices(t)))
      throw std::logic_error("tissue: tetrahedron " + std::to_string(t) +
                             " changed without a topology notification");
#endif
}

double TissueModel::multiply(const std::vector<Vec3>& x, std::vector<Vec3>& y) {
  return scalpel::multiply(rows_, active_, x, y, partial_, team());
}

double TissueModel::elastic_energy() {
  refresh();
  double e = 0;
  evaluate_elements(e);
  return e;
}

double TissueModel::kinetic_energy() const {
  const auto& vel = mesh_.velocities();
  double e = 0;
  for (std::size_t i = 0; i < mass_.size() && i < vel.size(); ++i)
    if (mesh_.node_slot_alive(static_cast<std::uint32_t>(i))) e += 0.5 * mass_[i] * vel[i].squaredNorm();
  return e;
}

std::vector<Vec3> TissueModel::internal_forces() {
  refresh();
  double e = 0;
  evaluate_elements(e);
  std::vector<Vec3> f(mesh_.node_capacity(), Vec3::Zero());
  for (std::uint32_t t = 0; t < tet_on_.size(); ++t) {
    if (!tet_on_[t]) continue;
    const Mat34& ft = settings_.kind == TissueKind::Corotational ? corot_[t].force : spring_[t].force;
    for (size_t a = 0; a < 4; ++a) f[tet_vertices_[t][a]] += ft.col(static_cast<Eigen::Index>(a));
  }
  return f;
}

Vec3 TissueModel::load_on_holder(std::span<const NodeId> nodes) {
  refresh();
  std::vector<std::uint32_t> slots, tets;
  for (const NodeId n : nodes) slots.push_back(n.index);
  std::sort(slots.begin(), slots.end());
  slots.erase(std::unique(slots.begin(), slots.end()), slots.end());
  for (const std::uint32_t i : slots)
    for (const std::uint32_t t : mesh_.node_tets(mesh_.node_handle(i))) tets.push_back(t);
  std::sort(tets.begin(), tets.end());  // each element once, in slot order: a deterministic sum
  tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
  const auto& pos = mesh_.positions();
  const auto held = [&](std::uint32_t i) { return std::binary_search(slots.begin(), slots.end(), i); };
  Vec3 f = Vec3::Zero();
  std::array<Vec3, 4> x;
  for (const std::uint32_t t : tets) {
    if (t >= tet_on_.size() || !tet_on_[t]) continue;
    for (size_t a = 0; a < 4; ++a) x[a] = pos[tet_vertices_[t][a]];
    const Mat34* ft = nullptr;
    CorotationalState corot;
    MassSpringState spring;
    if (settings_.kind == TissueKind::Corotational) {
      Eigen::Quaterniond q = rotation_[t];  // a copy: the step's warm start stays as it was
      evaluate_corotational(rest_[t], x, q, corot);
      ft = &corot.force;
    } else {
      evaluate_mass_spring(rest_[t], x, spring);
      ft = &spring.force;
    }
    for (size_t a = 0; a < 4; ++a)
      if (held(tet_vertices_[t][a])) f += ft->col(static_cast<Eigen::Index>(a));
  }
  for (const std::uint32_t i : slots) f += mass_[i] * settings_.gravity + external_[i];
  return f;
}

parallel::Team& TissueModel::team() {
  const int threads = std::max(settings_.threads, 1);
  if (!team_ || team_->size() != threads) team_ = std::make_unique<parallel::Team>(threads);
  return *team_;
}

StepStats TissueModel::step(double dt) {
  last_ = advance(dt, 0);
  return last_;
}

// A solve that stops at the iteration cap is far from the implicit Euler step where it matters: a
// cut that leaves thousands of elements beyond the strain limit stopped at a residual of 0.037, and
// its last iterate raised the elastic energy 5.3 times over the settled patch's. Such a step is
// not applied but redone as two steps of dt/2: the stiffness weighs dt^2 less against the mass,
// so CG converges in fewer iterations, and implicit Euler is closer to the motion in the smaller
// step. A step that still stops at the cap max_halvings halvings down is not applied either: its
// positions are kept and its velocities zeroed (the tissue is held for that part of the step and
// starts again from rest), which adds no energy; the status says IterationCap. Steps that converge
// take none of this path and are unchanged.
StepStats TissueModel::advance(double dt, int depth) {
  StepStats st = solve_step(dt, depth >= settings_.max_halvings);
  if (st.status != StepStatus::IterationCap || depth >= settings_.max_halvings) return st;
  // The first attempt's work counts; its start-of-step figures describe the step.
  StepStats out = st;
  out.substeps = 0;
  out.residual = 0;
  out.status = StepStatus::Converged;
  for (int half = 0; half < 2; ++half) {
    const StepStats sub = advance(0.5 * dt, depth + 1);
    out.cg_iterations += sub.cg_iterations;
    out.cycle_iterations += sub.cycle_iterations;
    out.local_iterations += sub.local_iterations;
    out.preconditioner_built = out.preconditioner_built || sub.preconditioner_built;
    out.substeps += sub.substeps;
    out.seconds.elements += sub.seconds.elements;
    out.seconds.assembly += sub.seconds.assembly;
    out.seconds.local += sub.seconds.local;
    out.seconds.solve += sub.seconds.solve;
    out.residual = std::max(out.residual, sub.residual);
    out.kinetic_energy = sub.kinetic_energy;
    if (sub.status != StepStatus::Converged) {
      out.status = sub.status;
      out.message = sub.message;
    }
    if (sub.status == StepStatus::NonFinite) break;  // the state after the last good substep is kept
  }
  return out;
}

StepStats TissueModel::solve_step(double dt, bool last) {
  StepStats st;
  // The rows the last topology change rebuilt stay in changed_ until a solve is applied: a step
  // redone in halves (see advance) solves them first again, in its first half.
  const auto done_with_changes = [&] {
    if (!coarse_has_changes_) return;
    changed_.clear();
    coarse_has_changes_ = false;
  };
  const auto fail = [&](const std::string& why) {
    done_with_changes();
    st.status = StepStatus::NonFinite;
    st.message = "tissue step: " + why + "; the step was not applied and the last good state is kept";
    last_ = st;
    return st;
  };
  if (!(dt > 0) || !std::isfinite(dt)) return fail("time step " + std::to_string(dt) + " s is not positive");
  using clock = std::chrono::steady_clock;
  auto stage_start = clock::now();
  const auto stage_end = [&](double& seconds) {
    const auto now = clock::now();
    seconds += std::chrono::duration<double>(now - stage_start).count();
    stage_start = now;
  };
  // The rows a cut dirtied are rebuilt here (refresh): part of the assembly stage.
  refresh();
  ++coarse_age_;
  const std::size_t nn = rows_.size();
  parallel::Team& team = this->team();
  stage_end(st.seconds.assembly);
  st.strain_limited = evaluate_elements(st.elastic_energy);
  stage_end(st.seconds.elements);
  if (!std::isfinite(st.elastic_energy))
    return fail("non-finite elastic energy (NaN or inf in the positions)");
  assemble(dt);

  const StepPlan plan = plan_step();
  double rr = 0, b_norm = 0;
  if (!warm_start(plan, rr, b_norm)) return fail("non-finite forces or velocities");
  st.initial_residual = b_norm > 0 ? std::sqrt(rr) / b_norm : std::sqrt(rr);
  const double target = settings_.tolerance * b_norm;
  const bool local = plan.region && std::sqrt(rr) > target;
  stage_end(st.seconds.assembly);
  update_coarse_and_solve_locally(plan, local, target, st);
  coarse_has_changes_ = !changed_.empty();  // cleared with changed_ once a solve is applied
  born_.clear();
  if (local) rr = parallel::reduce(team, nn, partial_, [&](std::size_t i) { return r_[i].squaredNorm(); });
  stage_end(st.seconds.local);
  if (!std::isfinite(rr)) return fail("non-finite residual after the local solve");
  conjugate_gradients(plan, target, rr, st);
  st.residual = b_norm > 0 ? std::sqrt(rr) / b_norm : std::sqrt(rr);
  st.status = std::sqrt(rr) <= target ? StepStatus::Converged : StepStatus::IterationCap;
  if (st.cycle_iterations > settings_.coarse_rebuild_iterations) coarse_stale_ = true;
  if (st.status == StepStatus::IterationCap) {
    // Not applied (see advance): redone in halves, or at the last halving held.
    if (last) {
      done_with_changes();
      auto& v = mesh_.velocities();
      for (std::size_t i = 0; i < nn; ++i)
        if (mesh_.node_slot_alive(static_cast<std::uint32_t>(i))) v[i].setZero();
      std::ostringstream s;
      s << "tissue step: CG stopped at the iteration cap (" << st.cg_iterations
        << ") with a relative residual of " << st.residual << " in a step of " << dt
        << " s; the step was not applied, the tissue is held";
      st.message = s.str();
      st.kinetic_energy = kinetic_energy();
    }
    stage_end(st.seconds.solve);
    last_ = st;
    return st;
  }
  // Commit only a finite state.
  const auto& pos = mesh_.positions();
  for (std::size_t i = 0; i < nn; ++i)
    if (active_[i] && !(v_[i].allFinite() && (pos[i] + dt * v_[i]).allFinite())) {
      std::ostringstream s;
      s << "non-finite velocity at node " << i << " after " << st.cg_iterations << " CG iterations";
      return fail(s.str());
    }
  done_with_changes();
  apply_velocities(dt);
  st.kinetic_energy = kinetic_energy();
  stage_end(st.seconds.solve);
  last_ = st;
  return st;
}

// The case of this step, decided before it runs: settled (no rows changed since the last applied
// solve), after a cut (changed rows: a local solve on their region first, and the two-level
// preconditioner extended by the new nodes unless it is due for a rebuild), severing (the cut
// severs a coarse aggregate or grew one past coarse_regroup_growth, which is split beside the local
// solve), or rebuild due (the preconditioner was found stale at an earlier step: rebuilt now,
// beside the local solve if any).
TissueModel::StepPlan TissueModel::plan_step() {
  StepPlan p;
  p.two_level = settings_.preconditioner == Preconditioner::TwoLevel;
  p.extend = p.two_level && !coarse_has_changes_ && !coarse_stale_ && !coarse_regroup_ && !changed_.empty();
  p.changed = settings_.local_rings > 0 && !changed_.empty();
  p.active_count =
      (p.changed || p.extend) ? static_cast<std::size_t>(std::count(active_.begin(), active_.end(), 1)) : 0;
  if (p.extend) {
    for (const auto& [n, parent] : born_) coarse_.extend(n, parent, mesh_.positions()[n]);
    coarse_.touch(changed_);  // their coarse rows are out of date (the next split recomputes them)
  }
  // A cut that severs a coarse aggregate, or grows one past its limit: the split runs beside the
  // local solve, whose region then has fewer rings.
  p.severs = p.extend && coarse_.severs(rows_, active_, changed_, settings_.coarse_regroup_growth);
  // After a topology change: the local solve first (see tissue.hpp), on this region.
  p.region = p.changed && local_region(changed_, p.active_count,
                                       p.severs ? std::min(settings_.local_rings, settings_.severing_rings)
                                                : settings_.local_rings);
  // The two-level preconditioner: built at the first step, kept across steps, extended by the nodes
  // a cut created, and rebuilt at the step after the one that found it stale (too many two-level
  // iterations, too many extended nodes; with a smoothed prolongator, an aggregate grown too large):
  // the step that made the change does not also pay for the rebuild.
  p.rebuild = p.two_level && (coarse_stale_ || coarse_regroup_) && !p.extend;
  return p;
}

// v_ from the last velocity of the active nodes, scaled; r_ = b_ - A v_. Returns false if the
// residual is not finite; rr and b_norm: |r|^2 and |b|.
bool TissueModel::warm_start(const StepPlan& plan, double& rr, double& b_norm) {
  const std::size_t nn = rows_.size();
  parallel::Team& team = this->team();
  const auto& vel = mesh_.velocities();
  for (std::size_t i = 0; i < nn; ++i) v_[i] = active_[i] ? vel[i] : Vec3::Zero();
  const double vav = multiply(v_, q_);
  std::vector<double>& part = partial_;
  const std::size_t chunks = chunk_count(nn);
  // Scaled warm start: v = s v0 with s = (b . v0) / (v0 . A v0), the multiple of v0 nearest the
  // solution in the energy norm. Settling motion decays geometrically, so the plain v0 overshoots
  // (after a cut it was a worse guess than zero); s = 1 for steady motion, s = 0 if v0 points away.
  const double bv = parallel::reduce(team, nn, part, [&](std::size_t i) { return b_[i].dot(v_[i]); });
  const double scale = (vav > 0 && bv > 0) ? bv / vav : 0.0;
  // s = 0 after a cut: the cut's new forces, where the local solve works, outweigh the rest. Away
  // from it the tissue still moves as it did, so v0 is kept outside the region and the local solve
  // starts from zero inside it. In the energy norm that start is no better than zero, but the cycles
  // after the local solve need fewer iterations: on the 3 mm deep incision of bench/bench_fem.cpp,
  // 4-5 instead of 6-8 where the blade enters the next column of cells, 4.10 instead of 4.31 per cut
  // step (mass-spring 10.7 instead of 11.6; at 5 thousand tetrahedra 8.4 instead of 8.0, in the
  // same time).
  const bool keep_outside = plan.region && scale == 0;
  if (keep_outside) {
    for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i)
        if (in_local_[i]) v_[i].setZero();
    });
    multiply(v_, q_);
  }
  const double applied = keep_outside ? 1.0 : scale;
  for_chunks(team, nn, [&](std::size_t c, std::size_t begin, std::size_t end) {
    double r2 = 0, b2 = 0;
    for (std::size_t i = begin; i < end; ++i) {
      v_[i] *= applied;
      r_[i] = active_[i] ? Vec3(b_[i] - applied * q_[i]) : Vec3::Zero();
      r2 += r_[i].squaredNorm();
      b2 += b_[i].squaredNorm();
    }
    part[c] = r2;
    part[chunks + c] = b2;
  });
  rr = sum(part, chunks);
  double bb = 0;
  for (std::size_t c = 0; c < chunks; ++c) bb += part[chunks + c];
  b_norm = std::sqrt(bb);
  return std::isfinite(b_norm) && std::isfinite(rr);
}

// An aggregate the cut severed would tie both sides of the crack to one rigid motion, and one the
// cuts' nodes grew holds the tissue that deforms most in one. severs already searched the touched
// aggregates: without it there is nothing to split.
void TissueModel::split_coarse(const StepPlan& plan, parallel::Team& split_team, StepStats& st) {
  if (plan.severs) {
    const bool whole = coarse_age_ > kCoarseRefreshSteps;
    st.aggregates_split = coarse_.split_severed(rows_, active_, changed_, mesh_.positions(), split_team,
                                                whole, settings_.coarse_regroup_growth);
    if (coarse_.split_whole()) coarse_age_ = 0;
  }
  coarse_stale_ = static_cast<double>(coarse_.extended()) >
                  settings_.coarse_rebuild_fraction * static_cast<double>(plan.active_count);
  // A smoothed prolongator is not split: its grown aggregates are regrouped by a rebuild.
  coarse_regroup_ =
      !coarse_stale_ && coarse_.smoothed() && coarse_.growth() > settings_.coarse_regroup_growth;
}

void TissueModel::build_coarse(parallel::Team& build_team, std::vector<double>& build_partial,
                               StepStats& st) {
  coarse_.set_options(settings_.two_level);
  coarse_.build(rows_, diag_inverse_, active_, mesh_.positions(), build_partial, build_team, coarse_stale_);
  coarse_stale_ = false;
  coarse_regroup_ = false;
  coarse_age_ = 0;
  st.preconditioner_built = true;
}

void TissueModel::update_coarse_and_solve_locally(const StepPlan& plan, bool local, double target,
                                                  StepStats& st) {
  parallel::Team& team = this->team();
  if (local && plan.severs) {
    // The split on one worker, the local solve on the caller, joined by the worker once the split
    // is done.
    team.run_beside([&] { split_coarse(plan, solo_, st); },
                    [&] { solve_locally(plan.active_count, target, st, team); });
  } else if (local && plan.rebuild) {
    // A rebuild does not need the local solve's result either: the same.
    team.run_beside([&] { build_coarse(solo_, solo_partial_, st); },
                    [&] { solve_locally(plan.active_count, target, st, team); });
  } else {
    if (plan.extend) split_coarse(plan, team, st);
    if (local) solve_locally(plan.active_count, target, st, team);
    if (plan.rebuild) build_coarse(team, partial_, st);
  }
}

// Preconditioned conjugate gradients on the active nodes from the warm start, to |r| <= target or
// the iteration cap; rr: |r|^2, kept current.
void TissueModel::conjugate_gradients(const StepPlan& plan, double target, double& rr, StepStats& st) {
  const std::size_t nn = rows_.size();
  parallel::Team& team = this->team();
  std::vector<double>& part = partial_;
  const bool two_level = plan.two_level;
  // z = B r; returns r . z.
  bool cycle = false;  // the two-level cycle is in use
  const auto precondition = [&] {
    if (cycle) {
      coarse_.apply(rows_, diag_inverse_, active_, r_, z_, team);
      return parallel::reduce(team, nn, part, [&](std::size_t i) { return r_[i].dot(z_[i]); });
    }
    return parallel::reduce(team, nn, part, [&](std::size_t i) {
      z_[i] = diag_inverse_[i] * r_[i];
      return r_[i].dot(z_[i]);
    });
  };

  int it = 0, cycle_it = 0;
  bool reestimated = false;
  double rz = 0;
  const auto restart = [&] {
    rz = precondition();
    for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) p_[i] = z_[i];
    });
  };
  // Escalation: a V(1,1) cycle costs about three block-Jacobi iterations, so a step whose warm start
  // is good stays on block-Jacobi; after two_level_after iterations CG restarts from its current
  // iterate with the two-level cycle (a restart keeps v and r; only the search direction is lost).
  // A warm start that removed less than half of the residual is a cold start, and what a local
  // solve leaves is smooth: the cycle from the first iteration.
  const int escalate = (st.initial_residual > 0.5 || st.local_nodes > 0) ? 0 : settings_.two_level_after;
  cycle = two_level && coarse_.factored() && escalate <= 0;
  if (std::sqrt(rr) > target) restart();
  while (std::sqrt(rr) > target && it < settings_.max_iterations) {
    if (two_level && !cycle && it == escalate && coarse_.factored()) {
      cycle = true;
      restart();
    }
    // The cycle is not positive definite here: the smoother's bound (lambda, kept by regroups) no
    // longer covers the spectrum, which cuts stiffen. Rebuilt with a fresh estimate, once a step,
    // then back to block-Jacobi (seen in the mass-spring incision of bench/bench_fem.cpp with
    // local_fraction 0.6: after 5 iterations, then 102 with block-Jacobi, or 19 rebuilt).
    if (cycle && !(rz > 0) && !reestimated) {
      reestimated = true;
      coarse_stale_ = true;
      build_coarse(team, partial_, st);
      restart();
    }
    if (cycle && !(rz > 0)) {
      cycle = false;
      coarse_stale_ = true;
      restart();
    }
    const double pq = multiply(p_, q_);
    if (!(pq > 0)) break;  // A is positive definite on the active nodes; a breakdown ends the solve
    const double alpha = rz / pq;
    rr = parallel::reduce(team, nn, part, [&](std::size_t i) {
      v_[i] += alpha * p_[i];
      r_[i] -= alpha * q_[i];
      return r_[i].squaredNorm();
    });
    ++it;
    cycle_it += cycle ? 1 : 0;
    if (std::sqrt(rr) <= target) break;
    const double rz_new = precondition();
    const double beta = rz_new / rz;
    rz = rz_new;
    for_chunks(team, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) p_[i] = z_[i] + beta * p_[i];
    });
  }
  st.cg_iterations = it;
  st.cycle_iterations = cycle_it;
}

// Applies the solved velocities: active nodes move with theirs, passengers with their supporting
// neighbours', the rest stand.
void TissueModel::apply_velocities(double dt) {
  const std::size_t nn = rows_.size();
  auto& x = mesh_.positions();
  auto& v = mesh_.velocities();
  for (std::size_t i = 0; i < nn; ++i) {
    if (!mesh_.node_slot_alive(static_cast<std::uint32_t>(i))) continue;
    if (active_[i]) {
      v[i] = v_[i];
      x[i] += dt * v_[i];
    } else if (passenger_[i]) {
      // Rides with the mean new velocity of its neighbours that carry stiffness (fixed ones: 0).
      Vec3 sum = Vec3::Zero();
      int count = 0;
      for (const std::uint32_t j : rows_[i].cols)
        if (active_[j] || prescribed_[j]) {
          sum += v_[j];
          ++count;
        }
      v[i] = count > 0 ? Vec3(sum / count) : Vec3::Zero();
      x[i] += dt * v[i];
    } else {
      v[i].setZero();
    }
  }
}

}  // namespace scalpel
