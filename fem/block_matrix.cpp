#include "fem/block_matrix.hpp"

#include <algorithm>

#include "fem/parallel.hpp"

namespace scalpel {

BlockRows::BlockRows(const BlockRows& other)
    : rows_(other.rows_),
      start_(other.start_),
      room_(other.room_),
      cols_(other.cols_),
      blocks_(other.blocks_),
      roomed_(other.roomed_) {
  point_views();
}

BlockRows& BlockRows::operator=(const BlockRows& other) {
  if (this != &other) {
    rows_ = other.rows_;
    start_ = other.start_;
    room_ = other.room_;
    cols_ = other.cols_;
    blocks_ = other.blocks_;
    roomed_ = other.roomed_;
    point_views();
  }
  return *this;
}

void BlockRows::grow(std::size_t n) {
  if (n <= rows_.size()) return;
  rows_.resize(n);
  start_.resize(n, 0);
  room_.resize(n, 0);
}

void BlockRows::set(std::size_t i, std::span<const std::uint32_t> cols) {
  if (cols.size() <= room_[i]) {
    std::copy(cols.begin(), cols.end(), cols_.begin() + static_cast<std::ptrdiff_t>(start_[i]));
    std::fill_n(blocks_.begin() + static_cast<std::ptrdiff_t>(start_[i]), cols.size(), Mat3::Zero());
    view(i, cols);
    return;
  }
  roomed_ -= room_[i];
  const std::uint32_t* cols_data = cols_.data();
  const Mat3* blocks_data = blocks_.data();
  place(i, cols);
  if (cols_.size() - roomed_ > cols_.size() / 8) {
    repack();
  } else if (cols_.data() != cols_data || blocks_.data() != blocks_data) {
    point_views();  // the storage moved as it grew
  }
}

// At the end of the storage, with its room.
void BlockRows::place(std::size_t i, std::span<const std::uint32_t> cols) {
  const std::size_t need = cols_.size() + cols.size() + kSlack;
  if (need > cols_.capacity()) {  // both arrays move at once
    const std::size_t capacity = std::max(need, 2 * cols_.capacity());
    cols_.reserve(capacity);
    blocks_.reserve(capacity);
  }
  start_[i] = cols_.size();
  room_[i] = cols.size() + kSlack;
  roomed_ += room_[i];
  cols_.insert(cols_.end(), cols.begin(), cols.end());
  cols_.resize(cols_.size() + kSlack, 0);
  blocks_.resize(cols_.size(), Mat3::Zero());
  view(i, cols);
}

// Row i's view of its place in the storage, which holds `cols`.
void BlockRows::view(std::size_t i, std::span<const std::uint32_t> cols) {
  BlockRow& row = rows_[i];
  row.cols = {cols_.data() + start_[i], cols.size()};
  row.blocks = {blocks_.data() + start_[i], cols.size()};
  row.diag = cols.empty()
                 ? 0
                 : static_cast<std::uint32_t>(std::lower_bound(cols.begin(), cols.end(), i) - cols.begin());
}

// Every row again, in row order, its blocks kept.
void BlockRows::repack() {
  std::vector<std::uint32_t> cols;
  std::vector<Mat3> blocks;
  cols.reserve(roomed_);
  blocks.reserve(roomed_);
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const std::size_t n = rows_[i].cols.size();
    const auto from = static_cast<std::ptrdiff_t>(start_[i]);
    start_[i] = cols.size();
    room_[i] = n + kSlack;
    cols.insert(cols.end(), cols_.begin() + from, cols_.begin() + from + static_cast<std::ptrdiff_t>(n));
    cols.resize(cols.size() + kSlack, 0);
    blocks.insert(blocks.end(), blocks_.begin() + from,
                  blocks_.begin() + from + static_cast<std::ptrdiff_t>(n));
    blocks.resize(cols.size(), Mat3::Zero());
  }
  cols_ = std::move(cols);
  blocks_ = std::move(blocks);
  roomed_ = cols_.size();
  point_views();
}

void BlockRows::point_views() {
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    BlockRow& row = rows_[i];
    const std::size_t n = row.cols.size();
    row.cols = {cols_.data() + start_[i], n};
    row.blocks = {blocks_.data() + start_[i], n};
  }
}

double multiply(std::span<const BlockRow> a, std::span<const std::uint8_t> active, const std::vector<Vec3>& x,
                std::vector<Vec3>& y, std::vector<double>& partial, parallel::Team& team) {
  const std::size_t nn = a.size();
  parallel::for_chunks(team, nn, [&](std::size_t c, std::size_t begin, std::size_t end) {
    double d = 0;
    for (std::size_t i = begin; i < end; ++i) {
      if (!active[i]) {
        y[i].setZero();
        continue;
      }
      const Vec3 s = row_product(a[i], x);
      y[i] = s;
      d += x[i].dot(s);
    }
    partial[c] = d;
  });
  return parallel::sum(partial, parallel::chunk_count(nn));
}

}  // namespace scalpel
