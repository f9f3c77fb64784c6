// Sparse symmetric matrices of 3x3 blocks, one row per mesh node (docs/tissue.md).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "fem/element.hpp"
#include "fem/parallel.hpp"

namespace scalpel {

// One block row: A(i, cols[k]) = blocks[k]; cols sorted, containing i itself at diag. A node that
// is not active (fixed or massless) has an empty or all-zero row and all-zero column blocks.
struct BlockRow {
  std::vector<std::uint32_t> cols;
  std::vector<Mat3> blocks;
  std::uint32_t diag = 0;
};

// (A x)_i for one block row.
[[nodiscard]] inline Vec3 row_product(const BlockRow& row, const std::vector<Vec3>& x) {
  Vec3 s = Vec3::Zero();
  for (std::size_t k = 0; k < row.cols.size(); ++k) s.noalias() += row.blocks[k] * x[row.cols[k]];
  return s;
}

// y = A x over the active rows (others get 0), returns x . y. partial holds chunk_count(n) sums.
double multiply(std::span<const BlockRow> a, std::span<const std::uint8_t> active, const std::vector<Vec3>& x,
                std::vector<Vec3>& y, std::vector<double>& partial, parallel::Team& team);

}  // namespace scalpel
