// Deterministic parallel loops for the tissue solver (DESIGN section 6).
//
// Work is split into chunks of a fixed size, independent of the thread count, and per-chunk partial
// sums are added in chunk order: reductions are bit-identical for any number of threads.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace scalpel::parallel {

inline constexpr std::size_t kChunk = 256;

inline std::size_t chunk_count(std::size_t n) {
  return (n + kChunk - 1) / kChunk;
}

// f(chunk, begin, end) over [0, n) in chunks of kChunk, on `threads` OpenMP threads.
template <class F>
void for_chunks(int threads, std::size_t n, F&& f) {
  const long chunks = static_cast<long>(chunk_count(n));
#pragma omp parallel for num_threads(threads) schedule(static)
  for (long c = 0; c < chunks; ++c) {
    const std::size_t begin = static_cast<std::size_t>(c) * kChunk;
    f(static_cast<std::size_t>(c), begin, std::min(n, begin + kChunk));
  }
}

// Sum of the first n partials, in order.
inline double sum(const std::vector<double>& partial, std::size_t n) {
  double s = 0;
  for (std::size_t c = 0; c < n; ++c) s += partial[c];
  return s;
}

// Sum of row(i) over [0, n): per chunk in index order into partial[chunk] (sized for chunk_count(n)),
// then the chunks in order. row may also update row i's data.
template <class Row>
double reduce(int threads, std::size_t n, std::vector<double>& partial, Row&& row) {
  for_chunks(threads, n, [&](std::size_t c, std::size_t begin, std::size_t end) {
    double s = 0;
    for (std::size_t i = begin; i < end; ++i) s += row(i);
    partial[c] = s;
  });
  return sum(partial, chunk_count(n));
}

}  // namespace scalpel::parallel
