// Sparse symmetric matrices of 3x3 blocks, one row per mesh node (docs/tissue.md).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "fem/element.hpp"
#include "fem/parallel.hpp"

namespace scalpel {

// One block row: A(i, cols[k]) = blocks[k]; cols sorted, containing i itself at diag. A node that
// is not active (fixed or massless) has an empty or all-zero row and all-zero column blocks. A view
// into the storage of BlockRows.
struct BlockRow {
  std::span<const std::uint32_t> cols;
  std::span<const Mat3> blocks;
  std::uint32_t diag = 0;
};

// The block rows of a matrix, stored one after another in two arrays (columns, blocks) in row order,
// as a compressed-row matrix: a product streams through memory. Rows held in vectors of their own
// lay scattered over the heap, the more so as cuts rebuilt them: a product over the 20-thousand-
// tetrahedron patch took 1.35 times as long as over the same rows copied in order, 1.5 times at
// the end of its incision.
//
// A row is set whole (its columns; its blocks start at zero). It keeps its place while its columns
// fit in its room (its size when it was placed, and kSlack more: a cut adds a few columns to the
// rows around it); a row that outgrows its room moves to the end. Once the rooms left behind hold
// more than an eighth of the storage, every row is placed again in row order. set() moves rows:
// one call at a time, with columns that do not point into this storage; threads may write the
// blocks of different rows at once.
class BlockRows {
 public:
  static constexpr std::size_t kSlack = 4;

  BlockRows() = default;
  BlockRows(const BlockRows& other);
  BlockRows& operator=(const BlockRows& other);
  BlockRows(BlockRows&&) noexcept = default;
  BlockRows& operator=(BlockRows&&) noexcept = default;
  ~BlockRows() = default;

  [[nodiscard]] std::size_t size() const { return rows_.size(); }
  // Adds empty rows up to n (never shrinks).
  void grow(std::size_t n);
  [[nodiscard]] const BlockRow& operator[](std::size_t i) const { return rows_[i]; }
  // Row i's blocks, to write.
  [[nodiscard]] std::span<Mat3> blocks(std::size_t i) {
    return {blocks_.data() + start_[i], rows_[i].blocks.size()};
  }
  operator std::span<const BlockRow>() const { return rows_; }  // NOLINT: a view, as a vector's
  // Row i gets the columns `cols` (sorted, without repeats; i among them unless empty), its blocks
  // zero.
  void set(std::size_t i, std::span<const std::uint32_t> cols);

  // Entries the rows' storage holds, theirs, their rooms' and those left behind (for tests).
  [[nodiscard]] std::size_t stored() const { return cols_.size(); }

 private:
  void place(std::size_t i, std::span<const std::uint32_t> cols);
  void view(std::size_t i, std::span<const std::uint32_t> cols);
  void repack();
  void point_views();

  std::vector<BlockRow> rows_;
  std::vector<std::size_t> start_, room_;
  std::vector<std::uint32_t> cols_;
  std::vector<Mat3> blocks_;
  std::size_t roomed_ = 0;  // entries in the rows' rooms; the rest of the storage was left behind
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
