// The step's per-element work (fem/tissue.hpp, docs/tissue.md, "Implicit Euler"): element states
// four at a time, and the row-wise assembly of the matrix, the right-hand side and the block-Jacobi
// inverse from them.
#include "fem/parallel.hpp"
#include "fem/row_kernel.hpp"
#include "fem/tissue.hpp"

namespace scalpel {

using parallel::chunk_count;
using parallel::for_chunks;
using parallel::sum;

std::size_t TissueModel::evaluate_elements(double& energy) {
  const std::size_t nt = tet_on_.size();
  const std::size_t chunks = chunk_count(nt);
  const auto& pos = mesh_.positions();
  const bool corot = settings_.kind == TissueKind::Corotational;
  for_chunks(team(), nt, [&](std::size_t c, std::size_t begin, std::size_t end) {
    double e = 0, held = 0;
    if (corot) {
      // Four live elements at a time (evaluate_corotational4), the rest one by one; the same bits.
      std::array<std::array<Vec3, 4>, 4> x;
      std::array<std::uint32_t, 4> group{};
      std::size_t n = 0;
      const auto add = [&](std::uint32_t t) {
        e += corot_[t].energy;
        held += corot_[t].held ? 1 : 0;
      };
      for (std::size_t t = begin; t < end; ++t) {
        if (!tet_on_[t]) continue;
        for (size_t a = 0; a < 4; ++a) x[n][a] = pos[tet_vertices_[t][a]];
        group[n++] = static_cast<std::uint32_t>(t);
        if (n < 4) continue;
        evaluate_corotational4(
            {&rest_[group[0]], &rest_[group[1]], &rest_[group[2]], &rest_[group[3]]},
            {&x[0], &x[1], &x[2], &x[3]},
            {&rotation_[group[0]], &rotation_[group[1]], &rotation_[group[2]], &rotation_[group[3]]},
            {&corot_[group[0]], &corot_[group[1]], &corot_[group[2]], &corot_[group[3]]});
        for (const std::uint32_t g : group) add(g);
        n = 0;
      }
      for (std::size_t k = 0; k < n; ++k) {
        evaluate_corotational(rest_[group[k]], x[k], rotation_[group[k]], corot_[group[k]]);
        add(group[k]);
      }
    } else {
      std::array<Vec3, 4> x;
      for (std::size_t t = begin; t < end; ++t) {
        if (!tet_on_[t]) continue;
        for (size_t a = 0; a < 4; ++a) x[a] = pos[tet_vertices_[t][a]];
        evaluate_mass_spring(rest_[t], x, spring_[t]);
        e += spring_[t].energy;
        held += spring_[t].held ? 1 : 0;
      }
    }
    partial_[c] = e;
    partial_[chunks + c] = held;
  });
  energy = sum(partial_, chunks);
  double held = 0;
  for (std::size_t c = 0; c < chunks; ++c) held += partial_[chunks + c];
  return static_cast<std::size_t>(held);
}

namespace {

constexpr std::size_t kPrefetchAhead = 16;

// Asks for every cache line t lies on, ahead of its use.
template <class T>
void prefetch(const T& t) {
  constexpr std::uintptr_t kLine = 64;
  const auto first = reinterpret_cast<std::uintptr_t>(&t) & ~(kLine - 1);
  const auto last = reinterpret_cast<std::uintptr_t>(&t) + sizeof(T) - 1;
  for (std::uintptr_t line = first; line <= last; line += kLine)
    __builtin_prefetch(reinterpret_cast<const void*>(line));
}

}  // namespace

// Row-wise assembly of A = M + dt C + dt^2 K, the right-hand side and the block-Jacobi inverse.
void TissueModel::assemble(double dt) {
  const std::size_t nn = rows_.size();
  const bool corot = settings_.kind == TissueKind::Corotational;
  const auto& vel = mesh_.velocities();
  const CorotationalRowKernel corot_row = corotational_row_kernel();
  for (std::size_t r = 0; r < materials_.size(); ++r)
    stiffness_factor_[r] = dt * materials_[r].damping_stiffness + dt * dt;
  for_chunks(team(), nn, [&](std::size_t, std::size_t begin, std::size_t end) {
    // The element states of a row lie far apart (a row's tetrahedra span two layers of cells): a
    // cursor runs kPrefetchAhead entries ahead of the assembly, across the ends of rows, and asks
    // for each state before it is read.
    std::size_t ahead_row = begin, ahead_entry = 0;
    const auto prefetch_next = [&](std::size_t count) {
      while (count > 0 && ahead_row < end) {
        if (!active_[ahead_row] || ahead_entry >= entries_[ahead_row].size()) {
          ++ahead_row;
          ahead_entry = 0;
          continue;
        }
        const std::uint32_t t = entries_[ahead_row][ahead_entry++].tet;
        if (corot)
          prefetch(corot_[t]);
        else
          prefetch(spring_[t]);
        --count;
      }
    };
    prefetch_next(kPrefetchAhead);
    for (std::size_t i = begin; i < end; ++i) {
      if (!active_[i]) {
        b_[i].setZero();
        continue;
      }
      const BlockRow& row = rows_[i];
      const std::span<Mat3> blocks = rows_.blocks(i);
      for (Mat3& blk : blocks) blk.setZero();
      Vec3 f = Vec3::Zero();
      // Per entry only the element's state is read (rest data and mass are per row or region).
      for (const Entry& e : entries_[i]) {
        prefetch_next(1);
        const double h = stiffness_factor_[e.region];
        if (corot) {
          const CorotationalState& s = corot_[e.tet];
          f += s.force.col(e.local);
          corot_row(s, e.local, h,
                    {&blocks[e.block[0]], &blocks[e.block[1]], &blocks[e.block[2]], &blocks[e.block[3]]});
        } else {
          const MassSpringState& s = spring_[e.tet];
          f += s.force.col(e.local);
          add_mass_spring_row(
              s, e.local, h,
              {&blocks[e.block[0]], &blocks[e.block[1]], &blocks[e.block[2]], &blocks[e.block[3]]});
        }
      }
      blocks[row.diag].diagonal().array() += mass_[i] + dt * mass_damping_[i];
      // Fixed or massless neighbours have v = 0: their columns drop out.
      for (std::size_t k = 0; k < row.cols.size(); ++k)
        if (!active_[row.cols[k]]) blocks[k].setZero();
      b_[i] = mass_[i] * vel[i] + dt * (f + mass_[i] * settings_.gravity + external_[i]);
      diag_inverse_[i] = row.blocks[row.diag].inverse();
    }
  });
}

}  // namespace scalpel
