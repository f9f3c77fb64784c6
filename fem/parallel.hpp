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

}  // namespace scalpel::parallel
