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

// A unit whose cut is final: in an end state (§4.4, the blade has left it) with every cut node that
// opens opened. A unit where the cut ends inside (a node still closed) is the cut's open end, which
// a later stroke continues (Fig. 12).
bool CutEngine::into_final(const std::array<std::uint32_t, 3>& face) const {
  for (const std::uint32_t t : coarse_tets_around(face)) {
    const auto it = cut_tets_.find(t);
    if (it != cut_tets_.end() && it->second.complete && !it->second.any_cut_node([&](std::uint32_t id) {
          return cut_nodes_.opens(id) && !cut_nodes_[id].opened;
        }))
      return true;
  }
  return false;
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

void CutEngine::rebuild_live(std::uint32_t t, CutStepStats& stats) {
  CutUnit& c = cut_tets_.at(t);
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
        if (!cut_nodes_.is_crack_face(face[0], face[1], face[2])) continue;
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
