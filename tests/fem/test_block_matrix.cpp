// Block rows stored in row order (fem/block_matrix.hpp): rows set, grown, moved and packed again keep
// their columns and blocks, a copy is a matrix of its own, and products are those of the rows.
#include <doctest/doctest.h>

#include <algorithm>
#include <map>
#include <random>
#include <vector>

#include "fem/block_matrix.hpp"
#include "fem/parallel.hpp"

using namespace scalpel;

namespace {

// The rows as plain maps: what BlockRows must hold.
using Reference = std::vector<std::map<std::uint32_t, Mat3>>;

void check_holds(const BlockRows& a, const Reference& ref) {
  REQUIRE(a.size() == ref.size());
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const BlockRow& row = a[i];
    REQUIRE(row.cols.size() == ref[i].size());
    REQUIRE(row.blocks.size() == ref[i].size());
    std::size_t k = 0;
    for (const auto& [col, block] : ref[i]) {
      CHECK(row.cols[k] == col);
      CHECK(row.blocks[k] == block);
      if (col == i) CHECK(row.diag == k);
      ++k;
    }
  }
}

// Row i: i and up to `extra` other columns, at random; blocks random.
void set_random(BlockRows& a, Reference& ref, std::uint32_t i, std::size_t extra, std::mt19937& rng) {
  std::uniform_int_distribution<std::uint32_t> col(0, static_cast<std::uint32_t>(a.size() - 1));
  std::vector<std::uint32_t> cols{i};
  for (std::size_t k = 0; k < extra; ++k) cols.push_back(col(rng));
  std::sort(cols.begin(), cols.end());
  cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
  a.set(i, cols);
  ref[i].clear();
  std::normal_distribution<double> n;
  for (std::size_t k = 0; k < cols.size(); ++k) {
    CHECK(a[i].blocks[k] == Mat3::Zero());
    const Mat3 b = Mat3::NullaryExpr([&] { return n(rng); });
    a.blocks(i)[k] = b;
    ref[i][cols[k]] = b;
  }
}

}  // namespace

TEST_CASE("block rows: rows set, grown past their room and packed again keep their columns and blocks") {
  std::mt19937 rng(11);
  BlockRows a;
  a.grow(300);
  Reference ref(300);
  for (std::uint32_t i = 0; i < 300; ++i) set_random(a, ref, i, 12, rng);
  check_holds(a, ref);
  // Row order: each row starts where the one before it (and its room) ends.
  for (std::uint32_t i = 1; i < 300; ++i)
    CHECK(a[i].blocks.data() == a[i - 1].blocks.data() + a[i - 1].blocks.size() + BlockRows::kSlack);
  const std::size_t packed = a.stored();

  // Rows that shrink or grow within their room stay where they are.
  const Mat3* before = a[7].blocks.data();
  set_random(a, ref, 7, 3, rng);
  CHECK(a[7].blocks.data() == before);
  CHECK(a.stored() == packed);

  // Rows that outgrow their room move to the end; once more than an eighth of the storage is left
  // behind, every row is placed again in order.
  bool moved = false, repacked = false;
  for (std::uint32_t i = 0; i < 300; i += 3) {
    const std::size_t stored = a.stored();
    set_random(a, ref, i, 40, rng);
    moved = moved || a.stored() > stored;
    repacked = repacked || a.stored() < stored;
    check_holds(a, ref);
  }
  CHECK(moved);
  CHECK(repacked);
  // Rows are added, some emptied (a node removed).
  a.grow(320);
  ref.resize(320);
  for (std::uint32_t i = 300; i < 320; ++i) set_random(a, ref, i, 20, rng);
  for (std::uint32_t i = 0; i < 320; i += 17) {
    a.set(i, {});
    ref[i].clear();
  }
  check_holds(a, ref);

  // A copy holds the same rows in storage of its own.
  BlockRows copy = a;
  check_holds(copy, ref);
  CHECK(copy[5].blocks.data() != a[5].blocks.data());
  Reference changed = ref;
  set_random(copy, changed, 5, 60, rng);
  check_holds(a, ref);
  check_holds(copy, changed);
  a = copy;
  check_holds(a, changed);
  CHECK(a[5].blocks.data() != copy[5].blocks.data());

  // The product is that of the rows.
  std::vector<Vec3> x(320), y(320);
  std::normal_distribution<double> n;
  for (Vec3& v : x) v = Vec3(n(rng), n(rng), n(rng));
  std::vector<std::uint8_t> active(320, 1);
  std::vector<double> partial(parallel::chunk_count(320));
  parallel::Team team(2);
  multiply(a, active, x, y, partial, team);
  for (std::size_t i = 0; i < 320; ++i) {
    Vec3 s = Vec3::Zero();
    for (const auto& [col, block] : changed[i]) s.noalias() += block * x[col];
    CHECK(y[i] == s);
  }
}
