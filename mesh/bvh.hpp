// Dynamic bounding-volume hierarchy of axis-aligned boxes (docs/state_machine.md: the collision step costs
// O(elements near the blade), never O(mesh)).
//
// A binary tree whose leaves hold "fat" boxes: the tight box of an element enlarged by a margin, so
// that small motions of the element need no change to the tree (the idea of Box2D's b2DynamicTree,
// written here for 3D). Leaves are inserted and removed one at a time (the cutter replaces a few
// tetrahedra every step) with the surface-area descent heuristic and AVL-like rotations that keep the
// height O(log n); a bulk build (median split) makes the initial tree. Internal boxes are always the
// exact union of their children's boxes.
//
// Node layout: one array of nodes with a free list; node ids are int32 indices, kNullNode = -1.
#pragma once

#include <cstdint>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

struct Aabb {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());

  void extend(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void extend(const Aabb& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  [[nodiscard]] bool contains(const Aabb& b) const {
    return (lo.array() <= b.lo.array()).all() && (b.hi.array() <= hi.array()).all();
  }
  [[nodiscard]] bool overlaps(const Aabb& b) const {
    return (lo.array() <= b.hi.array()).all() && (b.lo.array() <= hi.array()).all();
  }
  // Half the surface area: the cost measure of the insertion heuristic.
  [[nodiscard]] double half_area() const {
    const Vec3 d = hi - lo;
    return d.x() * d.y() + d.y() * d.z() + d.z() * d.x();
  }
  [[nodiscard]] static Aabb merged(const Aabb& a, const Aabb& b) {
    Aabb r = a;
    r.extend(b);
    return r;
  }
  friend bool operator==(const Aabb& a, const Aabb& b) { return a.lo == b.lo && a.hi == b.hi; }
};

class AabbTree {
 public:
  static constexpr std::int32_t kNullNode = -1;

  struct Node {
    Aabb box;
    std::int32_t parent = kNullNode;  // next free node while on the free list
    std::int32_t child1 = kNullNode;  // kNullNode for a leaf
    std::int32_t child2 = kNullNode;
    std::int32_t height = 0;  // leaf 0; -1 while free
    std::uint32_t payload = 0;
    [[nodiscard]] bool is_leaf() const { return child1 == kNullNode; }
  };

  struct LeafInput {
    Aabb box;
    std::uint32_t payload;
  };

  // Replaces the tree by a balanced one over `leaves` (median split along the widest axis of the
  // box centres). Writes each leaf's node id to leaf_ids[i] (same order as `leaves`).
  void build(const std::vector<LeafInput>& leaves, std::vector<std::int32_t>& leaf_ids);
  void clear();

  // Inserts a leaf with the given (already fat) box; returns its node id.
  std::int32_t insert(const Aabb& box, std::uint32_t payload);
  void remove(std::int32_t leaf);
  // Sets a leaf's box and recomputes its ancestors (exact unions), stopping as soon as an
  // ancestor's box does not change. Keeps the tree's shape.
  void set_leaf_box(std::int32_t leaf, const Aabb& box);
  // Sets a leaf's box without touching its ancestors; call refit_internal() before the next query.
  void set_leaf_box_only(std::int32_t leaf, const Aabb& box) { at(leaf).box = box; }
  // Recomputes every internal box from its children, bottom-up: O(nodes). `order` is scratch.
  void refit_internal(std::vector<std::int32_t>& order);

  // Visits every leaf whose box passes `overlap(const Aabb&)` on it and on all its ancestors;
  // `visit(payload)` is called in a deterministic order. `stack` is scratch (capacity reused).
  template <class Overlap, class Visit>
  void query(Overlap&& overlap, Visit&& visit, std::vector<std::int32_t>& stack) const {
    if (root_ == kNullNode) return;
    stack.clear();
    stack.push_back(root_);
    while (!stack.empty()) {
      const std::int32_t id = stack.back();
      stack.pop_back();
      const Node& n = nodes_[static_cast<std::size_t>(id)];
      if (!overlap(n.box)) continue;
      if (n.is_leaf()) {
        visit(n.payload);
      } else {
        stack.push_back(n.child2);
        stack.push_back(n.child1);
      }
    }
  }

  [[nodiscard]] std::int32_t root() const { return root_; }
  [[nodiscard]] const Node& node(std::int32_t id) const { return nodes_[static_cast<std::size_t>(id)]; }
  [[nodiscard]] std::size_t leaf_count() const { return leaf_count_; }
  [[nodiscard]] int height() const { return root_ == kNullNode ? 0 : node(root_).height; }
  // Checks the structure: parent links, heights, exact unions, balance within 1, leaf count.
  // Returns an empty string when valid, else what is wrong.
  [[nodiscard]] std::string validate() const;

 private:
  std::int32_t allocate();
  void release(std::int32_t id);
  std::int32_t balance(std::int32_t a);
  void fix_upwards(std::int32_t id);
  std::int32_t build_range(std::vector<std::int32_t>& ids, std::size_t begin, std::size_t end,
                           std::vector<Vec3>& centres);
  Node& at(std::int32_t id) { return nodes_[static_cast<std::size_t>(id)]; }

  std::vector<Node> nodes_;
  std::int32_t root_ = kNullNode;
  std::int32_t free_ = kNullNode;
  std::size_t leaf_count_ = 0;
};

}  // namespace scalpel
