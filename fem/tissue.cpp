#include "fem/tissue.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace scalpel {

namespace {

// Work is split into chunks of a fixed size, independent of the thread count, and per-chunk partial
// sums are added in chunk order: reductions are deterministic.
constexpr std::size_t kChunk = 256;

std::size_t chunk_count(std::size_t n) {
  return (n + kChunk - 1) / kChunk;
}

template <class F>
void for_chunks(int threads, std::size_t n, F&& f) {
  const long chunks = static_cast<long>(chunk_count(n));
#pragma omp parallel for num_threads(threads) schedule(static)
  for (long c = 0; c < chunks; ++c) {
    const std::size_t begin = static_cast<std::size_t>(c) * kChunk;
    f(static_cast<std::size_t>(c), begin, std::min(n, begin + kChunk));
  }
}

double sum(const std::vector<double>& partial, std::size_t n) {
  double s = 0;
  for (std::size_t c = 0; c < n; ++c) s += partial[c];
  return s;
}

}  // namespace

TissueModel::TissueModel(TetMesh& mesh, std::vector<Material> materials, TissueSettings settings)
    : mesh_(mesh), materials_(std::move(materials)), settings_(settings) {
  for (std::size_t r = 0; r < materials_.size(); ++r)
    if (const auto err = validate_material(materials_[r]))
      throw std::invalid_argument("materials[" + std::to_string(r) + "]." + err->field + ": " + err->message);
  if (settings_.threads < 1) settings_.threads = 1;
  grow();
  const std::vector<TetId> tets = mesh_.tets();
  on_tets_added(tets);
  for (std::uint32_t i = 0; i < mesh_.node_capacity(); ++i)
    if (!dirty_[i]) {
      dirty_[i] = 1;
      dirty_list_.push_back(i);
    }
}

void TissueModel::grow() {
  const std::size_t nt = mesh_.tet_capacity();
  if (rest_.size() < nt) {
    rest_.resize(nt);
    rotation_.resize(nt, Eigen::Quaterniond::Identity());
    tet_vertices_.resize(nt);
    tet_region_.resize(nt, 0);
    tet_on_.resize(nt, 0);
    if (settings_.kind == TissueKind::Corotational)
      corot_.resize(nt);
    else
      spring_.resize(nt);
  }
  const std::size_t nn = mesh_.node_capacity();
  if (fixed_.size() < nn) {
    fixed_.resize(nn, 0);
    active_.resize(nn, 0);
    dirty_.resize(nn, 0);
    external_.resize(nn, Vec3::Zero());
    mass_.resize(nn, 0.0);
    rows_.resize(nn);
    for (auto* v : {&b_, &v_, &r_, &z_, &p_, &q_}) v->resize(nn, Vec3::Zero());
    diag_inverse_.resize(nn, Mat3::Identity());
  }
  const std::size_t chunks = std::max(chunk_count(nn), chunk_count(nt));
  if (partial_.size() < 3 * chunks) partial_.resize(3 * chunks, 0.0);
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
    external_[n].setZero();
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
  if (!dirty_[n.index]) {
    dirty_[n.index] = 1;
    dirty_list_.push_back(n.index);
  }
}

bool TissueModel::fixed(NodeId n) const {
  return n.index < fixed_.size() && fixed_[n.index];
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

// Rebuilds one node row: its incident elements, sparsity pattern and lumped mass.
void TissueModel::rebuild_row(std::uint32_t i) {
  Row& row = rows_[i];
  row.cols.clear();
  row.entries.clear();
  mass_[i] = 0;
  active_[i] = 0;
  if (!mesh_.node_slot_alive(i)) {
    row.blocks.clear();
    return;
  }
  std::vector<std::uint32_t> tets;
  for (const std::uint32_t t : mesh_.node_tets(mesh_.node_handle(i)))
    if (t < tet_on_.size() && tet_on_[t]) tets.push_back(t);
  std::sort(tets.begin(), tets.end());
  row.cols.push_back(i);
  for (const std::uint32_t t : tets)
    for (const std::uint32_t n : tet_vertices_[t]) row.cols.push_back(n);
  std::sort(row.cols.begin(), row.cols.end());
  row.cols.erase(std::unique(row.cols.begin(), row.cols.end()), row.cols.end());
  const auto col_of = [&](std::uint32_t n) {
    return static_cast<std::uint32_t>(std::lower_bound(row.cols.begin(), row.cols.end(), n) -
                                      row.cols.begin());
  };
  row.diag = col_of(i);
  for (const std::uint32_t t : tets) {
    Entry e{t, 0, {}};
    for (int a = 0; a < 4; ++a) {
      const std::uint32_t n = tet_vertices_[t][static_cast<size_t>(a)];
      if (n == i) e.local = a;
      e.block[static_cast<size_t>(a)] = col_of(n);
    }
    row.entries.push_back(e);
    mass_[i] += materials_[static_cast<std::size_t>(tet_region_[t])].density * rest_[t].mass_volume / 4.0;
  }
  row.blocks.assign(row.cols.size(), Mat3::Zero());
  active_[i] = (!fixed_[i] && mass_[i] > 0) ? 1 : 0;
}

void TissueModel::refresh() {
  grow();
  std::sort(dirty_list_.begin(), dirty_list_.end());
  for (const std::uint32_t i : dirty_list_) {
    rebuild_row(i);
    dirty_[i] = 0;
  }
  dirty_list_.clear();
#ifdef SCALPEL_VALIDATE
  for (std::uint32_t t = 0; t < tet_on_.size(); ++t)
    if (static_cast<bool>(tet_on_[t]) != mesh_.tet_slot_alive(t) ||
        (tet_on_[t] && tet_vertices_[t] != mesh_.tet_vertex_indices(t)))
      throw std::logic_error("tissue: tetrahedron " + std::to_string(t) +
                             " changed without a topology notification");
#endif
}

void TissueModel::evaluate_elements(double& energy) {
  const std::size_t nt = tet_on_.size();
  const auto& pos = mesh_.positions();
  const bool corot = settings_.kind == TissueKind::Corotational;
  for_chunks(settings_.threads, nt, [&](std::size_t c, std::size_t begin, std::size_t end) {
    double e = 0;
    std::array<Vec3, 4> x;
    for (std::size_t t = begin; t < end; ++t) {
      if (!tet_on_[t]) continue;
      for (size_t a = 0; a < 4; ++a) x[a] = pos[tet_vertices_[t][a]];
      if (corot) {
        evaluate_corotational(rest_[t], x, rotation_[t], corot_[t]);
        e += corot_[t].energy;
      } else {
        evaluate_mass_spring(rest_[t], x, spring_[t]);
        e += spring_[t].energy;
      }
    }
    partial_[c] = e;
  });
  energy = sum(partial_, chunk_count(nt));
}

// Row-wise assembly of A = M + dt C + dt^2 K, the right-hand side and the block-Jacobi inverse.
void TissueModel::assemble(double dt) {
  const std::size_t nn = rows_.size();
  const bool corot = settings_.kind == TissueKind::Corotational;
  const auto& vel = mesh_.velocities();
  for_chunks(settings_.threads, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (!active_[i]) {
        b_[i].setZero();
        continue;
      }
      Row& row = rows_[i];
      for (Mat3& blk : row.blocks) blk.setZero();
      Vec3 f = Vec3::Zero();
      double mass_term = 0;
      for (const Entry& e : row.entries) {
        const Material& m = materials_[static_cast<std::size_t>(tet_region_[e.tet])];
        const TetRest& rest = rest_[e.tet];
        const double h = dt * m.damping_stiffness + dt * dt;
        mass_term += (1.0 + dt * m.damping_mass) * m.density * rest.mass_volume / 4.0;
        if (corot) {
          const CorotationalState& s = corot_[e.tet];
          f += s.force.col(e.local);
          for (int b = 0; b < 4; ++b)
            row.blocks[e.block[static_cast<size_t>(b)]] += h * corotational_block(rest, s, e.local, b);
        } else {
          const MassSpringState& s = spring_[e.tet];
          f += s.force.col(e.local);
          for (int b = 0; b < 4; ++b)
            row.blocks[e.block[static_cast<size_t>(b)]] += h * mass_spring_block(rest, s, e.local, b);
        }
      }
      row.blocks[row.diag].diagonal().array() += mass_term;
      // Fixed or massless neighbours have v = 0: their columns drop out.
      for (std::size_t k = 0; k < row.cols.size(); ++k)
        if (!active_[row.cols[k]]) row.blocks[k].setZero();
      b_[i] = mass_[i] * vel[i] + dt * (f + mass_[i] * settings_.gravity + external_[i]);
      diag_inverse_[i] = row.blocks[row.diag].inverse();
    }
  });
}

void TissueModel::multiply(const std::vector<Vec3>& x, std::vector<Vec3>& y, double& dot_xy) {
  const std::size_t nn = rows_.size();
  for_chunks(settings_.threads, nn, [&](std::size_t c, std::size_t begin, std::size_t end) {
    double d = 0;
    for (std::size_t i = begin; i < end; ++i) {
      if (!active_[i]) {
        y[i].setZero();
        continue;
      }
      const Row& row = rows_[i];
      Vec3 s = Vec3::Zero();
      for (std::size_t k = 0; k < row.cols.size(); ++k) s.noalias() += row.blocks[k] * x[row.cols[k]];
      y[i] = s;
      d += x[i].dot(s);
    }
    partial_[c] = d;
  });
  dot_xy = sum(partial_, chunk_count(nn));
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

StepStats TissueModel::step(double dt) {
  StepStats st;
  const auto fail = [&](const std::string& why) {
    st.status = StepStatus::NonFinite;
    st.message = "tissue step: " + why + "; the step was not applied and the last good state is kept";
    last_ = st;
    return st;
  };
  if (!(dt > 0) || !std::isfinite(dt)) return fail("time step " + std::to_string(dt) + " s is not positive");
  refresh();
  const std::size_t nn = rows_.size();
  const int threads = settings_.threads;

  evaluate_elements(st.elastic_energy);
  if (!std::isfinite(st.elastic_energy))
    return fail("non-finite elastic energy (NaN or inf in the positions)");
  assemble(dt);

  // Preconditioned conjugate gradients on the active nodes, warm-started from the last velocity.
  const auto& vel = mesh_.velocities();
  for (std::size_t i = 0; i < nn; ++i) v_[i] = active_[i] ? vel[i] : Vec3::Zero();
  double dummy = 0;
  multiply(v_, q_, dummy);
  std::vector<double>& part = partial_;
  const std::size_t chunks = chunk_count(nn);
  for_chunks(threads, nn, [&](std::size_t c, std::size_t begin, std::size_t end) {
    double rz = 0, rr = 0, bb = 0;
    for (std::size_t i = begin; i < end; ++i) {
      r_[i] = b_[i] - q_[i];
      z_[i] = diag_inverse_[i] * r_[i];
      if (!active_[i]) {
        r_[i].setZero();
        z_[i].setZero();
      }
      p_[i] = z_[i];
      rz += r_[i].dot(z_[i]);
      rr += r_[i].squaredNorm();
      bb += b_[i].squaredNorm();
    }
    part[c] = rz;
    part[chunks + c] = rr;
    part[2 * chunks + c] = bb;
  });
  double rz = sum(part, chunks);
  double rr = 0, bb = 0;
  for (std::size_t c = 0; c < chunks; ++c) {
    rr += part[chunks + c];
    bb += part[2 * chunks + c];
  }
  const double b_norm = std::sqrt(bb);
  if (!std::isfinite(b_norm) || !std::isfinite(rr)) return fail("non-finite forces or velocities");

  const double target = settings_.tolerance * b_norm;
  int it = 0;
  while (std::sqrt(rr) > target && it < settings_.max_iterations) {
    double pq = 0;
    multiply(p_, q_, pq);
    if (!(pq > 0)) break;  // A is positive definite on the active nodes; a breakdown ends the solve
    const double alpha = rz / pq;
    for_chunks(threads, nn, [&](std::size_t c, std::size_t begin, std::size_t end) {
      double rz_c = 0, rr_c = 0;
      for (std::size_t i = begin; i < end; ++i) {
        v_[i] += alpha * p_[i];
        r_[i] -= alpha * q_[i];
        z_[i] = diag_inverse_[i] * r_[i];
        rz_c += r_[i].dot(z_[i]);
        rr_c += r_[i].squaredNorm();
      }
      part[c] = rz_c;
      part[chunks + c] = rr_c;
    });
    const double rz_new = sum(part, chunks);
    rr = 0;
    for (std::size_t c = 0; c < chunks; ++c) rr += part[chunks + c];
    const double beta = rz_new / rz;
    rz = rz_new;
    for_chunks(threads, nn, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) p_[i] = z_[i] + beta * p_[i];
    });
    ++it;
  }
  st.cg_iterations = it;
  st.residual = b_norm > 0 ? std::sqrt(rr) / b_norm : std::sqrt(rr);
  st.status = std::sqrt(rr) <= target ? StepStatus::Converged : StepStatus::IterationCap;

  // Commit only a finite state.
  const auto& pos = mesh_.positions();
  for (std::size_t i = 0; i < nn; ++i)
    if (active_[i] && !(v_[i].allFinite() && (pos[i] + dt * v_[i]).allFinite())) {
      std::ostringstream s;
      s << "non-finite velocity at node " << i << " after " << it << " CG iterations";
      return fail(s.str());
    }
  auto& x = mesh_.positions();
  auto& v = mesh_.velocities();
  for (std::size_t i = 0; i < nn; ++i) {
    if (!mesh_.node_slot_alive(static_cast<std::uint32_t>(i))) continue;
    if (active_[i]) {
      v[i] = v_[i];
      x[i] += dt * v_[i];
    } else {
      v[i].setZero();
    }
  }
  st.kinetic_energy = kinetic_energy();
  last_ = st;
  return st;
}

}  // namespace scalpel
