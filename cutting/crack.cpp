// The crack (paper section 4.1): the cut units' live elements, rebuilt from their subdivisions at
// the copies of their cut nodes, and the cut surface they bound.
#include "cutting/crack.hpp"

#include <algorithm>
#include <map>
#include <numeric>
#include <set>

#include "cutting/cut_engine_internal.hpp"

namespace scalpel {

using namespace cut_internal;

Crack::Crack(TetMesh& mesh, const TetMesh& units, const CutNodes& nodes, CutChanges& changes)
    : mesh_(mesh), units_(units), nodes_(nodes), changes_(changes) {
  unit_of_.resize(mesh.tet_capacity());
  std::iota(unit_of_.begin(), unit_of_.end(), 0u);
  unit_of_.reserve(mesh.tet_capacity() + mesh.tet_capacity() / 8);
}

const CutUnit* Crack::find(std::uint32_t unit) const {
  const auto it = cut_.find(unit);
  return it == cut_.end() ? nullptr : &it->second;
}

CutUnit* Crack::find(std::uint32_t unit) {
  const auto it = cut_.find(unit);
  return it == cut_.end() ? nullptr : &it->second;
}

CutUnit& Crack::start(std::uint32_t unit, TetId live) {
  CutUnit& c = cut_[unit];
  c.live = {live};
  c.real = {mesh_.tet_nodes(live)};
  return c;
}

void Crack::retire(const std::vector<std::uint32_t>& units) {
  // Each crack face once, from the first sub-tetrahedron holding it; the other lip from the second.
  std::map<std::array<GNode, 3>, std::size_t> index;
  for (const std::uint32_t t : units) {
    const CutUnit& c = cut_.at(t);
    for (std::uint32_t s = 0; s < c.subs.size(); ++s)
      for (int f = 0; f < 4; ++f) {
        auto face = face_without(c.subs[s], f);
        if (!nodes_.is_crack_face(face[0], face[1], face[2])) continue;
        std::sort(face.begin(), face.end());
        const std::array<NodeId, 3> real = face_without(c.real[s], f);
        const auto [it, first] = index.try_emplace(face, retired_faces_.size());
        if (first)
          retired_faces_.push_back({real, real});
        else
          retired_faces_[it->second][1] = real;
      }
  }
}

CutUnit Crack::take(std::uint32_t unit) {
  CutUnit c = std::move(cut_.at(unit));
  cut_.erase(unit);
  return c;
}

std::uint32_t Crack::unit_of(std::uint32_t live_slot) const {
  return live_slot < unit_of_.size() ? unit_of_[live_slot] : kInvalidIndex;
}

void Crack::set_unit_of(std::uint32_t live_slot, std::uint32_t unit) {
  if (unit_of_.size() <= live_slot) unit_of_.resize(live_slot + 1, kInvalidIndex);
  unit_of_[live_slot] = unit;
}

Crack::Rebuilt Crack::rebuild(std::uint32_t t) {
  Rebuilt out;
  CutUnit& c = cut_.at(t);
  // Built in scratch, then swapped with the unit's: the unit's old storage is the next scratch.
  auto& real = scratch_.real;
  real.resize(c.subs.size());
  for (std::uint32_t s = 0; s < c.subs.size(); ++s)
    for (int i = 0; i < 4; ++i) {
      const GNode g = c.subs[s][static_cast<size_t>(i)];
      if (!(g & kCutBit)) {
        real[s][static_cast<size_t>(i)] = mesh_.node_handle(static_cast<std::uint32_t>(g));
      } else {
        const CutNode& n = nodes_[static_cast<size_t>(g & ~kCutBit)];
        real[s][static_cast<size_t>(i)] = n.copies[n.group(t, s)];
      }
    }
  // Match old live elements to new ones by their real nodes (each old one used once).
  auto& old_by_nodes = scratch_.old_by_nodes;
  old_by_nodes.resize(c.real.size());
  for (std::size_t i = 0; i < c.real.size(); ++i) old_by_nodes[i] = {c.real[i], i};
  std::sort(old_by_nodes.begin(), old_by_nodes.end());
  auto& live = scratch_.live;
  live.assign(real.size(), TetId{});
  auto& kept = scratch_.kept;
  kept.assign(c.live.size(), 0);
  auto& to_add = scratch_.to_add;
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
  const int region = units_.region(units_.tet_handle(t));
  for (std::size_t i = 0; i < c.live.size(); ++i) {
    if (kept[i]) continue;
    changes_.removed_tets.push_back(c.live[i].index);
    for (const NodeId n : c.real[i]) changes_.touched_nodes.push_back(n.index);
    mesh_.remove_tet(c.live[i]);
    ++out.removed;
  }
  for (const std::size_t s : to_add) {
    live[s] = mesh_.add_tet(real[s], region);
    changes_.added_tets.push_back(live[s]);
    for (const NodeId n : real[s]) changes_.touched_nodes.push_back(n.index);
    mesh_.set_parent(live[s], parent);
    set_unit_of(live[s].index, t);
    ++out.created;
  }
  c.real.swap(real);
  c.live.swap(live);
  return out;
}

std::vector<std::array<NodeId, 3>> Crack::cut_surface_faces() const {
  std::vector<std::uint32_t> keys;
  for (const auto& [k, c] : cut_) keys.push_back(k);
  std::sort(keys.begin(), keys.end());
  std::vector<std::array<NodeId, 3>> out;
  auto alive = [&](const std::array<NodeId, 3>& f) {
    return mesh_.alive(f[0]) && mesh_.alive(f[1]) && mesh_.alive(f[2]);
  };
  for (const auto& lips : retired_faces_)
    if (alive(lips[0]))
      out.push_back(lips[0]);
    else if (alive(lips[1]))
      out.push_back(lips[1]);
  for (const CrackFace& f : crack_faces(keys))
    out.push_back(face_without(cut_.at(f.unit).real[f.sub], f.face));
  return out;
}

std::vector<Crack::CrackFace> Crack::crack_faces(const std::vector<std::uint32_t>& units) const {
  std::vector<CrackFace> out;
  std::set<std::array<GNode, 3>> seen;
  for (const std::uint32_t t : units) {
    const auto& subs = cut_.at(t).subs;
    for (std::uint32_t s = 0; s < subs.size(); ++s)
      for (int f = 0; f < 4; ++f) {
        auto face = face_without(subs[s], f);
        if (!nodes_.is_crack_face(face[0], face[1], face[2])) continue;
        std::sort(face.begin(), face.end());
        if (seen.insert(face).second) out.push_back({t, s, f});
      }
  }
  return out;
}

}  // namespace scalpel
