// The crack (paper section 4.1): which faces of the subdivision are cut surface, the copies of a
// cut node on either side once the surface surrounds it (the virtual nodes), the live elements
// rebuilt from them, and the cut surface they bound.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <set>
#include <stdexcept>

#include "cutting/cut_engine_internal.hpp"
#include "mesh/closest_point.hpp"
#include "mesh/validate.hpp"

namespace scalpel {

using namespace cut_internal;

// A sub-tetrahedron face on the cut surface: three cut nodes, none crossed only by the blunt side.
// Faces with an entry node are the strip between the tip's path and the cut above it: without them
// the crack would end at the mid nodes half a face above the tip (§4.1, the cut surface reaches the
// tool). Entry nodes themselves never open (the surface ends there), and such a face must lie on one
// stroke's surface: an entry node beside a node of an earlier cut joins two surfaces that meet there
// only, and would free a chip neither encloses.
bool CutEngine::is_crack_face(GNode a, GNode b, GNode c) const {
  const CutNode* entry = nullptr;
  for (const GNode g : {a, b, c}) {
    if (!(g & kCutBit)) return false;
    const CutNode& n = cut_nodes_[static_cast<std::uint32_t>(g & ~kCutBit)];
    if (n.registered) return false;
    if (n.kind == CutNode::Kind::Entry) entry = &n;
  }
  if (entry == nullptr) return true;
  for (const GNode g : {a, b, c})
    if (cut_nodes_[static_cast<std::uint32_t>(g & ~kCutBit)].stroke != entry->stroke) return false;
  return true;
}

// A unit whose cut is final: in an end state (§4.4, the blade has left it) with every cut node that
// opens opened. A unit where the cut ends inside (a node still closed) is the cut's open end, which
// a later stroke continues (Fig. 12).
bool CutEngine::into_final(const std::array<std::uint32_t, 3>& face) const {
  for (const std::uint32_t t : coarse_tets_around(face)) {
    const auto it = cut_tets_.find(t);
    if (it != cut_tets_.end() && it->second.complete &&
        !it->second.any_cut_node([&](std::uint32_t id) { return opens(id) && !cut_nodes_[id].opened; }))
      return true;
  }
  return false;
}

// Entry nodes lie on the tip's path, where the cut surface ends, and registered edge nodes were
// crossed only by the blunt side: neither ever separates.
bool CutEngine::opens(std::uint32_t id) const {
  const CutNode& n = cut_nodes_[id];
  return n.kind != CutNode::Kind::Entry && !n.registered;
}

std::vector<std::uint32_t> CutEngine::coarse_tets_around(const std::array<std::uint32_t, 3>& key) const {
  std::vector<std::uint32_t> out;
  coarse_tets_around(key, out);
  return out;
}

void CutEngine::coarse_tets_around(const std::array<std::uint32_t, 3>& key,
                                   std::vector<std::uint32_t>& out) const {
  out.clear();
  for_coarse_tets_around(key, [&](std::uint32_t t) { out.push_back(t); });
  std::sort(out.begin(), out.end());
}

std::vector<std::array<std::uint32_t, 3>> CutEngine::faces_around_edge(
    const std::array<std::uint32_t, 3>& key) const {
  std::vector<Key3> out;
  for (const std::uint32_t t : coarse_tets_around(key))
    for (const std::uint32_t third : coarse_.tet_vertex_indices(t))
      if (third != key[0] && third != key[1]) out.push_back(sorted_key(key[0], key[1], third));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// Groups the sub-tetrahedra around a cut node by face adjacency that does not cross the crack and
// gives each group a copy of the node. Groups are ordered by the smallest coarse vertex they hold,
// which the cut never changes, so the assignment is deterministic.
void CutEngine::regroup(std::uint32_t id, std::vector<std::uint32_t>& changed) {
  const std::uint32_t groups = group_around(id);
  vote_copies(id);
  choose_copies(id, groups);
  CutNode& n = cut_nodes_[id];
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
std::uint32_t CutEngine::group_around(std::uint32_t id) {
  const CutNode& n = cut_nodes_[id];
  const GNode g = kCutBit | id;
  auto& items = scratch_.items;
  items.clear();
  coarse_tets_around(n.key, scratch_.around);
  for (const std::uint32_t t : scratch_.around) {
    const auto it = cut_tets_.find(t);
    if (it == cut_tets_.end()) continue;
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
      if (is_crack_face(face[0], face[1], face[2])) continue;
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

void CutEngine::vote_copies(std::uint32_t id) {
  const CutNode& n = cut_nodes_[id];
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
      for (const auto& e : cut_tets_.at(shared_of).real)
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
void CutEngine::choose_copies(std::uint32_t id, std::uint32_t groups) {
  CutNode& n = cut_nodes_[id];
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
        for (const NodeId c : cut_nodes_[static_cast<size_t>(face[j] & ~kCutBit)].copies)
          real[j].push_back(c.index);
      }
      const int at = face[0] == g ? 0 : face[1] == g ? 1 : 2;
      for (const std::uint32_t x : real[0])
        for (const std::uint32_t y : real[1])
          for (const std::uint32_t z : real[2]) {
            if (!has_seal(sorted_key(x, y, z))) continue;
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
    n.copies.push_back(add_node(p));
  }
}

std::uint32_t CutEngine::CutNode::group(std::uint32_t coarse, std::uint32_t sub) const {
  const auto it = std::lower_bound(group_of.begin(), group_of.end(), GroupEntry{coarse, sub, 0});
  return it != group_of.end() && it->coarse == coarse && it->sub == sub ? it->group : 0;
}

// Brings the live sub-tetrahedra of one coarse tetrahedron in line with its subdivision and the
// node groups: elements whose real nodes are unchanged stay (minimal removals, §4.3).
void CutEngine::rebuild_live(std::uint32_t t, CutStepStats& stats) {
  CoarseTet& c = cut_tets_.at(t);
  // Built in scratch, then swapped with the unit's: the unit's old storage is the next scratch.
  auto& real = rebuild_scratch_.real;
  real.resize(c.subs.size());
  for (std::uint32_t s = 0; s < c.subs.size(); ++s)
    for (int i = 0; i < 4; ++i) {
      const GNode g = c.subs[s][static_cast<size_t>(i)];
      if (!(g & kCutBit)) {
        real[s][static_cast<size_t>(i)] = mesh_.node_handle(static_cast<std::uint32_t>(g));
      } else {
        const CutNode& n = cut_nodes_[static_cast<size_t>(g & ~kCutBit)];
        real[s][static_cast<size_t>(i)] = n.copies[n.group(t, s)];
      }
    }
  // Match old live elements to new ones by their real nodes (each old one used once).
  auto& old_by_nodes = rebuild_scratch_.old_by_nodes;
  old_by_nodes.resize(c.real.size());
  for (std::size_t i = 0; i < c.real.size(); ++i) old_by_nodes[i] = {c.real[i], i};
  std::sort(old_by_nodes.begin(), old_by_nodes.end());
  auto& live = rebuild_scratch_.live;
  live.assign(real.size(), TetId{});
  auto& kept = rebuild_scratch_.kept;
  kept.assign(c.live.size(), 0);
  auto& to_add = rebuild_scratch_.to_add;
  to_add.clear();
  for (std::size_t s = 0; s < real.size(); ++s) {
    auto it =
        std::lower_bound(old_by_nodes.begin(), old_by_nodes.end(), std::make_pair(real[s], std::size_t{0}));
    while (it != old_by_nodes.end() && it->first == real[s] && kept[it->second]) ++it;
    if (it != old_by_nodes.end() && it->first == real[s]) {
      kept[it->second] = 1;
      live[s] = c.live[it->second];
    } else {
      to_add.push_back(s);
    }
  }
  const std::uint32_t parent = c.live.empty() ? t : mesh_.parent(c.live[0]);
  const int region = coarse_.region(coarse_.tet_handle(t));
  for (std::size_t i = 0; i < c.live.size(); ++i) {
    if (kept[i]) continue;
    changes_.removed_tets.push_back(c.live[i].index);
    for (const NodeId n : c.real[i]) changes_.touched_nodes.push_back(n.index);
    mesh_.remove_tet(c.live[i]);
    ++stats.tets_removed;
  }
  for (const std::size_t s : to_add) {
    live[s] = mesh_.add_tet(real[s], region);
    changes_.added_tets.push_back(live[s]);
    for (const NodeId n : real[s]) changes_.touched_nodes.push_back(n.index);
    mesh_.set_parent(live[s], parent);
    if (live_to_coarse_.size() <= live[s].index) live_to_coarse_.resize(live[s].index + 1, kInvalidIndex);
    live_to_coarse_[live[s].index] = t;
    ++stats.tets_created;
  }
  c.real.swap(real);
  c.live.swap(live);
}

// Each crack face once, at the real nodes of the sub-tetrahedron that owns it: one side's copies,
// so the area does not grow as the crack opens.
double CutEngine::cut_surface_area() const {
  double area = 0.0;
  for (const auto& f : cut_surface_faces())
    area += triangle_area(mesh_.position(f[0]), mesh_.position(f[1]), mesh_.position(f[2]));
  return area;
}

std::vector<std::array<NodeId, 3>> CutEngine::cut_surface_faces() const {
  std::vector<std::uint32_t> keys;
  for (const auto& [k, c] : cut_tets_) keys.push_back(k);
  std::sort(keys.begin(), keys.end());
  std::vector<std::array<NodeId, 3>> out = retired_crack_faces_;
  for (const CrackFace& f : crack_faces(keys))
    out.push_back(face_without(cut_tets_.at(f.unit).real[f.sub], f.face));
  return out;
}

std::vector<CutEngine::CrackFace> CutEngine::crack_faces(const std::vector<std::uint32_t>& units) const {
  std::vector<CrackFace> out;
  std::set<std::array<GNode, 3>> seen;
  for (const std::uint32_t t : units) {
    const auto& subs = cut_tets_.at(t).subs;
    for (std::uint32_t s = 0; s < subs.size(); ++s)
      for (int f = 0; f < 4; ++f) {
        auto face = face_without(subs[s], f);
        if (!is_crack_face(face[0], face[1], face[2])) continue;
        std::sort(face.begin(), face.end());
        if (seen.insert(face).second) out.push_back({t, s, f});
      }
  }
  return out;
}

std::vector<CutEngine::CutNodeCopies> CutEngine::cut_node_copies() const {
  std::vector<CutNodeCopies> out;
  out.reserve(cut_nodes_.size());
  for (const CutNode& n : cut_nodes_) {
    if (n.copies.empty()) continue;  // undone by tremble (§5.1)
    CutNodeCopies c;
    c.rest = mesh_.rest(n.copies[0]);
    for (const NodeId x : n.copies)
      if (!mesh_.node_tets(x).empty()) c.copies.push_back(x);
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace scalpel
