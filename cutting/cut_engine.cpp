// The cut engine (paper section 3): one step of the blade, from the sweep's events through the
// cut nodes, the subdivision and the crack to the live mesh; point location for the tool. The
// sections it calls live beside it, each owning its data: the Units, the cut-node store
// (CutNodes), the Subdivision of a unit, the Crack with the cut units' live elements and its
// VirtualNodes, and the Seals of the continuation (whose promotion is continuation.cpp).
#include "cutting/cut_engine.hpp"

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

void CutTotals::add(const CutStepStats& s) {
  ++steps;
  edges_cut += s.edges_cut;
  backward_crossings += s.backward_crossings;
  replaced_crossings += s.replaced_crossings;
  recrossed_edges += s.recrossed_edges;
  recrossed_faces += s.recrossed_faces;
  face_pierces += s.face_pierces;
  undone_faces += s.undone_faces;
  recursions += s.recursions;
  promoted_tets += s.promoted_tets;
  recursion_fallbacks += s.recursion_fallbacks;
  stroke_recursions += s.stroke_recursions;
  sealed_events += s.sealed_events;
  final_pierces += s.final_pierces;
  max_recursion_depth = std::max(max_recursion_depth, s.recursion_depth);
  tets_created += s.tets_created;
  tets_removed += s.tets_removed;
  nodes_created += s.nodes_created;
}

CutEngine::CutEngine(TetMesh& mesh, CutOptions options)
    : mesh_(mesh),
      options_(options),
      table_(options.table ? *options.table : default_cut_table()),
      coarse_volume_(mesh.total_rest_volume()),
      units_(mesh),
      cut_nodes_(mesh_, units_.mesh(), changes_, options.min_face_bary),
      subdivision_(units_.mesh(), cut_nodes_, table_),
      crack_(mesh_, units_.mesh(), cut_nodes_, changes_),
      seals_(units_.mesh()),
      virtual_nodes_(mesh_, units_.mesh(), cut_nodes_, seals_) {
  sweep_ = std::make_unique<BladeSweep>(units_.mesh());
  (void)canonicalize({});  // builds the canonical-state table now, not in the first cut step
  original_.resize(mesh.tet_capacity());
  original_removed_.assign(mesh.node_capacity(), 0);
  for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t)
    if (mesh.tet_slot_alive(t)) original_[t] = mesh.tet_vertex_indices(t);
}

CutEngine::~CutEngine() = default;

void CutEngine::refit() {
  units_.follow(mesh_);
  sweep_->refit();
}

void CutEngine::place(const BladePose& pose) {
  blade_ = pose;
  placed_ = true;
  stroke_start_ = step_count_ + 1;
  in_contact_ = false;  // the next contact is a new stroke
}

std::uint32_t CutEngine::coarse_of(TetId live) const {
  if (!mesh_.alive(live)) throw std::logic_error("CutEngine::coarse_of: stale handle");
  return crack_.unit_of(live.index);
}

CutTopology CutEngine::topology(std::uint32_t coarse_slot) const {
  const CutUnit* c = crack_.find(coarse_slot);
  return c == nullptr ? CutTopology{} : c->topology;
}

CanonicalState CutEngine::state(std::uint32_t coarse_slot) const {
  const CutUnit* c = crack_.find(coarse_slot);
  return c == nullptr ? CanonicalState{} : c->state;
}

std::string CutEngine::state_label_of(std::uint32_t coarse_slot) const {
  const CutUnit* c = crack_.find(coarse_slot);
  return c == nullptr ? table_.label({}, false) : table_.label(c->topology, c->complete);
}

int CutEngine::state_code_of(std::uint32_t coarse_slot) const {
  const CutUnit* c = crack_.find(coarse_slot);
  return c == nullptr ? table_.label_code({}, false) : table_.label_code(c->topology, c->complete);
}

std::vector<std::size_t> CutEngine::subdivision_sizes() const {
  std::vector<std::uint32_t> keys;
  for (const auto& [k, v] : crack_.units()) keys.push_back(k);
  std::sort(keys.begin(), keys.end());
  std::vector<std::size_t> out;
  for (const auto k : keys) out.push_back(crack_.at(k).live.size());
  return out;
}

// Subdivides the affected coarse tetrahedra again, records their transitions, opens the crack
// where the cut surface now surrounds a node, and updates the live mesh.
std::size_t CutEngine::commit(const FlatSet<std::uint32_t>& affected,
                              const FlatSet<std::uint32_t>& left_faces_tets, CutStepStats& stats) {
  auto& scratch = commit_scratch_;
  // The state before the step of every tetrahedron that may change, recorded once per step below.
  auto& before = scratch.before;
  before.clear();
  for (const auto* set : {&affected, &left_faces_tets})
    for (const std::uint32_t t : *set) {
      const CutUnit* c = crack_.find(t);
      before.emplace_back(t, c == nullptr ? MachineState{} : MachineState{c->state.reference, c->complete});
    }
  // By unit, each once (a unit in both sets has the same state in each). std::sort, as every sort of
  // a step: std::stable_sort allocates a buffer.
  std::sort(before.begin(), before.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  before.erase(std::unique(before.begin(), before.end(),
                           [](const auto& a, const auto& b) { return a.first == b.first; }),
               before.end());
  // Subdivide the affected tetrahedra again.
  auto& regroup_ids = scratch.regroup_ids;
  regroup_ids.clear();
  for (const std::uint32_t t : affected) {
    CutUnit* found = crack_.find(t);
    if (found == nullptr) {
      found = &crack_.start(t, mesh_.tet_handle(units_.live(t)));
      ++totals_.coarse_tets_cut;
    }
    CutUnit& c = *found;
    c.topology = subdivision_.topology(t);
    c.state = canonicalize(c.topology);
    subdivision_.subdivide(t, c.state, c.subs);
    for (const auto& s : c.subs)
      for (const GNode g : s)
        if ((g & kCutBit) && cut_nodes_.opens(static_cast<std::uint32_t>(g & ~kCutBit)))
          regroup_ids.insert(static_cast<std::uint32_t>(g & ~kCutBit));
  }
  // Completion (§4.3, "leave"): a cut tetrahedron none of whose faces the blade crosses any more is
  // in an end state. One whose cut this step changed is open while the blade crosses one of its
  // faces (a stroke extending its cut); one whose cut did not change stays as it was. Only
  // tetrahedra whose cut changed or whose faces the blade left can change.
  for (const auto& [t, from] : before) {
    CutUnit* found = crack_.find(t);
    if (found == nullptr) continue;
    CutUnit& c = *found;
    bool crossed = false;
    for (int f = 0; f < 4 && !crossed; ++f) {
      const auto fv = face_vertex_indices(units_.mesh(), t, f);
      const std::uint32_t id = cut_nodes_.mid(sorted_key(fv[0], fv[1], fv[2]));
      crossed = id != kInvalidIndex && cut_nodes_[id].crossing;
    }
    if (affected.contains(t))
      c.complete = !crossed && c.topology.edges != 0;
    else if (!crossed && c.topology.edges != 0)
      c.complete = true;
    const MachineState to{c.state.reference, c.complete};
    if (to == from) continue;
    ++stats.transitions;
    ++totals_.state_transitions[{from.key(), to.key()}];
  }

  // Open the crack where the cut surface now surrounds a node.
  auto& rebuild = scratch.rebuild;
  rebuild.clear();
  rebuild.insert(affected.begin(), affected.end());
  auto& regrouped = scratch.regrouped;
  regrouped.clear();
  for (const std::uint32_t id : regroup_ids) virtual_nodes_.regroup(id, crack_.units(), regrouped);
  rebuild.insert(regrouped.begin(), regrouped.end());
  for (const std::uint32_t t : rebuild) {
    const Crack::Rebuilt r = crack_.rebuild(t);
    stats.tets_created += r.created;
    stats.tets_removed += r.removed;
  }
  // A copy no group took (groups that merged again once a crack face between them went, e.g. a
  // subdivision undone by tremble, §5.1) has lost its elements with the rebuild: it goes, or the
  // tissue would keep a node it never moves. Promoted units may still hold a pinned node's copy.
  auto& unused = scratch.unused;
  unused.clear();
  auto& index = scratch.copy_index;
  for (const std::uint32_t id : regroup_ids) {
    CutNode& n = cut_nodes_[id];
    index.assign(n.copies.size(), kInvalidIndex);
    for (const auto& e : n.group_of) index[e.group] = 0;
    std::uint32_t kept = 0;
    for (std::uint32_t k = 0; k < n.copies.size(); ++k) {
      if (index[k] == kInvalidIndex && mesh_.node_tets(n.copies[k]).empty()) {
        unused.push_back(n.copies[k]);
        continue;
      }
      index[k] = kept;
      n.copies[kept++] = n.copies[k];
    }
    if (kept == n.copies.size()) continue;
    n.copies.resize(kept);
    for (auto& e : n.group_of) e.group = index[e.group];
  }
  return cut_nodes_.remove_nodes(unused);
}

std::map<std::string, std::size_t> CutEngine::transitions_by_label() const {
  std::map<std::string, std::size_t> out;
  for (const auto& [states, count] : totals_.state_transitions) {
    const MachineState from = MachineState::from_key(states.first),
                       to = MachineState::from_key(states.second);
    out[table_.label(from.topology, from.complete) + "->" + table_.label(to.topology, to.complete)] += count;
  }
  return out;
}

CutStepStats CutEngine::step(const BladePose& pose) {
  return sweep_to(pose, true);
}

template <class F>
bool CutEngine::for_units_at(const Vec3& p, F&& f) const {
  constexpr double kSlack = 1e-9;  // a point on a shared face belongs to either side
  const auto& x = units_.mesh().positions();
  bool done = false;
  std::vector<std::int32_t> stack;
  sweep_->tree().query(
      [&](const Aabb& box) {
        return !done && (box.lo.array() <= p.array()).all() && (p.array() <= box.hi.array()).all();
      },
      [&](std::uint32_t unit) {
        if (done || !units_.mesh().tet_slot_alive(unit)) return;
        const auto& v = units_.mesh().tet_vertex_indices(unit);
        const auto w = volume_weights(p, {x[v[0]], x[v[1]], x[v[2]], x[v[3]]});
        if (w && std::all_of(w->begin(), w->end(), [](double wi) { return wi >= -kSlack; }))
          done = f(unit, *w);
      },
      stack);
  return done;
}

// The blade's motion through the tissue is what cuts (§3). Between two tool samples the tissue
// model moves the tissue under a blade that stands still: dragged along by the blade's resistance,
// springing back, gaping. Tissue that moved into the sharp edge must be cut as if the edge had moved
// into it, or a blade lifted out of skin it had dragged along leaves the lips joined. The tissue's
// displacement under the blade is taken at points along its part inside the tissue, from the units
// holding them before the move, and averaged: a translation, since the tissue turns little under the
// blade within one tissue step. Only its part against the sharp edge counts (the cutting direction,
// or the blade's last motion across itself): tissue pressed against the flat of the blade, or
// sliding along it, is pushed, not cut (Eq. 1).
CutStepStats CutEngine::follow_tissue() {
  Vec3 moved = Vec3::Zero();
  int inside = 0;
  if (placed_) {
    const auto& before = units_.mesh().positions();
    const auto& after = mesh_.positions();
    constexpr int kPoints = 16;
    for (int k = 0; k <= kPoints; ++k) {
      const Vec3 p = blade_.back + (blade_.tip - blade_.back) * (static_cast<double>(k) / kPoints);
      const bool found = for_units_at(p, [&](std::uint32_t unit, const std::array<double, 4>& w) {
        const auto& v = units_.mesh().tet_vertex_indices(unit);
        for (std::size_t i = 0; i < 4; ++i) moved += w[i] * (after[v[i]] - before[v[i]]);
        return true;
      });
      inside += found ? 1 : 0;
    }
  }
  refit();
  changes_.clear();
  const Vec3 edge = blade_.cutting_direction.squaredNorm() > 0 ? blade_.cutting_direction : heading_;
  // How far the blade went into the tissue along its edge, relative to the tissue.
  const double into = inside > 0 ? -moved.dot(edge) / inside : 0.0;
  if (!(into > 0.0)) return {};
  const BladePose pose = blade_;
  blade_.back -= into * edge;
  blade_.tip -= into * edge;
  return sweep_to(pose, false);
}

// The section-3 pipeline: collision (with the recursive continuation where the sweep reaches a
// cut it cannot continue), the events in sweep order, the tremble at faces, the face nodes placed,
// and the affected units subdivided again.
CutStepStats CutEngine::sweep_to(const BladePose& pose, bool tool_moved) {
  CutStepStats stats;
  changes_.clear();
  if (!placed_) {
    place(pose);
    totals_.add(stats);
    return stats;
  }
  const BladePose prev = blade_;
  collide(prev, pose, tool_moved, stats);
  const std::size_t nodes_before = mesh_.node_count();
  StepEvents& ev = step_events_;
  ev.clear();
  edge_events(prev, pose, ev, stats);
  pierce_events(ev, stats);
  crossing_events(prev, pose, ev, stats);
  tremble_at_faces(ev, stats);
  place_face_nodes(ev);

  stats.sealed_events = ev.sealed_now.size();
  std::size_t removed = commit(ev.affected, ev.left_faces_tets, stats);
  removed += cut_nodes_.remove_undone();
  stats.nodes_created = mesh_.node_count() + removed - nodes_before;
  totals_.add(stats);

#ifdef SCALPEL_VALIDATE
  // Invariants 1-4 wherever this step changed the mesh (docs/invariants.md).
  const auto report = validate_local(mesh_, changes_.touched_nodes, {.reference_volume = coarse_volume_});
  if (!report.ok())
    throw std::logic_error("CutEngine: mesh invariant broken after a cut step:\n" + report.summary());
#endif
  return stats;
}

void CutEngine::collide(const BladePose& prev, const BladePose& pose, bool tool_moved, CutStepStats& stats) {
  sweep_->sweep(prev, pose, sweep_result_);
  if (sweep_result_.tets.empty()) {
    if (tool_moved) in_contact_ = false;  // the tissue moving off the blade does not end a stroke
  } else if (!in_contact_) {
    in_contact_ = true;
    ++stroke_;
  }
  // Recursive continuation (§6): where the sweep reaches a component the basic machine cannot
  // continue, its sub-tetrahedra become units and collision runs again on them. Each pass goes one
  // level deeper in the components it promotes; the depth bound ends the loop.
  std::set<std::uint32_t> refused;
  for (int pass = 0; pass <= options_.max_recursion_depth; ++pass) {
    const std::map<std::uint32_t, bool> units = recursive_units(prev, pose);
    if (units.empty() || !promote(units, refused, stats)) break;
    sweep_->sweep(prev, pose, sweep_result_);
  }
  if (tool_moved) {
    ++step_count_;  // steps count tool samples (CutOptions::finished_after_steps)
    const Vec3 along = (pose.tip - pose.back).normalized();
    Vec3 across = (pose.tip + pose.back - prev.tip - prev.back) / 2;
    across -= across.dot(along) * along;
    if (across.squaredNorm() > 0 && along.allFinite()) heading_ = across.normalized();
  }
  blade_ = pose;
  for (const std::uint32_t t : sweep_result_.tets) units_.touch(t, step_count_);
  stats.tets_touched = sweep_result_.tets.size();
}

void CutEngine::StepEvents::clear() {
  changed_faces.clear();
  positioned_faces.clear();
  affected.clear();
  new_edges.clear();
  sealed_now.clear();
  tip_left.clear();
  crossing_now.clear();
  left_faces_tets.clear();
}

bool CutEngine::skip_sealed(const Key3& k, StepEvents& ev) const {
  if (!seals_.sealed(k)) return false;
  ev.sealed_now.insert(k);
  return true;
}

Vec3 CutEngine::face_bary(const Key3& k, const Vec3& point) const {
  const auto& x = units_.mesh().positions();
  return barycentric(point, x[k[0]], x[k[1]], x[k[2]]);
}

// Edge events in sweep order (§4.3). Only forward crossings cut (Eq. 1).
void CutEngine::edge_events(const BladePose& prev, const BladePose& pose, StepEvents& ev,
                            CutStepStats& stats) {
  auto& edges = sweep_order_.edges;
  for (const auto& e : sweep_result_.edges) edges.push_back(&e);
  // Stable: crossings at one u keep the sweep's order (their addresses, in one vector).
  std::sort(edges.begin(), edges.end(),
            [](const EdgeCut* a, const EdgeCut* b) { return a->u < b->u || (a->u == b->u && a < b); });
  for (const EdgeCut* e : edges) {
    const Key3 k = edge_key(e->a, e->b);
    if (skip_sealed(k, ev)) continue;
    if (along_former_cut(*e, prev, pose)) {
      ++stats.recrossed_edges;
      continue;
    }
    double t = std::clamp(e->t, options_.min_edge_param, 1.0 - options_.min_edge_param);
    if (e->a > e->b) t = 1.0 - t;  // weights follow the ascending key
    const std::uint32_t known = cut_nodes_.edge(k[0], k[1]);
    if (known != kInvalidIndex) {
      CutNode& n = cut_nodes_[known];
      if (!e->forward) {
        ++stats.backward_crossings;
      } else if (n.registered && !n.pinned) {
        // §5, Fig. 9: a forward crossing of a registered edge moves its node to the new crossing
        // and makes it a cut; the subdivision stays.
        n.registered = false;
        n.bary = Vec3(1.0 - t, t, 0.0);
        cut_nodes_.place(known);
        for_coarse_tets_around(k, [&](std::uint32_t c) { ev.affected.insert(c); });
        ++stats.replaced_crossings;
        ++stats.edges_cut;
      } else {
        ++stats.recrossed_edges;
      }
      continue;
    }
    // A new crossing. A backward one (Eq. 1: the blunt side leads) is registered on the edge: the
    // edge node exists and subdivides, but it never opens until a forward crossing cuts it.
    const std::uint32_t id = cut_nodes_.add(CutNode::Kind::Edge, k, Vec3(1.0 - t, t, 0.0), stroke_);
    // Normal of the swept surface at the crossing: blade direction x blade motion there.
    cut_nodes_[id].sheet_normal = swept_normal(prev, pose, e->s);
    cut_nodes_[id].registered = !e->forward;
    ev.new_edges.push_back(k);
    ++(e->forward ? stats.edges_cut : stats.backward_crossings);
  }
  edges.clear();  // they point into this step's sweep result
}

void CutEngine::pierce_events(StepEvents& ev, CutStepStats& stats) {
  // Tip pierces: entry nodes (§4.1). A pierce of a face that holds an entry node from an earlier
  // step is the tip leaving by the face it came in by (§5.1, handled below).
  // Per pierced face, once: the tetrahedron the tip goes into last (kInvalidIndex: out of the
  // mesh) and the first point, in the order of the faces' keys.
  auto& pierced = sweep_order_.pierced;
  pierced.clear();
  for (const auto& p : sweep_result_.pierces)
    pierced.push_back({sorted_key(p.nodes[0], p.nodes[1], p.nodes[2]), p.tet, p.entering, p.point,
                       static_cast<std::uint32_t>(pierced.size())});
  std::sort(pierced.begin(), pierced.end(), [](const SweepOrder::Pierce& a, const SweepOrder::Pierce& b) {
    return a.face < b.face || (a.face == b.face && a.order < b.order);
  });
  for (std::size_t i = 0; i < pierced.size();) {
    const Key3 k = pierced[i].face;
    const Vec3 point = pierced[i].point;
    std::uint32_t into = kInvalidIndex;
    for (; i < pierced.size() && pierced[i].face == k; ++i)
      if (pierced[i].entering) into = pierced[i].tet;
    if (skip_sealed(k, ev)) continue;
    const std::uint32_t known = cut_nodes_.entry(k);
    if (known != kInvalidIndex) {
      // Back the way it came: the tip leaves by the face it entered. The same way again is the face
      // moving with the tissue past a tip that already went through it: nothing happens.
      if (cut_nodes_[known].into != into) ev.tip_left.insert(k);
      continue;
    }
    const std::uint32_t mid = cut_nodes_.mid(k);
    if (mid != kInvalidIndex && cut_nodes_[mid].opened) {
      ++stats.recrossed_faces;  // the face is cut through already: the recursive case (§6)
      continue;
    }
    // The tip entering a unit whose cut is final (§4.4): its entry node, split first by the
    // program, would run that unit's subdivision again from a state whose crack faces need not
    // hold the lips it has opened, and join them again. The end state is terminal for the tip.
    if (into_final(k)) {
      ++stats.final_pierces;
      continue;
    }
    const Vec3 w = clamp_interior(face_bary(k, point), options_.min_face_bary);
    const std::uint32_t id = cut_nodes_.add(CutNode::Kind::Entry, k, w, stroke_);
    cut_nodes_[id].into = into;
    ev.changed_faces.insert(k);
    ev.positioned_faces.insert(k);
    ++stats.face_pierces;
  }
}

void CutEngine::crossing_events(const BladePose& prev, const BladePose& pose, StepEvents& ev,
                                CutStepStats& stats) {
  // Faces the blade crosses now: their mid node is the ENP and follows the blade.
  for (const auto& c : sweep_result_.crossings) {
    const Key3 k = sorted_key(c.nodes[0], c.nodes[1], c.nodes[2]);
    if (skip_sealed(k, ev)) continue;
    if (!ev.crossing_now.insert(k)) continue;
    const Vec3 sample = face_bary(k, c.point);
    const Vec3 w = clamp_interior(sample, options_.min_face_bary);
    std::uint32_t id = cut_nodes_.mid(k);
    if (id == kInvalidIndex) {
      id = cut_nodes_.add(CutNode::Kind::Mid, k, w, stroke_);
      ev.changed_faces.insert(k);
    }
    CutNode& n = cut_nodes_[id];
    if (n.opened) {  // already cut through; a second pass is the recursive case (§6)
      ++stats.recrossed_faces;
      continue;
    }
    n.crossing = true;
    n.bary = w;
    const Vec3 normal = swept_normal(prev, pose, c.s);
    if (normal.squaredNorm() > 0) n.sheet_normal = normal;
    n.stroke = stroke_;
    n.sample_sum += sample;
    ++n.samples;
    ev.positioned_faces.insert(k);
  }
  for (const Key3& k : cut_nodes_.crossing_faces()) {
    if (ev.crossing_now.contains(k)) continue;
    ev.positioned_faces.insert(k);
    for_coarse_tets_around(k, [&](std::uint32_t t) { ev.left_faces_tets.insert(t); });
  }
  cut_nodes_.update_crossings(ev.crossing_now);  // the others settle at their averaged trajectory (§5.2)
}

void CutEngine::tremble_at_faces(StepEvents& ev, CutStepStats& stats) {
  // Tremble at faces (§5.1, the dotted transitions O1->O0, O2->O1, A2->A1, B2->B1): a tip
  // that leaves by the face it entered before any edge of that face is cut undoes the face's
  // subdivision.
  for (const Key3& k : ev.tip_left) {
    const std::uint32_t mid = cut_nodes_.mid(k);
    if (cut_nodes_.face_has_edge_node(k) || (mid != kInvalidIndex && cut_nodes_[mid].opened)) {
      ++stats.recrossed_faces;  // the tip crosses a cut face again: the recursive case (§6)
      continue;
    }
    cut_nodes_.undo_face(k, !cut_nodes_.crossing_faces().contains(k));
    ev.changed_faces.insert(k);
    ++stats.undone_faces;
  }
}

void CutEngine::place_face_nodes(StepEvents& ev) {
  // Every face around a new cut edge carries the trace of the swept surface through it.
  for (const Key3& k : ev.new_edges) {
    for_coarse_tets_around(k, [&](std::uint32_t t) { ev.affected.insert(t); });
    for (const Key3& fk : faces_around_edge(k)) {
      ev.positioned_faces.insert(fk);
      if (cut_nodes_.mid(fk) == kInvalidIndex) {
        (void)cut_nodes_.add(CutNode::Kind::Mid, fk, Vec3::Constant(1.0 / 3.0), stroke_);
        ev.changed_faces.insert(fk);
      }
    }
  }

  // Place mid nodes; a mid node that moves to another part of an entry-split face changes topology.
  for (const Key3& k : ev.positioned_faces) {
    const std::uint32_t id = cut_nodes_.mid(k);
    if (id == kInvalidIndex) continue;
    const int before = cut_nodes_[id].entry_subtriangle;
    cut_nodes_.update_face_position(id);
    if (cut_nodes_[id].entry_subtriangle != before) ev.changed_faces.insert(k);
  }
  for (const Key3& k : ev.changed_faces)
    for_coarse_tets_around(k, [&](std::uint32_t t) { ev.affected.insert(t); });
}

CutStepStats CutEngine::impose(std::uint32_t t, const CutTopology& local, bool complete) {
  CutStepStats stats;
  changes_.clear();
  const std::size_t nodes_before = mesh_.node_count();
  const auto& v = units_.mesh().tet_vertex_indices(t);
  std::set<Key3> faces;
  auto make = [&](CutNode::Kind kind, const Key3& k, const Vec3& w) {
    const std::uint32_t known = cut_nodes_.find(kind, k);
    return known != kInvalidIndex ? known : cut_nodes_.add(kind, k, w, stroke_);
  };
  for (int e = 0; e < 6; ++e) {
    if (!(local.edges & (1u << e))) continue;
    const auto& ev = kEdgeVertices[static_cast<size_t>(e)];
    const double param = 0.3 + 0.07 * e;
    const Key3 k = edge_key(v[static_cast<size_t>(ev[0])], v[static_cast<size_t>(ev[1])]);
    make(CutNode::Kind::Edge, k, Vec3(1 - param, param, 0));
    for (const Key3& fk : faces_around_edge(k)) faces.insert(fk);
  }
  for (int f = 0; f < 4; ++f) {
    const auto fv = face_vertex_indices(units_.mesh(), t, f);
    const Key3 k = sorted_key(fv[0], fv[1], fv[2]);
    if (local.entries & (1u << f)) {
      make(CutNode::Kind::Entry, k, Vec3(0.2, 0.35, 0.45));
      ++stats.face_pierces;
    }
    if (local.faces & (1u << f)) faces.insert(k);
  }
  FlatSet<std::uint32_t> affected;
  for (const Key3& k : faces) {
    const std::uint32_t id = make(CutNode::Kind::Mid, k, Vec3(0.45, 0.3, 0.25));
    CutNode& n = cut_nodes_[id];
    if (n.samples == 0) {
      n.sample_sum = n.bary;
      n.samples = 1;
    }
    cut_nodes_.set_crossing(id, !complete);
    cut_nodes_.update_face_position(id);
  }
  const auto add = [&](std::uint32_t a) { affected.insert(a); };
  for (const Key3& k : faces) for_coarse_tets_around(k, add);
  for (const auto& [k, id] : cut_nodes_.entries()) for_coarse_tets_around(k, add);
  affected.insert(t);
  const std::size_t removed = commit(affected, FlatSet<std::uint32_t>{}, stats);
  stats.nodes_created = mesh_.node_count() + removed - nodes_before;
  totals_.add(stats);
  return stats;
}

// A unit whose cut is final: in an end state (§4.4, the blade has left it) with every cut node that
// opens opened. A unit where the cut ends inside (a node still closed) is the cut's open end, which
// a later stroke continues (Fig. 12).
bool CutEngine::into_final(const std::array<std::uint32_t, 3>& face) const {
  for (const std::uint32_t t : coarse_tets_around(face)) {
    const CutUnit* c = crack_.find(t);
    if (c != nullptr && c->complete &&
        !c->any_cut_node([&](std::uint32_t id) { return cut_nodes_.opens(id) && !cut_nodes_[id].opened; }))
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
    for (const std::uint32_t third : units_.mesh().tet_vertex_indices(t))
      if (third != key[0] && third != key[1]) out.push_back(sorted_key(key[0], key[1], third));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// Each crack face once, at the real nodes of the sub-tetrahedron that owns it: one side's copies,
// so the area does not grow as the crack opens.
double CutEngine::cut_surface_area() const {
  double area = 0.0;
  for (const auto& f : cut_surface_faces())
    area += triangle_area(mesh_.position(f[0]), mesh_.position(f[1]), mesh_.position(f[2]));
  return area;
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

std::optional<TetLocation> CutEngine::locate(const Vec3& p, double margin) const {
  // How far p lies from a tetrahedron (0 inside).
  const auto outside = [&p](const std::array<Vec3, 4>& x) {
    const std::optional<std::array<double, 4>> w = volume_weights(p, x);
    if (!w) return std::numeric_limits<double>::infinity();
    if (std::all_of(w->begin(), w->end(), [](double wi) { return wi >= 0.0; })) return 0.0;
    double out = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 4; ++i)
      out = std::min(
          out, (p - closest_point_on_triangle(p, x[(i + 1) % 4], x[(i + 2) % 4], x[(i + 3) % 4])).norm());
    return out;
  };
  const auto corners = [](const TetMesh& m, const std::array<std::uint32_t, 4>& v) {
    const auto& x = m.positions();
    return std::array<Vec3, 4>{x[v[0]], x[v[1]], x[v[2]], x[v[3]]};
  };
  // The live tetrahedron at p: the unit whose corners enclose it, or the sub-tetrahedron of a cut
  // unit that does, within the margin (none in an opened crack).
  TetId at;
  for_units_at(p, [&](std::uint32_t unit, const std::array<double, 4>&) {
    const CutUnit* c = crack_.find(unit);
    if (c == nullptr) {
      at = mesh_.tet_handle(units_.live(unit));
      return true;
    }
    for (const TetId t : c->live)
      if (mesh_.alive(t) && outside(corners(mesh_, mesh_.tet_vertex_indices(t.index))) <= margin) {
        at = t;
        return true;
      }
    return false;
  });
  if (at.is_null()) return std::nullopt;
  // Weights on the corners of the tetrahedron of the original mesh it descends from, at their
  // current positions; where p lies outside them (that tetrahedron is cut and deformed) the
  // negative weights are clamped and the rest rescaled.
  TetLocation out;
  out.original = mesh_.parent(at);
  // Where a removed piece took corners of that tetrahedron with it, on the live element's own.
  const std::array<std::uint32_t, 4>& first = original_[out.original];
  const bool whole =
      std::none_of(first.begin(), first.end(), [&](std::uint32_t n) { return original_removed_[n]; });
  const auto& v = whole ? first : mesh_.tet_vertex_indices(at.index);
  std::array<double, 4> w =
      volume_weights(p, corners(mesh_, v)).value_or(std::array<double, 4>{0.25, 0.25, 0.25, 0.25});
  double sum = 0;
  for (double& wi : w) sum += (wi = std::max(wi, 0.0));
  for (int i = 0; i < 4; ++i) {
    out.corners[i] = mesh_.node_handle(v[i]);
    out.weights[i] = w[i] / sum;
  }
  return out;
}

}  // namespace scalpel
