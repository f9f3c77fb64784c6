#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "mesh/bvh.hpp"

using namespace scalpel;

namespace {

Aabb random_box(std::mt19937& rng, double world, double max_size) {
  std::uniform_real_distribution<double> pos(0.0, world), size(0.0, max_size);
  Aabb b;
  b.lo = Vec3(pos(rng), pos(rng), pos(rng));
  b.hi = b.lo + Vec3(size(rng), size(rng), size(rng));
  return b;
}

std::vector<std::uint32_t> tree_hits(const AabbTree& tree, const Aabb& q) {
  std::vector<std::uint32_t> hits;
  std::vector<std::int32_t> stack;
  tree.query([&](const Aabb& b) { return b.overlaps(q); }, [&](std::uint32_t p) { hits.push_back(p); },
             stack);
  std::sort(hits.begin(), hits.end());
  return hits;
}

std::vector<std::uint32_t> brute_hits(const std::vector<Aabb>& boxes, const std::vector<bool>& present,
                                      const Aabb& q) {
  std::vector<std::uint32_t> hits;
  for (std::uint32_t i = 0; i < boxes.size(); ++i) {
    if (present[i] && boxes[i].overlaps(q)) hits.push_back(i);
  }
  return hits;
}

}  // namespace

TEST_CASE("bulk-built AABB tree is balanced and its queries equal brute force") {
  std::mt19937 rng(12345);
  std::vector<AabbTree::LeafInput> leaves;
  std::vector<Aabb> boxes;
  for (std::uint32_t i = 0; i < 2000; ++i) {
    boxes.push_back(random_box(rng, 10.0, 0.5));
    leaves.push_back({boxes.back(), i});
  }
  AabbTree tree;
  std::vector<std::int32_t> ids;
  tree.build(leaves, ids);
  CHECK(tree.validate().empty());
  CHECK(tree.leaf_count() == 2000);
  CHECK(tree.height() <= 11);  // ceil(log2(2000))
  for (std::size_t i = 0; i < ids.size(); ++i) CHECK(tree.node(ids[i]).payload == i);
  const std::vector<bool> present(boxes.size(), true);
  for (int k = 0; k < 100; ++k) {
    const Aabb q = random_box(rng, 10.0, 2.0);
    CHECK(tree_hits(tree, q) == brute_hits(boxes, present, q));
  }
}

TEST_CASE("AABB tree stays valid and exact under incremental inserts, removals and box updates") {
  std::mt19937 rng(777);
  AabbTree tree;
  std::vector<Aabb> boxes;
  std::vector<bool> present;
  std::vector<std::int32_t> leaf;
  std::uniform_real_distribution<double> coin(0.0, 1.0);
  for (int step = 0; step < 3000; ++step) {
    const double c = coin(rng);
    std::vector<std::uint32_t> live;
    for (std::uint32_t i = 0; i < present.size(); ++i)
      if (present[i]) live.push_back(i);
    if (c < 0.55 || live.size() < 10) {
      boxes.push_back(random_box(rng, 10.0, 0.5));
      present.push_back(true);
      leaf.push_back(tree.insert(boxes.back(), static_cast<std::uint32_t>(boxes.size() - 1)));
    } else if (c < 0.85) {
      const std::uint32_t i = live[std::uniform_int_distribution<std::size_t>(0, live.size() - 1)(rng)];
      tree.remove(leaf[i]);
      present[i] = false;
    } else {
      const std::uint32_t i = live[std::uniform_int_distribution<std::size_t>(0, live.size() - 1)(rng)];
      boxes[i] = random_box(rng, 10.0, 0.5);
      tree.set_leaf_box(leaf[i], boxes[i]);
    }
    if (step % 97 == 0) {
      REQUIRE(tree.validate().empty());
      const Aabb q = random_box(rng, 10.0, 3.0);
      CHECK(tree_hits(tree, q) == brute_hits(boxes, present, q));
    }
  }
  CHECK(tree.validate().empty());
  const std::size_t n = tree.leaf_count();
  // AVL-balanced: height <= 1.44 log2(n + 2).
  CHECK(tree.height() <= static_cast<int>(1.45 * std::log2(static_cast<double>(n) + 2.0)) + 1);
}

TEST_CASE("removing every leaf empties the tree and node slots are reused") {
  AabbTree tree;
  std::mt19937 rng(5);
  std::vector<std::int32_t> ids;
  for (std::uint32_t i = 0; i < 64; ++i) ids.push_back(tree.insert(random_box(rng, 1.0, 0.1), i));
  for (std::int32_t id : ids) tree.remove(id);
  CHECK(tree.leaf_count() == 0);
  CHECK(tree.root() == AabbTree::kNullNode);
  CHECK(tree.validate().empty());
  const std::int32_t again = tree.insert(random_box(rng, 1.0, 0.1), 99);
  CHECK(again < 127);  // taken from the free list
  CHECK(tree.validate().empty());
}
