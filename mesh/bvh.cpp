#include "mesh/bvh.hpp"

#include <algorithm>
#include <cstdlib>
#include <string>

namespace scalpel {

void AabbTree::clear() {
  nodes_.clear();
  root_ = kNullNode;
  free_ = kNullNode;
  leaf_count_ = 0;
}

std::int32_t AabbTree::allocate() {
  if (free_ == kNullNode) {
    nodes_.emplace_back();
    return static_cast<std::int32_t>(nodes_.size() - 1);
  }
  const std::int32_t id = free_;
  free_ = at(id).parent;
  at(id) = Node{};
  return id;
}

void AabbTree::release(std::int32_t id) {
  Node& n = at(id);
  n.parent = free_;
  n.child1 = n.child2 = kNullNode;
  n.height = -1;
  free_ = id;
}

std::int32_t AabbTree::insert(const Aabb& box, std::uint32_t payload) {
  const std::int32_t leaf = allocate();
  at(leaf).box = box;
  at(leaf).payload = payload;
  ++leaf_count_;
  if (root_ == kNullNode) {
    root_ = leaf;
    return leaf;
  }
  // Descend to the sibling that minimises the added surface area (Box2D's insertion heuristic):
  // stopping here costs the new parent's area, going down costs the enlargement of every ancestor.
  std::int32_t idx = root_;
  while (!at(idx).is_leaf()) {
    const Node& n = at(idx);
    const double area = n.box.half_area();
    const double combined = Aabb::merged(n.box, box).half_area();
    const double cost_here = 2.0 * combined;
    const double inherited = 2.0 * (combined - area);
    auto child_cost = [&](std::int32_t c) {
      const Node& cn = at(c);
      const double merged = Aabb::merged(cn.box, box).half_area();
      return (cn.is_leaf() ? merged : merged - cn.box.half_area()) + inherited;
    };
    const double cost1 = child_cost(n.child1), cost2 = child_cost(n.child2);
    if (cost_here < cost1 && cost_here < cost2) break;
    idx = cost1 <= cost2 ? n.child1 : n.child2;
  }
  const std::int32_t sibling = idx;
  const std::int32_t old_parent = at(sibling).parent;
  const std::int32_t new_parent = allocate();
  {
    Node& p = at(new_parent);
    p.parent = old_parent;
    p.box = Aabb::merged(at(sibling).box, box);
    p.height = at(sibling).height + 1;
    p.child1 = sibling;
    p.child2 = leaf;
  }
  if (old_parent == kNullNode) {
    root_ = new_parent;
  } else if (at(old_parent).child1 == sibling) {
    at(old_parent).child1 = new_parent;
  } else {
    at(old_parent).child2 = new_parent;
  }
  at(sibling).parent = new_parent;
  at(leaf).parent = new_parent;
  fix_upwards(new_parent);
  return leaf;
}

void AabbTree::remove(std::int32_t leaf) {
  --leaf_count_;
  if (leaf == root_) {
    root_ = kNullNode;
    release(leaf);
    return;
  }
  const std::int32_t parent = at(leaf).parent;
  const std::int32_t grand = at(parent).parent;
  const std::int32_t sibling = at(parent).child1 == leaf ? at(parent).child2 : at(parent).child1;
  if (grand == kNullNode) {
    root_ = sibling;
    at(sibling).parent = kNullNode;
  } else {
    if (at(grand).child1 == parent) {
      at(grand).child1 = sibling;
    } else {
      at(grand).child2 = sibling;
    }
    at(sibling).parent = grand;
  }
  release(parent);
  release(leaf);
  if (grand != kNullNode) fix_upwards(grand);
}

void AabbTree::set_leaf_box(std::int32_t leaf, const Aabb& box) {
  at(leaf).box = box;
  for (std::int32_t id = at(leaf).parent; id != kNullNode; id = at(id).parent) {
    const Aabb b = Aabb::merged(at(at(id).child1).box, at(at(id).child2).box);
    if (b == at(id).box) break;
    at(id).box = b;
  }
}

void AabbTree::refit_internal(std::vector<std::int32_t>& order) {
  order.clear();
  if (root_ == kNullNode) return;
  // Pre-order lists every parent before its children; the reverse visits children first.
  order.push_back(root_);
  for (std::size_t i = 0; i < order.size(); ++i) {
    const Node& n = at(order[i]);
    if (!n.is_leaf()) {
      order.push_back(n.child1);
      order.push_back(n.child2);
    }
  }
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    Node& n = at(*it);
    if (!n.is_leaf()) n.box = Aabb::merged(at(n.child1).box, at(n.child2).box);
  }
}

void AabbTree::fix_upwards(std::int32_t id) {
  while (id != kNullNode) {
    id = balance(id);
    Node& n = at(id);
    const Node& c1 = at(n.child1);
    const Node& c2 = at(n.child2);
    n.height = 1 + std::max(c1.height, c2.height);
    n.box = Aabb::merged(c1.box, c2.box);
    id = n.parent;
  }
}

// AVL-like rotation: if one child of `a` is more than one level taller than the other, lift that
// child's taller grandchild. Returns the id of the subtree's new root.
std::int32_t AabbTree::balance(std::int32_t a) {
  if (at(a).is_leaf() || at(a).height < 2) return a;
  const std::int32_t b = at(a).child1, c = at(a).child2;
  const int diff = at(c).height - at(b).height;
  if (diff >= -1 && diff <= 1) return a;
  // `up` is the taller child; it replaces `a`, and `a` becomes its child.
  const bool right = diff > 1;
  const std::int32_t up = right ? c : b;
  const std::int32_t f = at(up).child1, g = at(up).child2;
  const std::int32_t a_parent = at(a).parent;
  at(up).child1 = a;
  at(up).parent = a_parent;
  at(a).parent = up;
  if (a_parent == kNullNode) {
    root_ = up;
  } else if (at(a_parent).child1 == a) {
    at(a_parent).child1 = up;
  } else {
    at(a_parent).child2 = up;
  }
  // The taller grandchild stays under `up`; the shorter one moves under `a` beside `keep`.
  const bool f_taller = at(f).height > at(g).height;
  const std::int32_t stay = f_taller ? f : g;
  const std::int32_t move = f_taller ? g : f;
  at(up).child2 = stay;
  if (right) {
    at(a).child2 = move;
  } else {
    at(a).child1 = move;
  }
  at(move).parent = a;
  at(a).box = Aabb::merged(at(at(a).child1).box, at(at(a).child2).box);
  at(a).height = 1 + std::max(at(at(a).child1).height, at(at(a).child2).height);
  at(up).box = Aabb::merged(at(a).box, at(stay).box);
  at(up).height = 1 + std::max(at(a).height, at(stay).height);
  return up;
}

void AabbTree::build(const std::vector<LeafInput>& leaves, std::vector<std::int32_t>& leaf_ids) {
  clear();
  leaf_ids.assign(leaves.size(), kNullNode);
  if (leaves.empty()) return;
  nodes_.reserve(2 * leaves.size() + leaves.size() / 8);  // room for leaves inserted later
  std::vector<std::int32_t> ids(leaves.size());
  std::vector<Vec3> centres(leaves.size());
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    const std::int32_t id = allocate();
    at(id).box = leaves[i].box;
    at(id).payload = leaves[i].payload;
    leaf_ids[i] = ids[i] = id;
    centres[i] = 0.5 * (leaves[i].box.lo + leaves[i].box.hi);
  }
  leaf_count_ = leaves.size();
  root_ = build_range(ids, 0, ids.size(), centres);
  at(root_).parent = kNullNode;
}

// Top-down median split; `centres` is indexed by leaf node id (leaves are allocated first).
std::int32_t AabbTree::build_range(std::vector<std::int32_t>& ids, std::size_t begin, std::size_t end,
                                   std::vector<Vec3>& centres) {
  if (end - begin == 1) return ids[begin];
  Aabb cb;
  for (std::size_t i = begin; i < end; ++i) cb.extend(centres[static_cast<std::size_t>(ids[i])]);
  int axis = 0;
  const Vec3 ext = cb.hi - cb.lo;
  if (ext.y() > ext[axis]) axis = 1;
  if (ext.z() > ext[axis]) axis = 2;
  const std::size_t mid = begin + (end - begin) / 2;
  auto id_begin = ids.begin() + static_cast<std::ptrdiff_t>(begin);
  std::nth_element(id_begin, ids.begin() + static_cast<std::ptrdiff_t>(mid),
                   ids.begin() + static_cast<std::ptrdiff_t>(end), [&](std::int32_t x, std::int32_t y) {
                     const double cx = centres[static_cast<std::size_t>(x)][axis];
                     const double cy = centres[static_cast<std::size_t>(y)][axis];
                     return cx < cy || (cx == cy && x < y);
                   });
  const std::int32_t left = build_range(ids, begin, mid, centres);
  const std::int32_t right = build_range(ids, mid, end, centres);
  const std::int32_t id = allocate();
  Node& n = at(id);
  n.child1 = left;
  n.child2 = right;
  n.box = Aabb::merged(at(left).box, at(right).box);
  n.height = 1 + std::max(at(left).height, at(right).height);
  at(left).parent = id;
  at(right).parent = id;
  return id;
}

std::string AabbTree::validate() const {
  if (root_ == kNullNode) return leaf_count_ == 0 ? "" : "empty tree with leaves counted";
  if (node(root_).parent != kNullNode) return "root has a parent";
  std::size_t leaves = 0;
  std::vector<std::int32_t> stack{root_};
  while (!stack.empty()) {
    const std::int32_t id = stack.back();
    stack.pop_back();
    const Node& n = node(id);
    if (n.is_leaf()) {
      if (n.height != 0) return "leaf " + std::to_string(id) + " has height " + std::to_string(n.height);
      ++leaves;
      continue;
    }
    const Node& c1 = node(n.child1);
    const Node& c2 = node(n.child2);
    if (c1.parent != id || c2.parent != id) return "broken parent link under node " + std::to_string(id);
    if (n.height != 1 + std::max(c1.height, c2.height)) return "wrong height at node " + std::to_string(id);
    if (std::abs(c1.height - c2.height) > 1) return "unbalanced node " + std::to_string(id);
    if (!(n.box == Aabb::merged(c1.box, c2.box))) return "box is not the union at node " + std::to_string(id);
    stack.push_back(n.child1);
    stack.push_back(n.child2);
  }
  if (leaves != leaf_count_) return "leaf count mismatch";
  return "";
}

}  // namespace scalpel
