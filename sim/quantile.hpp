// Order statistics of timing samples, one convention for the report, the overlay and the benchmarks.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace scalpel {

// The q-quantile of v (q in [0, 1]) as the report gives it: the element of rank floor(q (n - 1))
// in ascending order; 0 for no values.
[[nodiscard]] inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto at = v.begin() + static_cast<std::ptrdiff_t>(std::floor(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), at, v.end());
  return *at;
}

}  // namespace scalpel
