#include "fem/block_matrix.hpp"

#include "fem/parallel.hpp"

namespace scalpel {

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
