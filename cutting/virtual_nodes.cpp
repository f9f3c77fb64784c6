// The virtual nodes (paper section 4.1): the copies of a cut node on either side of the crack.
#include "cutting/virtual_nodes.hpp"

#include <algorithm>
#include <numeric>

#include "cutting/cut_engine_internal.hpp"

namespace scalpel {

using namespace cut_internal;

// Groups the sub-tetrahedra around a cut node by face adjacency that does not cross the crack and
// gives each group a copy of the node. Groups are ordered by the smallest coarse vertex they hold,
// which the cut never changes, so the assignment is deterministic.
void VirtualNodes::regroup(std::uint32_t id, const CutUnits& cut_units, std::vector<std::uint32_t>& changed) {
  const std::uint32_t groups = group_around(id, cut_units);
  vote_copies(id, cut_units);
  choose_copies(id, groups);
  CutNode& n = nodes_[id];
  const auto& items = scratch_.items;
  // Coarse tetrahedra whose sub-tetrahedra changed group must be rebuilt.
  auto& fresh = scratch_.group_of;
  fresh.clear();
  for (std::uint32_t i = 0; i < items.size(); ++i)
    fresh.push_back({items[i].coarse, items[i].sub, scratch_.copy_of[scratch_.item_group[i]]});
  std::sort(fresh.begin(), fresh.end());
  for (const auto& e : fresh)
    if (n.group(e.coarse, e.sub) != e.group) changed.push_back(e.coarse);
  n.group_of.swap(fresh);
  n.opened |= n.copies.size() > 1;
}

// The sub-tetrahedra around cut node `id` (scratch_.items), joined across the faces holding it that
// are not crack faces, into groups numbered by the smallest vertex they hold (scratch_.item_group);
// returns how many.
std::uint32_t VirtualNodes::group_around(std::uint32_t id, const CutUnits& cut_units) {
  const CutNode& n = nodes_[id];
  const GNode g = kCutBit | id;
  auto& items = scratch_.items;
  items.clear();
  auto& around = scratch_.around;
  around.clear();
  for_tets_around(units_, n.key, [&](std::uint32_t t) { around.push_back(t); });
  std::sort(around.begin(), around.end());
  for (const std::uint32_t t : scratch_.around) {
    const auto it = cut_units.find(t);
    if (it == cut_units.end()) continue;
    const auto& subs = it->second.subs;
    for (std::uint32_t s = 0; s < subs.size(); ++s)
      if (contains(subs[s], g)) items.push_back({t, s, &subs[s]});
  }
  auto& parent = scratch_.parent;
  parent.resize(items.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  // Faces holding n that are not crack faces join the sub-tetrahedra on both sides of them.
  auto& faces = scratch_.faces;
  faces.clear();
  for (std::uint32_t i = 0; i < items.size(); ++i) {
    const auto& tet = *items[i].tet;
    for (int f = 0; f < 4; ++f) {
      if (tet[static_cast<size_t>(f)] == g) continue;  // the face opposite n does not hold n
      auto face = face_without(tet, f);
      if (nodes_.is_crack_face(face[0], face[1], face[2])) continue;
      std::sort(face.begin(), face.end());
      faces.push_back({face, i});
    }
  }
  std::sort(faces.begin(), faces.end());
  for (size_t k = 1; k < faces.size(); ++k)
    if (faces[k].first == faces[k - 1].first) parent[find(faces[k].second)] = find(faces[k - 1].second);

  // Order groups by the smallest vertex (coarse corners sort before cut nodes) they contain.
  auto& smallest = scratch_.smallest;
  smallest.assign(items.size(), ~GNode{0});
  for (std::uint32_t i = 0; i < items.size(); ++i) {
    GNode lo = ~GNode{0};
    for (const GNode v : *items[i].tet)
      if (v != g) lo = std::min(lo, v);
    GNode& s = smallest[find(i)];
    s = std::min(s, lo);
  }
  auto& order = scratch_.order;
  order.clear();
  for (std::uint32_t i = 0; i < items.size(); ++i)
    if (find(i) == i) order.emplace_back(smallest[i], i);
  std::sort(order.begin(), order.end());
  auto& group_of_root = scratch_.group_of_root;
  group_of_root.assign(items.size(), 0);
  for (std::uint32_t k = 0; k < order.size(); ++k) group_of_root[order[k].second] = k;

  auto& item_group = scratch_.item_group;
  item_group.resize(items.size());
  for (std::uint32_t i = 0; i < items.size(); ++i) item_group[i] = group_of_root[find(i)];
  return static_cast<std::uint32_t>(order.size());
}

void VirtualNodes::vote_copies(std::uint32_t id, const CutUnits& cut_units) {
  const CutNode& n = nodes_[id];
  const auto& items = scratch_.items;
  // Copies follow their elements: once the crack has opened, the copies of n stand apart, and an
  // element moved to another copy would be torn across the gap. A coarse corner of a sub-tetrahedron
  // votes for the copy that shared a live element of the same coarse tetrahedron with it before this
  // step (the live elements are rebuilt after regrouping); votes are counted per (group, copy),
  // largest counts first.
  auto& votes = scratch_.votes;  // (group, copy, count)
  votes.clear();
  auto& shared = scratch_.shared;  // (node slot, copy) per old live element of one coarse tetrahedron
  std::uint32_t shared_of = kInvalidIndex;
  for (std::uint32_t i = 0; i < items.size(); ++i) {
    if (items[i].coarse != shared_of) {
      shared_of = items[i].coarse;
      shared.clear();
      for (const auto& e : cut_units.at(shared_of).real)
        for (std::uint32_t k = 0; k < n.copies.size(); ++k)
          if (std::find(e.begin(), e.end(), n.copies[k]) != e.end())
            for (const NodeId v : e)
              if (v != n.copies[k]) shared.emplace_back(v.index, k);
    }
    for (const GNode v : *items[i].tet) {
      if (v & kCutBit) continue;
      for (const auto& [node, k] : shared)
        if (node == v) votes.push_back({scratch_.item_group[i], k, 1});
    }
  }
  std::sort(votes.begin(), votes.end());
  std::size_t runs = 0;
  for (std::size_t k = 0; k < votes.size(); ++k)
    if (runs > 0 && votes[runs - 1][0] == votes[k][0] && votes[runs - 1][1] == votes[k][1])
      ++votes[runs - 1][2];
    else
      votes[runs++] = votes[k];
  votes.resize(runs);
  // Largest counts first, ties in (group, copy) order (the runs are unique in it).
  std::sort(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
    return a[2] > b[2] || (a[2] == b[2] && (a[0] < b[0] || (a[0] == b[0] && a[1] < b[1])));
  });
}

// The copy each group uses (scratch_.copy_of). Each group keeps the copy with the most votes; a group
// split off gets a new copy where the copy it voted for stands; a group without votes (all its
// coarse tetrahedra newly cut) takes a copy no group uses or else a new one interpolated from the
// key nodes, where those coarse tetrahedra put n. A pinned node's group with a sealed face keeps the
// copy across it.
void VirtualNodes::choose_copies(std::uint32_t id, std::uint32_t groups) {
  CutNode& n = nodes_[id];
  const GNode g = kCutBit | id;
  const auto& items = scratch_.items;
  const auto& votes = scratch_.votes;
  auto& copy_of = scratch_.copy_of;  // by group
  copy_of.assign(groups, kInvalidIndex);
  auto& taken = scratch_.taken;  // by copy
  taken.assign(n.copies.size(), 0);
  // A pinned node's copies are shared with promoted units across sealed faces: a group with a face
  // there keeps the copy the promoted side has, whatever the votes.
  if (n.pinned && n.copies.size() > 1) {
    // The copy used by the first sealed real face over abstract face `face` (which holds g), if any.
    auto sealed_copy = [&](const std::array<GNode, 3>& face) {
      std::array<std::vector<std::uint32_t>, 3> real;  // candidate real node slots per vertex
      for (std::size_t j = 0; j < 3; ++j) {
        if (!(face[j] & kCutBit)) {
          real[j] = {static_cast<std::uint32_t>(face[j])};
          continue;
        }
        for (const NodeId c : nodes_[static_cast<size_t>(face[j] & ~kCutBit)].copies)
          real[j].push_back(c.index);
      }
      const int at = face[0] == g ? 0 : face[1] == g ? 1 : 2;
      for (const std::uint32_t x : real[0])
        for (const std::uint32_t y : real[1])
          for (const std::uint32_t z : real[2]) {
            if (!seals_.recorded(sorted_key(x, y, z))) continue;
            const std::uint32_t mine = at == 0 ? x : at == 1 ? y : z;
            for (std::uint32_t k = 0; k < n.copies.size(); ++k)
              if (n.copies[k].index == mine) return k;
          }
      return kInvalidIndex;
    };
    for (std::uint32_t i = 0; i < items.size(); ++i) {
      const std::uint32_t group = scratch_.item_group[i];
      const auto& tet = *items[i].tet;
      for (int f = 0; f < 4; ++f) {
        if (tet[static_cast<size_t>(f)] == g || copy_of[group] != kInvalidIndex) continue;
        const std::uint32_t k = sealed_copy(face_without(tet, f));
        if (k == kInvalidIndex) continue;
        copy_of[group] = k;
        taken[k] = 1;
      }
    }
  }
  for (const auto& [group, copy, count] : votes)
    if (copy_of[group] == kInvalidIndex && !taken[copy]) {
      copy_of[group] = copy;
      taken[copy] = 1;
    }
  for (std::uint32_t k = 0; k < groups; ++k) {
    if (copy_of[k] != kInvalidIndex) continue;
    std::uint32_t used = kInvalidIndex, most = 0;
    for (const auto& [group, copy, count] : votes)
      if (group == k && count > most) {
        used = copy;
        most = count;
      }
    if (used == kInvalidIndex) {  // no history: a copy no group uses, if there is one
      const auto free = std::find(taken.begin(), taken.end(), std::uint8_t{0});
      if (free != taken.end()) {
        *free = 1;
        copy_of[k] = static_cast<std::uint32_t>(free - taken.begin());
        continue;
      }
    }
    if (n.pinned) {  // promoted units hold its copies: the crack stays closed here
      copy_of[k] = used != kInvalidIndex ? used : 0;
      continue;
    }
    NodeParents p;
    if (used != kInvalidIndex) {
      p.parents[0] = n.copies[used];
      p.weights[0] = 1.0;
      p.count = 1;
    } else {
      p = key_parents(mesh_, n.key, n.placed_bary);
    }
    copy_of[k] = static_cast<std::uint32_t>(n.copies.size());
    n.copies.push_back(nodes_.add_real_node(p));
  }
}

}  // namespace scalpel
