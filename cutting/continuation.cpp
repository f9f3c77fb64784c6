// Recursive continuation (paper section 6): where the basic machine cannot go on, a cut's
// sub-tetrahedra become units one level deeper; whether a crossing belongs to a cut already made;
// the seals between the parts of a stroke promoted and not yet promoted.
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

bool CutEngine::near_surface(const Vec3& old_point, const Vec3& old_normal, const Vec3& point,
                             const Vec3& normal, double size, double angle_deg, double distance) const {
  const double on = old_normal.norm(), nn = normal.norm();
  if (on == 0.0 || nn == 0.0) return (point - old_point).norm() <= distance * size;
  const double cos_angle = std::abs(old_normal.dot(normal)) / (on * nn);
  return cos_angle >= std::cos(angle_deg * std::numbers::pi / 180.0) &&
         std::abs(old_normal.dot(point - old_point)) / on <= distance * size;
}

bool CutEngine::same_cut(const Vec3& old_point, const Vec3& old_normal, const Vec3& point, const Vec3& normal,
                         double size, std::uint64_t stroke) const {
  // An earlier stroke's cut is crossed, not continued, unless the blade follows it closely (a
  // re-cut along the same path): the wide tolerances, meant for the blade's own tremble, would
  // take a second incision for the first near the line where the two meet.
  if (stroke != stroke_)
    return near_surface(old_point, old_normal, point, normal, size, options_.earlier_cut_angle_deg,
                        options_.earlier_cut_distance);
  return near_surface(old_point, old_normal, point, normal, size, options_.same_cut_angle_deg,
                      options_.same_cut_distance);
}

// The swept surface's normal at a face: its mid node's last sample, else one of its cut edges'.
Vec3 CutEngine::face_sheet_normal(const Key3& k) const {
  const std::uint32_t mid = cut_nodes_.mid(k);
  if (mid != kInvalidIndex && cut_nodes_[mid].sheet_normal.squaredNorm() > 0)
    return cut_nodes_[mid].sheet_normal;
  for (const auto& [a, b] : {std::pair{k[0], k[1]}, std::pair{k[1], k[2]}, std::pair{k[0], k[2]}}) {
    const std::uint32_t e = cut_nodes_.edge(a, b);
    if (e != kInvalidIndex && cut_nodes_[e].sheet_normal.squaredNorm() > 0) return cut_nodes_[e].sheet_normal;
  }
  return Vec3::Zero();
}

std::map<std::uint32_t, bool> CutEngine::recursive_units(const BladePose& prev, const BladePose& pose) const {
  std::map<std::uint32_t, bool> out;
  const auto& x = units_.mesh().positions();
  auto point_of = [&](const CutNode& n) {
    Vec3 p = Vec3::Zero();
    for (int i = 0; i < (n.kind == CutNode::Kind::Edge ? 2 : 3); ++i)
      p += n.bary[i] * x[n.key[static_cast<size_t>(i)]];
    return p;
  };
  // Whether a new cut at `point` in unit `c` extends the surface already cut there (the blade
  // returning to a cut it left, along it: the basic machine goes on) rather than starting another.
  auto extends = [&](const CutUnit& c, const Vec3& point, const Vec3& normal, double size) {
    return c.any_cut_node([&](std::uint32_t id) {
      const CutNode& n = cut_nodes_[id];
      return n.kind != CutNode::Kind::Entry &&
             same_cut(point_of(n), n.sheet_normal, point, normal, size, n.stroke);
    });
  };
  // Every cut unit around `key`; or, for a new cut there, those whose subdivision is final and that
  // it does not extend.
  auto add_units = [&](const Key3& key, bool only_complete, const Vec3& point = Vec3::Zero(),
                       const Vec3& normal = Vec3::Zero(), double size = 0.0) {
    for (const std::uint32_t t : coarse_tets_around(key)) {
      const CutUnit* c = crack_.find(t);
      if (c == nullptr) continue;
      if (!only_complete || (c->complete && !extends(*c, point, normal, size))) out[t] |= !only_complete;
    }
  };
  const Vec3 blade = pose.tip - pose.back;
  auto face_size = [&](const Key3& k) {
    return std::max({(x[k[0]] - x[k[1]]).norm(), (x[k[1]] - x[k[2]]).norm(), (x[k[0]] - x[k[2]]).norm()});
  };
  // A new cut on a face: a second surface there if the face is cut already, otherwise new only
  // to units whose subdivision is final.
  auto face_event = [&](const Key3& k, const Vec3& point, const Vec3& normal) {
    if (seals_.sealed(k)) return;
    const std::uint32_t mid = cut_nodes_.mid(k);
    if (mid == kInvalidIndex) {
      add_units(k, true, point, normal, face_size(k));
      return;
    }
    const CutNode& m = cut_nodes_[mid];
    if (same_cut(point_of(m), face_sheet_normal(k), point, normal, face_size(k), m.stroke)) return;
    add_units(k, !m.opened);  // an opened face cannot take a second surface at any level
  };

  for (const EdgeCut& e : sweep_result_.edges) {
    if (!e.forward) continue;  // backward crossings cut nothing (Eq. 1)
    const Key3 k = edge_key(e.a, e.b);
    if (seals_.sealed(k) || along_former_cut(e, prev, pose)) continue;
    const std::uint32_t id = cut_nodes_.edge(e.a, e.b);
    if (id == kInvalidIndex) {
      add_units(k, true, e.point, swept_normal(prev, pose, e.s), (x[e.a] - x[e.b]).norm());
      continue;
    }
    const CutNode& n = cut_nodes_[id];
    if (n.registered) continue;  // Fig. 9: the crossing takes the registered node's place
    if (!same_cut(point_of(n), n.sheet_normal, e.point, swept_normal(prev, pose, e.s),
                  (x[e.a] - x[e.b]).norm(), n.stroke))
      add_units(k, false);
  }
  for (const FacePierce& p : sweep_result_.pierces) {
    const Key3 k = sorted_key(p.nodes[0], p.nodes[1], p.nodes[2]);
    if (cut_nodes_.entry(k) != kInvalidIndex) continue;  // the tip's own way back (§5.1)
    const Vec3 dir = (1.0 - p.u) * (prev.tip - prev.back) + p.u * blade;
    face_event(k, p.point, dir.cross(pose.tip - prev.tip));
  }
  for (const FaceCrossing& c : sweep_result_.crossings)
    face_event(sorted_key(c.nodes[0], c.nodes[1], c.nodes[2]), c.point, swept_normal(prev, pose, c.s));
  return out;
}

std::vector<std::uint32_t> CutEngine::cut_component(std::uint32_t t) const {
  std::vector<std::uint32_t> out{t};
  std::set<std::uint32_t> seen{t}, nodes_seen;
  for (std::size_t i = 0; i < out.size(); ++i)
    crack_.at(out[i]).any_cut_node([&](std::uint32_t id) {
      if (nodes_seen.insert(id).second)
        for (const std::uint32_t u : coarse_tets_around(cut_nodes_[id].key))
          if (crack_.contains(u) && seen.insert(u).second) out.push_back(u);
      return false;
    });
  std::sort(out.begin(), out.end());
  return out;
}

// §6: a component of cut units is subdivided completely to the end state of its last valid state
// (its current subdivision, which the blade has left), and its sub-tetrahedra, already live, become
// units one level deeper. Its cut nodes become their corners, the interconnection nodes the next
// level's cuts start from. The live mesh does not change; only the engine's units do.
// Only the part of a component the blade has left is promoted: units it has not touched for
// CutOptions::finished_after_steps, or since place(). Within a stroke that is the cut behind the
// blade, which the stroke reaches again when it curls back or crosses itself; the units around the
// blade keep the basic machine (§5: tremble, reversals). Between the two parts the unit mesh is not
// conforming: the cut nodes they share are pinned (they keep their place and their copies) and the
// faces and edges between them sealed (a crossing there is ignored) until the rest is promoted too.
// A component at the depth bound keeps its one-level subdivision: the fallback, which stays valid
// but cannot follow a second surface exactly.
bool CutEngine::promote(const std::map<std::uint32_t, bool>& units, std::set<std::uint32_t>& refused,
                        CutStepStats& stats) {
  bool any = false;
  auto left_behind = [&](std::uint32_t t) {
    const std::uint64_t touched = units_.last_touch(t);
    return touched + options_.finished_after_steps < step_count_ || touched < stroke_start_;
  };
  // A unit where the cut ends (a cut node in it has not opened): promoted, those nodes could not
  // open any more, and a new cut that starts there (Fig. 12) would stay joined to the old one. The
  // basic machine continues such a unit, unless the new cut crosses the old one there or another
  // unit of its component is promoted.
  auto at_boundary = [&](std::uint32_t t) {
    return crack_.at(t).any_cut_node(
        [&](std::uint32_t id) { return cut_nodes_.opens(id) && !cut_nodes_[id].opened; });
  };
  for (const auto& [seed, crosses] : units) {
    if (refused.count(seed) || !crack_.contains(seed) || (!crosses && at_boundary(seed))) continue;
    const std::vector<std::uint32_t> comp = cut_component(seed);
    std::vector<std::uint32_t> part, rest;
    for (const std::uint32_t t : comp) (left_behind(t) ? part : rest).push_back(t);
    bool too_deep = false;
    for (const std::uint32_t t : part) too_deep |= units_.level(t) >= options_.max_recursion_depth;
    if (!left_behind(seed) || too_deep) {
      refused.insert(comp.begin(), comp.end());
      if (left_behind(seed) && too_deep) ++stats.recursion_fallbacks;
      continue;
    }
    promote_part(part, rest, stats);
    refused.insert(rest.begin(), rest.end());
    any = true;
  }
  return any;
}

// Promotes `part` of a cut component (§6): its sub-tetrahedra become units one level deeper, its
// cut nodes their corners. The cut nodes `rest` (the part still being cut) shares are pinned and the
// faces and edges between them sealed.
void CutEngine::promote_part(const std::vector<std::uint32_t>& part, const std::vector<std::uint32_t>& rest,
                             CutStepStats& stats) {
  // Cut nodes of the promoted part; those the rest shares stay cut nodes there, pinned.
  std::set<std::uint32_t> ids, kept;
  for (const std::uint32_t t : part)
    crack_.at(t).any_cut_node([&](std::uint32_t id) {
      ids.insert(id);
      return false;
    });
  for (const std::uint32_t t : rest)
    crack_.at(t).any_cut_node([&](std::uint32_t id) {
      if (ids.count(id)) {
        kept.insert(id);
        cut_nodes_[id].pinned = true;
      }
      return false;
    });
  for (const std::uint32_t t : part) seal(t, rest);
  // The crack faces stay part of the cut surface.
  crack_.retire(part);
  for (const std::uint32_t t : part) {
    const CutUnit c = crack_.take(t);
    const int region = units_.mesh().region(units_.mesh().tet_handle(t));
    const int level = units_.level(t) + 1;
    sweep_->on_tet_removed(t);
    units_.remove(t);
    for (std::size_t s = 0; s < c.live.size(); ++s) {
      const std::uint32_t child = units_.add(mesh_, c.real[s], c.live[s].index, region, level);
      crack_.set_unit_of(c.live[s].index, child);
      sweep_->on_tet_added(child);
    }
    stats.recursion_depth = std::max<int>(stats.recursion_depth, level);
  }
  // A mid node the blade never crossed takes its face's swept-surface normal from a cut edge
  // while the face's cut data is still there: along_former_cut() tells surfaces apart by it.
  for (const std::uint32_t id : ids) {
    CutNode& n = cut_nodes_[id];
    if (!kept.count(id) && n.kind == CutNode::Kind::Mid && n.sheet_normal.squaredNorm() == 0)
      n.sheet_normal = face_sheet_normal(n.key);
  }
  for (const std::uint32_t id : ids) {
    if (kept.count(id)) continue;
    CutNode& n = cut_nodes_[id];
    for (const NodeId c : n.copies) former_[c.index] = id;
    cut_nodes_.forget(id);
  }
  // Seals whose unit has been promoted now are lifted.
  seals_.lift_released();
  ++stats.recursions;
  if (!rest.empty()) ++stats.stroke_recursions;
  stats.promoted_tets += part.size();
}

// Sculpting (paper section 7.3): a severed piece is deleted. A unit the last cut went through holds
// live elements of both pieces, so the units cannot simply be dropped: the cut components reaching
// into the piece are promoted whole (the blade is out of the tissue, so none is still being cut),
// after which every element of the piece stands for a unit of its own and goes with it. The
// promotion here ignores max_recursion_depth (each deletion may take the units it promotes one
// level further): the bound limits the work a stroke can start, and this is not a stroke.
double CutEngine::remove_piece(std::span<const std::uint32_t> live_tets) {
  if (in_contact_) throw std::logic_error("CutEngine::remove_piece: the blade is in the tissue");
  std::vector<std::uint32_t> tets(live_tets.begin(), live_tets.end());
  std::sort(tets.begin(), tets.end());
  tets.erase(std::unique(tets.begin(), tets.end()), tets.end());
  std::vector<std::uint32_t> nodes;
  for (const std::uint32_t t : tets) {
    if (!mesh_.tet_slot_alive(t)) throw std::logic_error("CutEngine::remove_piece: a removed element");
    for (const std::uint32_t v : mesh_.tet_vertex_indices(t)) nodes.push_back(v);
  }
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  for (const std::uint32_t n : nodes)
    for (const std::uint32_t t : mesh_.node_tets(mesh_.node_handle(n)))
      if (!std::binary_search(tets.begin(), tets.end(), t))
        throw std::logic_error("CutEngine::remove_piece: the elements share a node with the rest");

  changes_.clear();
  CutStepStats stats;
  for (const std::uint32_t t : tets) {
    const std::uint32_t unit = crack_.unit_of(t);
    if (crack_.contains(unit)) promote_part(cut_component(unit), {}, stats);
  }
  double volume = 0.0;
  for (const std::uint32_t t : tets) {
    const std::uint32_t unit = crack_.unit_of(t);
    if (crack_.contains(unit) || units_.live(unit) != t)
      throw std::logic_error("CutEngine::remove_piece: an element is not a unit of its own");
    const TetId live = mesh_.tet_handle(t);
    volume += mesh_.rest_volume(live);
    sweep_->on_tet_removed(unit);
    units_.remove(unit);
    crack_.set_unit_of(t, kInvalidIndex);
    mesh_.remove_tet(live);
    changes_.removed_tets.push_back(t);
  }
  seals_.lift_released();  // a seal a unit of the piece held goes with it
  for (const std::uint32_t n : nodes) {
    mesh_.remove_node(mesh_.node_handle(n));
    units_.remove_node(n);
    former_.erase(n);
    if (n < original_removed_.size()) original_removed_[n] = 1;
  }
  cut_nodes_.on_piece_removed(nodes);
  coarse_volume_ -= volume;
  totals_.recursions += stats.recursions;
  totals_.promoted_tets += stats.promoted_tets;
  totals_.max_recursion_depth = std::max(totals_.max_recursion_depth, stats.recursion_depth);
  return volume;
}

// Seals the faces and edges of unit `t` (about to be promoted) that a unit of `rest` holds whole
// while `t`'s subdivision splits them: those holding cut data. Each of their pieces in `t`'s
// subdivision is sealed with them.
void CutEngine::seal(std::uint32_t t, const std::vector<std::uint32_t>& rest) {
  const CutUnit& c = crack_.at(t);
  const auto& v = units_.mesh().tet_vertex_indices(t);
  auto in = [](const Key3& outer, std::uint32_t slot) {
    return slot == kInvalidIndex || std::find(outer.begin(), outer.end(), slot) != outer.end();
  };
  // Whether abstract node g lies on the face or edge `outer`.
  auto lies_on = [&](GNode g, const Key3& outer) {
    if (!(g & kCutBit)) return in(outer, static_cast<std::uint32_t>(g));
    const Key3& k = cut_nodes_[static_cast<size_t>(g & ~kCutBit)].key;
    return in(outer, k[0]) && in(outer, k[1]) && in(outer, k[2]);
  };
  auto held_by_rest = [&](const Key3& key) {
    for (const std::uint32_t u : coarse_tets_around(key))
      if (std::find(rest.begin(), rest.end(), u) != rest.end()) return true;
    return false;
  };
  auto seal_edges = [&](std::uint32_t a, std::uint32_t b, std::uint32_t d, const Key3& outer) {
    seals_.add(edge_key(a, b), outer);
    seals_.add(edge_key(b, d), outer);
    seals_.add(edge_key(a, d), outer);
  };
  for (int f = 0; f < 4; ++f) {
    const auto fv = face_vertex_indices(units_.mesh(), t, f);
    const Key3 face = sorted_key(fv[0], fv[1], fv[2]);
    const bool cut = cut_nodes_.mid(face) != kInvalidIndex || cut_nodes_.entry(face) != kInvalidIndex ||
                     cut_nodes_.face_has_edge_node(face);
    if (!cut || !held_by_rest(face)) continue;
    seals_.add(face, face);
    seal_edges(face[0], face[1], face[2], face);
    for (std::size_t s = 0; s < c.subs.size(); ++s)
      for (int j = 0; j < 4; ++j) {
        const auto g = face_without(c.subs[s], j);
        if (!lies_on(g[0], face) || !lies_on(g[1], face) || !lies_on(g[2], face)) continue;
        const auto r = face_without(c.real[s], j);
        seals_.add(sorted_key(r[0].index, r[1].index, r[2].index), face);
        seal_edges(r[0].index, r[1].index, r[2].index, face);
      }
  }
  for (const auto& ev : kEdgeVertices) {
    const Key3 edge = edge_key(v[static_cast<size_t>(ev[0])], v[static_cast<size_t>(ev[1])]);
    if (cut_nodes_.edge(edge[0], edge[1]) == kInvalidIndex || !held_by_rest(edge)) continue;
    seals_.add(edge, edge);
    for (std::size_t s = 0; s < c.subs.size(); ++s)
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j)
          if (lies_on(c.subs[s][static_cast<size_t>(i)], edge) &&
              lies_on(c.subs[s][static_cast<size_t>(j)], edge))
            seals_.add(
                edge_key(c.real[s][static_cast<size_t>(i)].index, c.real[s][static_cast<size_t>(j)].index),
                edge);
  }
}

bool CutEngine::along_former_cut(const EdgeCut& e, const BladePose& prev, const BladePose& pose) const {
  // Both ends on one earlier cut surface where it has opened: the edge lies in it (or across a
  // sliver beside it), and a blade running along that surface would shave off slivers. Ends on two
  // surfaces (the edge runs from one earlier cut to another where they meet) do not count: a new
  // cut parallel to one of them and near it must still split the edge.
  const auto a = former_.find(e.a), b = former_.find(e.b);
  if (a == former_.end() || b == former_.end()) return false;
  const CutNode &na = cut_nodes_[a->second], &nb = cut_nodes_[b->second];
  if (!na.opened || !nb.opened) return false;
  const Vec3 &ma = na.sheet_normal, &mb = nb.sheet_normal;
  if (ma.squaredNorm() == 0 || mb.squaredNorm() == 0) return false;  // surface unknown
  const auto& x = units_.mesh().positions();
  const double size = (x[e.a] - x[e.b]).norm();
  const double angle = options_.same_cut_angle_deg, distance = options_.same_cut_distance;
  if (!near_surface(x[e.a], ma, x[e.b], mb, size, angle, distance) ||
      !near_surface(x[e.b], mb, x[e.a], ma, size, angle, distance))
    return false;
  // Along the surface, not across it at a small angle (CutOptions::along_cut_angle_deg).
  const Vec3 normal = swept_normal(prev, pose, e.s);
  const double along = options_.along_cut_angle_deg;
  return near_surface(x[e.a], ma, e.point, normal, size, along, distance) ||
         near_surface(x[e.b], mb, e.point, normal, size, along, distance);
}

}  // namespace scalpel
