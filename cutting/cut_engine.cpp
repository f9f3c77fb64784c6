#include "cutting/cut_engine.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <set>
#include <stdexcept>

#include "mesh/closest_point.hpp"
#include "mesh/validate.hpp"

namespace scalpel {

struct CutEngine::CutNode {
  using Kind = CutNodeKind;
  Kind kind = Kind::Edge;
  std::array<std::uint32_t, 3> key{};  // sorted coarse node slots; an edge has key[2] = kInvalidIndex
  Vec3 bary = Vec3::Zero();            // weights of the key nodes
  Vec3 placed_bary = Vec3::Zero();     // the weights its copies were last placed at
  std::uint32_t into = kInvalidIndex;  // entry node: the coarse tetrahedron the tip went into
  Vec3 sample_sum = Vec3::Zero();      // mid node: sum of sampled ENP barycentrics (§5.2)
  int samples = 0;
  bool crossing = false;             // mid node: the blade crosses the face now
  bool registered = false;           // edge node crossed only backward so far (§5, Eq. 1)
  int entry_subtriangle = -1;        // mid node on a face with an entry node: which part holds it
  Vec3 sheet_normal = Vec3::Zero();  // normal of the swept surface where it was cut (last sample)
  std::uint64_t stroke = 0;          // the stroke that cut it (last sample)
  // Shared with units promoted within a stroke (§6): it stays where it is and gains no copy.
  bool pinned = false;
  std::vector<NodeId> copies;  // real nodes, one per group (group_of says which)
  // It has had two copies: the cut has gone through here, even where its groups joined again
  // and the copy no element used has gone.
  bool opened = false;
  using GroupEntry = CutNodeGroup;
  std::vector<GroupEntry> group_of;  // sorted by (coarse, sub)
  // The copy sub-tetrahedron `sub` of coarse tetrahedron `coarse` uses (0 if not grouped).
  [[nodiscard]] std::uint32_t group(std::uint32_t coarse, std::uint32_t sub) const;
};

struct CutEngine::CoarseTet {
  std::vector<std::array<GNode, 4>> subs;   // the subdivision in abstract nodes
  std::vector<std::array<NodeId, 4>> real;  // the real nodes of each live sub-tetrahedron
  std::vector<TetId> live;
  CutTopology topology;  // in local labels
  CanonicalState state;  // the state (§4.2): canonical topology and absolute transformation
  bool complete = false;
  // Calls f(cut node index) for each cut-node corner of the sub-tetrahedra (a node once per
  // corner) until f returns true; returns whether it did.
  template <class F>
  bool any_cut_node(F&& f) const {
    for (const auto& sub : subs)
      for (const GNode g : sub)
        if ((g & kCutBit) && f(static_cast<std::uint32_t>(g & ~kCutBit))) return true;
    return false;
  }
};

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

namespace {

using Key3 = std::array<std::uint32_t, 3>;

Key3 sorted_key(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  Key3 k{a, b, c};
  std::sort(k.begin(), k.end());
  return k;
}

Key3 edge_key(std::uint32_t a, std::uint32_t b) {
  return {std::min(a, b), std::max(a, b), kInvalidIndex};
}

// Barycentric coordinates of p in triangle (a, b, c), p assumed near its plane.
Vec3 barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double nn = n.squaredNorm();
  if (nn == 0.0) return Vec3::Constant(1.0 / 3.0);
  const double la = (b - p).cross(c - p).dot(n) / nn;
  const double lb = (c - p).cross(a - p).dot(n) / nn;
  return {la, lb, 1.0 - la - lb};
}

// Pulls barycentric weights into the interior: every weight at least `floor` (a sliver guard).
Vec3 clamp_interior(Vec3 w, double floor) {
  w = w.cwiseMax(0.0);
  const double sum = w.sum();
  w = sum > 0 ? Vec3(w / sum) : Vec3::Constant(1.0 / 3.0);
  const double lo = w.minCoeff();
  if (lo >= floor) return w;
  // Blend toward the centroid just enough: (1-s) lo + s/3 = floor.
  const double s = (floor - lo) / (1.0 / 3.0 - lo);
  return (1.0 - s) * w + Vec3::Constant(s / 3.0);
}

// Normal of the surface the blade sweeps from `prev` to `pose` at blade parameter s (0 back, 1 tip):
// the blade's direction times its motion there.
Vec3 swept_normal(const BladePose& prev, const BladePose& pose, double s) {
  return (pose.tip - pose.back).cross((1.0 - s) * (pose.back - prev.back) + s * (pose.tip - prev.tip));
}

// The vertices of a tetrahedron but vertex `f`: its face f, in vertex order (not oriented).
template <class T>
std::array<T, 3> face_without(const std::array<T, 4>& tet, int f) {
  std::array<T, 3> out{};
  for (int i = 0, j = 0; i < 4; ++i)
    if (i != f) out[static_cast<size_t>(j++)] = tet[static_cast<size_t>(i)];
  return out;
}

// Parents of a node interpolated on a cut node's key edge (key[2] = kInvalidIndex) or face, at
// weights w.
NodeParents key_parents(const TetMesh& mesh, const std::array<std::uint32_t, 3>& key, const Vec3& w) {
  NodeParents p;
  p.count = key[2] == kInvalidIndex ? 2 : 3;
  for (int i = 0; i < p.count; ++i) {
    p.parents[static_cast<size_t>(i)] = mesh.node_handle(key[static_cast<size_t>(i)]);
    p.weights[static_cast<size_t>(i)] = w[i];
  }
  return p;
}

double triangle_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5 * (b - a).cross(c - a).norm();
}

int index_of(const std::array<std::uint64_t, 4>& t, std::uint64_t g) {
  for (int i = 0; i < 4; ++i)
    if (t[static_cast<size_t>(i)] == g) return i;
  return -1;
}

bool contains(const std::array<std::uint64_t, 4>& t, std::uint64_t g) {
  return index_of(t, g) >= 0;
}

// Stellar split of the sub-tetrahedron holding face {x, y, z} at a point inside that face: the
// three copies replace one face vertex each by m, so each keeps a positive volume (its volume is
// the barycentric weight of the replaced vertex times the parent's).
void split_face(std::vector<std::array<std::uint64_t, 4>>& subs, std::uint64_t x, std::uint64_t y,
                std::uint64_t z, std::uint64_t m) {
  for (size_t s = 0; s < subs.size(); ++s) {
    const auto t = subs[s];
    if (!contains(t, x) || !contains(t, y) || !contains(t, z)) continue;
    bool first = true;
    for (int i = 0; i < 4; ++i) {
      const auto v = t[static_cast<size_t>(i)];
      if (v != x && v != y && v != z) continue;
      auto child = t;
      child[static_cast<size_t>(i)] = m;
      if (first) {
        subs[s] = child;
        first = false;
      } else {
        subs.push_back(child);
      }
    }
    return;
  }
  throw std::logic_error("CutEngine: face to split not found in the subdivision");
}

// Stellar split of every sub-tetrahedron holding edge {p, q} at a point inside it.
void split_edge(std::vector<std::array<std::uint64_t, 4>>& subs, std::uint64_t p, std::uint64_t q,
                std::uint64_t x) {
  const size_t n = subs.size();
  for (size_t s = 0; s < n; ++s) {
    const int ip = index_of(subs[s], p), iq = index_of(subs[s], q);
    if (ip < 0 || iq < 0) continue;
    auto other = subs[s];
    subs[s][static_cast<size_t>(ip)] = x;
    other[static_cast<size_t>(iq)] = x;
    subs.push_back(other);
  }
}

// Barycentric weights of p in tetrahedron x by volumes: w_i is the volume with p in place of
// corner i over the whole; none for a tetrahedron of no positive volume.
std::optional<std::array<double, 4>> volume_weights(const Vec3& p, const std::array<Vec3, 4>& x) {
  const double whole = signed_volume(x[0], x[1], x[2], x[3]);
  if (!(whole > 0.0)) return std::nullopt;
  return std::array<double, 4>{
      signed_volume(p, x[1], x[2], x[3]) / whole, signed_volume(x[0], p, x[2], x[3]) / whole,
      signed_volume(x[0], x[1], p, x[3]) / whole, signed_volume(x[0], x[1], x[2], p) / whole};
}

}  // namespace

CutEngine::CutEngine(TetMesh& mesh, CutOptions options)
    : mesh_(mesh),
      coarse_(mesh),
      options_(options),
      table_(options.table ? *options.table : default_cut_table()),
      coarse_volume_(mesh.total_rest_volume()) {
  // The units grow when a cut is continued recursively (§6): room for an eighth more, so that the
  // first continuations of a session do not copy the whole unit mesh.
  coarse_.reserve(coarse_.node_capacity() + coarse_.node_capacity() / 8,
                  coarse_.tet_capacity() + coarse_.tet_capacity() / 8);
  sweep_ = std::make_unique<BladeSweep>(coarse_);
  (void)canonicalize({});  // builds the canonical-state table now, not in the first cut step
  live_to_coarse_.resize(mesh.tet_capacity());
  std::iota(live_to_coarse_.begin(), live_to_coarse_.end(), 0u);
  unit_live_ = live_to_coarse_;
  level_.assign(mesh.tet_capacity(), 0);
  last_touch_.assign(mesh.tet_capacity(), 0);
  for (auto* v : {&unit_live_, &live_to_coarse_})
    v->reserve(coarse_.tet_capacity() + coarse_.tet_capacity() / 8);
  level_.reserve(unit_live_.capacity());
  last_touch_.reserve(unit_live_.capacity());
  original_.resize(mesh.tet_capacity());
  for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t)
    if (mesh.tet_slot_alive(t)) original_[t] = mesh.tet_vertex_indices(t);
}

CutEngine::~CutEngine() = default;

void CutEngine::refit() {
  auto& x = coarse_.positions();
  const auto& live = mesh_.positions();
  std::copy(live.begin(), live.begin() + static_cast<std::ptrdiff_t>(x.size()), x.begin());
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
  return live.index < live_to_coarse_.size() ? live_to_coarse_[live.index] : kInvalidIndex;
}

CutTopology CutEngine::topology(std::uint32_t coarse_slot) const {
  const auto it = cut_tets_.find(coarse_slot);
  return it == cut_tets_.end() ? CutTopology{} : it->second.topology;
}

CanonicalState CutEngine::state(std::uint32_t coarse_slot) const {
  const auto it = cut_tets_.find(coarse_slot);
  return it == cut_tets_.end() ? CanonicalState{} : it->second.state;
}

std::string CutEngine::state_label_of(std::uint32_t coarse_slot) const {
  const auto it = cut_tets_.find(coarse_slot);
  if (it == cut_tets_.end()) return table_.label({}, false);
  return table_.label(it->second.topology, it->second.complete);
}

int CutEngine::state_code_of(std::uint32_t coarse_slot) const {
  const auto it = cut_tets_.find(coarse_slot);
  if (it == cut_tets_.end()) return table_.label_code({}, false);
  return table_.label_code(it->second.topology, it->second.complete);
}

std::vector<std::size_t> CutEngine::subdivision_sizes() const {
  std::vector<std::uint32_t> keys;
  for (const auto& [k, v] : cut_tets_) keys.push_back(k);
  std::sort(keys.begin(), keys.end());
  std::vector<std::size_t> out;
  for (const auto k : keys) out.push_back(cut_tets_.at(k).live.size());
  return out;
}

std::uint32_t CutEngine::edge_node(std::uint32_t a, std::uint32_t b) const {
  const auto it = edge_nodes_.find(edge_key(a, b));
  return it == edge_nodes_.end() ? kInvalidIndex : it->second;
}

std::uint32_t CutEngine::face_node(const std::map<Key3, std::uint32_t>& map, const Key3& key) const {
  const auto it = map.find(key);
  return it == map.end() ? kInvalidIndex : it->second;
}

// Places every copy of a cut node at its weights over the coarse nodes (docs/architecture.md: the
// cut is made in the current configuration and carried to the rest one by the same weights). The
// rest position is the weighted one. In the current configuration a copy goes where the tissue has
// put the material point of its new rest position: the piecewise-linear map of the live elements
// around it. So it keeps the displacement the tissue gave it, and sliding along the face leaves the
// field the elements interpolate as it was, up to re-interpolation. The coarse face's corners are no
// measure of that map once a crack or a strained element lies between them; they move only a copy
// no element holds yet.
void CutEngine::place_cut_node(std::uint32_t id) {
  CutNode& n = cut_nodes_[id];
  const int count = n.kind == CutNode::Kind::Edge ? 2 : 3;
  Vec3 r = Vec3::Zero(), dx_face = Vec3::Zero();
  for (int i = 0; i < count; ++i) {
    const NodeId p = mesh_.node_handle(n.key[static_cast<size_t>(i)]);
    r += n.bary[i] * mesh_.rest(p);
    dx_face += (n.bary[i] - n.placed_bary[i]) * mesh_.position(p);
  }
  for (const NodeId c : n.copies) {
    const std::optional<Vec3> x = current_position_of(c, r);
    mesh_.set_rest(c, r);
    mesh_.set_position(c, x ? *x : Vec3(mesh_.position(c) + dx_face));
    changes_.moved_nodes.push_back(c);
    changes_.touched_nodes.push_back(c.index);
  }
  n.placed_bary = n.bary;
}

// Where the live elements around real node c put rest point `rest` now: the element of c's star
// that holds it in the rest configuration (the one it is deepest in), interpolated at its current
// corners. None if c has no element of positive rest volume, or the point lies far outside them all.
std::optional<Vec3> CutEngine::current_position_of(NodeId c, const Vec3& rest) const {
  const auto& rp = mesh_.rest_positions();
  const auto& xp = mesh_.positions();
  double deepest = -0.5;  // further outside than that: the star is no measure
  std::optional<Vec3> out;
  for (const std::uint32_t t : mesh_.node_tets(c)) {
    const auto& v = mesh_.tet_vertex_indices(t);
    Eigen::Matrix3d dm;
    for (int k = 0; k < 3; ++k) dm.col(k) = rp[v[static_cast<size_t>(k + 1)]] - rp[v[0]];
    if (!(dm.determinant() > 0)) continue;
    const Vec3 w = dm.inverse() * (rest - rp[v[0]]);
    const double lowest = std::min({1.0 - w.sum(), w[0], w[1], w[2]});
    if (!(lowest > deepest)) continue;
    deepest = lowest;
    out = (1.0 - w.sum()) * xp[v[0]] + w[0] * xp[v[1]] + w[1] * xp[v[2]] + w[2] * xp[v[3]];
  }
  return out;
}

// Where a mid node stands (§4.1, §5.2): on the blade while the blade crosses the face; afterwards
// at the average of its sampled positions; a face the swept surface crossed between two samples
// has none, and takes the middle of its trace (the average of the trace's end points on the face).
void CutEngine::update_face_position(std::uint32_t id) {
  CutNode& n = cut_nodes_[id];
  if (n.opened || n.pinned) return;  // the crack has opened here, or promoted units hold it
  const Key3& k = n.key;
  const Vec3 pa = coarse_.positions()[k[0]], pb = coarse_.positions()[k[1]], pc = coarse_.positions()[k[2]];
  Vec3 w;
  if (n.crossing) {
    w = n.bary;
  } else if (n.samples > 0) {
    w = n.sample_sum / n.samples;
  } else {
    // Trace end points known on this face: its cut edges and its entry node.
    std::vector<Vec3> ends;
    const std::array<std::array<int, 2>, 3> edges{{{0, 1}, {1, 2}, {0, 2}}};
    std::uint32_t single_edge = kInvalidIndex;
    for (const auto& e : edges) {
      const std::uint32_t en = edge_node(k[static_cast<size_t>(e[0])], k[static_cast<size_t>(e[1])]);
      if (en == kInvalidIndex) continue;
      Vec3 b = Vec3::Zero();
      b[e[0]] = cut_nodes_[en].bary[0];  // key order of an edge is ascending, as in the face key
      b[e[1]] = cut_nodes_[en].bary[1];
      ends.push_back(b);
      single_edge = en;
    }
    const std::uint32_t entry = face_node(entry_nodes_, k);
    if (entry != kInvalidIndex) ends.push_back(cut_nodes_[entry].bary);
    if (ends.size() >= 2) {
      w = Vec3::Zero();
      for (const auto& b : ends) w += b / static_cast<double>(ends.size());
    } else if (single_edge != kInvalidIndex) {
      // One cut edge: follow the swept surface's plane from the cut point across the face.
      const Vec3 start = ends[0];
      const Vec3 x = start[0] * pa + start[1] * pb + start[2] * pc;
      const Vec3& normal = cut_nodes_[single_edge].sheet_normal;
      const std::array<Vec3, 3> p{pa, pb, pc};
      w = (start + Vec3::Constant(1.0 / 3.0)) / 2.0;  // if the plane misses the face
      for (int i = 0; i < 3 && normal.squaredNorm() > 0; ++i) {
        const int j = (i + 1) % 3;
        if (start[i] > 0 && start[j] > 0) continue;  // the edge that was cut
        const double di = normal.dot(p[static_cast<size_t>(i)] - x),
                     dj = normal.dot(p[static_cast<size_t>(j)] - x);
        if ((di < 0) == (dj < 0) || di == dj) continue;
        const double t = di / (di - dj);
        Vec3 end = Vec3::Zero();
        end[i] = 1.0 - t;
        end[j] = t;
        w = (start + end) / 2.0;
        break;
      }
    } else if (!ends.empty()) {
      w = ends[0];
    } else {
      w = Vec3::Constant(1.0 / 3.0);
    }
  }
  w = clamp_interior(w, options_.min_face_bary);

  // With an entry node on the face, the mid node lies in one of the three parts the entry node
  // cuts the face into; keep it clearly inside that part.
  const std::uint32_t entry = face_node(entry_nodes_, k);
  if (entry != kInvalidIndex) {
    const Vec3 e = cut_nodes_[entry].bary;
    int best = -1;
    double best_min = -1e300;
    Vec3 best_local;
    for (int j = 0; j < 3; ++j) {
      // Part j: corner j replaced by the entry node. Local weights (on e, then the two corners).
      const double alpha = w[j] / e[j];
      Vec3 local(alpha, 0, 0);
      local[1] = w[(j + 1) % 3] - alpha * e[(j + 1) % 3];
      local[2] = w[(j + 2) % 3] - alpha * e[(j + 2) % 3];
      if (local.minCoeff() > best_min) {
        best_min = local.minCoeff();
        best = j;
        best_local = local;
      }
    }
    best_local = clamp_interior(best_local, options_.min_face_bary);
    w = best_local[0] * e;
    w[(best + 1) % 3] += best_local[1];
    w[(best + 2) % 3] += best_local[2];
    n.entry_subtriangle = best;
  }
  n.bary = w;
  place_cut_node(id);
}

CutTopology CutEngine::compute_topology(std::uint32_t t) const {
  CutTopology topo;
  const auto& v = coarse_.tet_vertex_indices(t);
  for (int e = 0; e < 6; ++e) {
    const auto& ev = kEdgeVertices[static_cast<size_t>(e)];
    if (edge_node(v[static_cast<size_t>(ev[0])], v[static_cast<size_t>(ev[1])]) != kInvalidIndex)
      topo.edges |= static_cast<std::uint8_t>(1u << e);
  }
  for (int f = 0; f < 4; ++f) {
    const auto fv = face_vertex_indices(coarse_, t, f);
    const Key3 k = sorted_key(fv[0], fv[1], fv[2]);
    if (face_node(mid_nodes_, k) != kInvalidIndex) topo.faces |= static_cast<std::uint8_t>(1u << f);
    if (face_node(entry_nodes_, k) != kInvalidIndex) topo.entries |= static_cast<std::uint8_t>(1u << f);
  }
  return topo;
}

// The subdivision of one coarse tetrahedron: the table's program, run in the reference labels of the
// canonical state (§4.2) through the absolute transformation, so symmetric states share one entry.
void CutEngine::subdivide(std::uint32_t t, std::vector<std::array<GNode, 4>>& out) const {
  const auto& v = coarse_.tet_vertex_indices(t);
  out.assign(1, {v[0], v[1], v[2], v[3]});
  const CanonicalState& state = cut_tets_.at(t).state;
  const auto& p = state.transform.p;  // reference vertex i is local vertex p[i]
  for (const CutInstruction& ins : table_.program) {
    if (!ins.applies(state.reference)) continue;
    if (ins.op == CutInstruction::Op::SplitEdge) {
      const auto& ev = kEdgeVertices[ins.edge];
      const std::uint32_t a = v[p[static_cast<size_t>(ev[0])]], b = v[p[static_cast<size_t>(ev[1])]];
      split_edge(out, a, b, kCutBit | edge_node(a, b));
      continue;
    }
    const auto fv = face_vertex_indices(coarse_, t, p[ins.face]);
    const Key3 k = sorted_key(fv[0], fv[1], fv[2]);
    const std::uint32_t entry = face_node(entry_nodes_, k), mid = face_node(mid_nodes_, k);
    if (ins.op == CutInstruction::Op::SplitPart) {
      std::array<GNode, 3> part{k[0], k[1], k[2]};
      part[static_cast<size_t>(cut_nodes_[mid].entry_subtriangle)] = kCutBit | entry;
      split_face(out, part[0], part[1], part[2], kCutBit | mid);
    } else {
      split_face(out, k[0], k[1], k[2], kCutBit | (ins.node == CutInstruction::Node::Entry ? entry : mid));
    }
  }
}

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
  for (const std::uint32_t t : coarse_.node_tets(coarse_.node_handle(key[0]))) {
    const auto& v = coarse_.tet_vertex_indices(t);
    bool all = true;
    for (int i = 1; i < 3; ++i)
      if (key[static_cast<size_t>(i)] != kInvalidIndex)
        all &= std::find(v.begin(), v.end(), key[static_cast<size_t>(i)]) != v.end();
    if (all) out.push_back(t);
  }
  std::sort(out.begin(), out.end());
  return out;
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
  CutNode& n = cut_nodes_[id];
  const GNode g = kCutBit | id;
  auto& items = scratch_.items;
  items.clear();
  for (const std::uint32_t t : coarse_tets_around(n.key)) {
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

  // Copies follow their elements: once the crack has opened, the copies of n stand apart, and an
  // element moved to another copy would be torn across the gap. A coarse corner of a sub-tetrahedron
  // votes for the copy that shared a live element of the same coarse tetrahedron with it before this
  // step (the live elements are rebuilt after regrouping). Each group keeps the copy with the most
  // votes (largest counts first); a group split off gets a new copy where the copy it voted for
  // stands; a group without votes (all its coarse tetrahedra newly cut) takes a copy no group uses
  // or else a new one interpolated from the key nodes, where those coarse tetrahedra put n.
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
        if (node == v) votes.push_back({group_of_root[find(i)], k, 1});
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
  std::stable_sort(votes.begin(), votes.end(), [](const auto& a, const auto& b) { return a[2] > b[2]; });
  auto& copy_of = scratch_.copy_of;  // by group
  copy_of.assign(order.size(), kInvalidIndex);
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
      const std::uint32_t group = group_of_root[find(i)];
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
  for (std::uint32_t k = 0; k < order.size(); ++k) {
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
  // Coarse tetrahedra whose sub-tetrahedra changed group must be rebuilt.
  auto& fresh = scratch_.group_of;
  fresh.clear();
  for (std::uint32_t i = 0; i < items.size(); ++i)
    fresh.push_back({items[i].coarse, items[i].sub, copy_of[group_of_root[find(i)]]});
  std::sort(fresh.begin(), fresh.end());
  for (const auto& e : fresh)
    if (n.group(e.coarse, e.sub) != e.group) changed.push_back(e.coarse);
  n.group_of.swap(fresh);
  n.opened |= n.copies.size() > 1;
}

std::uint32_t CutEngine::CutNode::group(std::uint32_t coarse, std::uint32_t sub) const {
  const auto it = std::lower_bound(group_of.begin(), group_of.end(), GroupEntry{coarse, sub, 0});
  return it != group_of.end() && it->coarse == coarse && it->sub == sub ? it->group : 0;
}

// Brings the live sub-tetrahedra of one coarse tetrahedron in line with its subdivision and the
// node groups: elements whose real nodes are unchanged stay (minimal removals, §4.3).
void CutEngine::rebuild_live(std::uint32_t t, CutStepStats& stats) {
  CoarseTet& c = cut_tets_.at(t);
  std::vector<std::array<NodeId, 4>> real(c.subs.size());
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
  std::vector<std::pair<std::array<NodeId, 4>, std::size_t>> old_by_nodes(c.real.size());
  for (std::size_t i = 0; i < c.real.size(); ++i) old_by_nodes[i] = {c.real[i], i};
  std::sort(old_by_nodes.begin(), old_by_nodes.end());
  std::vector<TetId> live(real.size());
  std::vector<bool> kept(c.live.size(), false);
  std::vector<std::size_t> to_add;
  for (std::size_t s = 0; s < real.size(); ++s) {
    auto it =
        std::lower_bound(old_by_nodes.begin(), old_by_nodes.end(), std::make_pair(real[s], std::size_t{0}));
    while (it != old_by_nodes.end() && it->first == real[s] && kept[it->second]) ++it;
    if (it != old_by_nodes.end() && it->first == real[s]) {
      kept[it->second] = true;
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
  c.real = std::move(real);
  c.live = std::move(live);
}

// Subdivides the affected coarse tetrahedra again, records their transitions, opens the crack
// where the cut surface now surrounds a node, and updates the live mesh.
std::size_t CutEngine::commit(const std::set<std::uint32_t>& affected,
                              const std::set<std::uint32_t>& left_faces_tets, CutStepStats& stats) {
  // The state before the step of every tetrahedron that may change, recorded once per step below.
  std::map<std::uint32_t, MachineState> before;
  for (const auto* set : {&affected, &left_faces_tets})
    for (const std::uint32_t t : *set) {
      const auto it = cut_tets_.find(t);
      before.try_emplace(t, it == cut_tets_.end()
                                ? MachineState{}
                                : MachineState{it->second.state.reference, it->second.complete});
    }
  // Subdivide the affected tetrahedra again.
  std::set<std::uint32_t> regroup_ids;
  for (const std::uint32_t t : affected) {
    auto [it, fresh] = cut_tets_.try_emplace(t);
    CoarseTet& c = it->second;
    if (fresh) {
      const TetId live = mesh_.tet_handle(unit_live_[t]);
      c.live = {live};
      c.real = {mesh_.tet_nodes(live)};
      ++totals_.coarse_tets_cut;
    }
    c.topology = compute_topology(t);
    c.state = canonicalize(c.topology);
    subdivide(t, c.subs);
    for (const auto& s : c.subs)
      for (const GNode g : s)
        if ((g & kCutBit) && opens(static_cast<std::uint32_t>(g & ~kCutBit)))
          regroup_ids.insert(static_cast<std::uint32_t>(g & ~kCutBit));
  }
  // Completion (§4.3, "leave"): a cut tetrahedron none of whose faces the blade crosses any more is
  // in an end state; one the blade crosses again is open (a stroke extending its cut). Only
  // tetrahedra whose cut changed or whose faces the blade left can change.
  for (const auto& [t, from] : before) {
    const auto it = cut_tets_.find(t);
    if (it == cut_tets_.end()) continue;
    CoarseTet& c = it->second;
    bool crossed = false;
    for (int f = 0; f < 4 && !crossed; ++f) {
      const auto fv = face_vertex_indices(coarse_, t, f);
      const std::uint32_t id = face_node(mid_nodes_, sorted_key(fv[0], fv[1], fv[2]));
      crossed = id != kInvalidIndex && cut_nodes_[id].crossing;
    }
    if (affected.count(t))
      c.complete = !crossed && c.topology.edges != 0;
    else if (!crossed && c.topology.edges != 0)
      c.complete = true;
    const MachineState to{c.state.reference, c.complete};
    if (to == from) continue;
    ++stats.transitions;
    ++totals_.transitions[table_.label(from.topology, from.complete) + "->" +
                          table_.label(to.topology, to.complete)];
    ++totals_.state_transitions[{from.key(), to.key()}];
  }

  // Open the crack where the cut surface now surrounds a node.
  std::set<std::uint32_t> rebuild = affected;
  std::vector<std::uint32_t> regrouped;
  for (const std::uint32_t id : regroup_ids) regroup(id, regrouped);
  rebuild.insert(regrouped.begin(), regrouped.end());
  for (const std::uint32_t t : rebuild) rebuild_live(t, stats);
  // A copy no group took (groups that merged again once a crack face between them went, e.g. a
  // subdivision undone by tremble, §5.1) has lost its elements with the rebuild: it goes, or the
  // tissue would keep a node it never moves. Promoted units may still hold a pinned node's copy.
  std::vector<NodeId> unused;
  for (const std::uint32_t id : regroup_ids) {
    CutNode& n = cut_nodes_[id];
    std::vector<std::uint32_t> index(n.copies.size(), kInvalidIndex);
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
  return remove_nodes(unused);
}

CutStepStats CutEngine::step(const BladePose& pose) {
  return sweep_to(pose, true);
}

template <class F>
bool CutEngine::for_units_at(const Vec3& p, F&& f) const {
  constexpr double kSlack = 1e-9;  // a point on a shared face belongs to either side
  const auto& x = coarse_.positions();
  bool done = false;
  std::vector<std::int32_t> stack;
  sweep_->tree().query(
      [&](const Aabb& box) {
        return !done && (box.lo.array() <= p.array()).all() && (p.array() <= box.hi.array()).all();
      },
      [&](std::uint32_t unit) {
        if (done || !coarse_.tet_slot_alive(unit)) return;
        const auto& v = coarse_.tet_vertex_indices(unit);
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
    const auto& before = coarse_.positions();
    const auto& after = mesh_.positions();
    constexpr int kPoints = 16;
    for (int k = 0; k <= kPoints; ++k) {
      const Vec3 p = blade_.back + (blade_.tip - blade_.back) * (static_cast<double>(k) / kPoints);
      const bool found = for_units_at(p, [&](std::uint32_t unit, const std::array<double, 4>& w) {
        const auto& v = coarse_.tet_vertex_indices(unit);
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

CutStepStats CutEngine::sweep_to(const BladePose& pose, bool tool_moved) {
  CutStepStats stats;
  changes_.clear();
  if (!placed_) {
    place(pose);
    totals_.add(stats);
    return stats;
  }
  const BladePose prev = blade_;
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
  for (const std::uint32_t t : sweep_result_.tets) last_touch_[t] = step_count_;
  stats.tets_touched = sweep_result_.tets.size();

  std::set<Key3> changed_faces;      // faces whose topology (mid or entry node) is new
  std::set<Key3> positioned_faces;   // faces whose mid node must be placed again
  std::set<std::uint32_t> affected;  // coarse tetrahedra to subdivide again
  const std::size_t nodes_before = mesh_.node_count();

  auto face_bary = [&](const Key3& k, const Vec3& point) {
    const auto& x = coarse_.positions();
    return barycentric(point, x[k[0]], x[k[1]], x[k[2]]);
  };

  // Edge events in sweep order (§4.3). Only forward crossings cut (Eq. 1).
  std::vector<const EdgeCut*> edges;
  for (const auto& e : sweep_result_.edges) edges.push_back(&e);
  std::stable_sort(edges.begin(), edges.end(),
                   [](const EdgeCut* a, const EdgeCut* b) { return a->u < b->u; });
  std::vector<Key3> new_edges;
  std::set<Key3> sealed_now;               // sealed faces and edges the blade crossed, counted once
  auto skip_sealed = [&](const Key3& k) {  // a crossing of a sealed face or edge is ignored (§6)
    if (!sealed(k)) return false;
    sealed_now.insert(k);
    return true;
  };
  for (const EdgeCut* e : edges) {
    const Key3 k = edge_key(e->a, e->b);
    if (skip_sealed(k)) continue;
    if (along_former_cut(*e, prev, pose)) {
      ++stats.recrossed_edges;
      continue;
    }
    double t = std::clamp(e->t, options_.min_edge_param, 1.0 - options_.min_edge_param);
    if (e->a > e->b) t = 1.0 - t;  // weights follow the ascending key
    const auto known = edge_nodes_.find(k);
    if (known != edge_nodes_.end()) {
      CutNode& n = cut_nodes_[known->second];
      if (!e->forward) {
        ++stats.backward_crossings;
      } else if (n.registered && !n.pinned) {
        // §5, Fig. 9: a forward crossing of a registered edge moves its node to the new crossing
        // and makes it a cut; the subdivision stays.
        n.registered = false;
        n.bary = Vec3(1.0 - t, t, 0.0);
        place_cut_node(known->second);
        for (const std::uint32_t c : coarse_tets_around(k)) affected.insert(c);
        ++stats.replaced_crossings;
        ++stats.edges_cut;
      } else {
        ++stats.recrossed_edges;
      }
      continue;
    }
    // A new crossing. A backward one (Eq. 1: the blunt side leads) is registered on the edge: the
    // edge node exists and subdivides, but it never opens until a forward crossing cuts it.
    const std::uint32_t id = create_cut_node(CutNode::Kind::Edge, k, Vec3(1.0 - t, t, 0.0));
    // Normal of the swept surface at the crossing: blade direction x blade motion there.
    cut_nodes_[id].sheet_normal = swept_normal(prev, pose, e->s);
    cut_nodes_[id].registered = !e->forward;
    edge_nodes_.emplace(k, id);
    new_edges.push_back(k);
    ++(e->forward ? stats.edges_cut : stats.backward_crossings);
  }

  // Tip pierces: entry nodes (§4.1). A pierce of a face that holds an entry node from an earlier
  // step is the tip leaving by the face it came in by (§5.1, handled below).
  // Per pierced face: the tetrahedron the tip goes into (kInvalidIndex: out of the mesh) and the
  // point.
  std::map<Key3, std::pair<std::uint32_t, Vec3>> pierced;
  for (const auto& p : sweep_result_.pierces) {
    const auto [it, fresh] =
        pierced.try_emplace(sorted_key(p.nodes[0], p.nodes[1], p.nodes[2]), kInvalidIndex, p.point);
    if (p.entering) it->second.first = p.tet;
  }
  std::set<Key3> tip_left;
  for (const auto& [k, pierce] : pierced) {
    if (skip_sealed(k)) continue;
    const auto [into, point] = pierce;
    const auto known = entry_nodes_.find(k);
    if (known != entry_nodes_.end()) {
      // Back the way it came: the tip leaves by the face it entered. The same way again is the face
      // moving with the tissue past a tip that already went through it: nothing happens.
      if (cut_nodes_[known->second].into != into) tip_left.insert(k);
      continue;
    }
    const std::uint32_t mid = face_node(mid_nodes_, k);
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
    const std::uint32_t id = create_cut_node(CutNode::Kind::Entry, k, w);
    cut_nodes_[id].into = into;
    entry_nodes_.emplace(k, id);
    changed_faces.insert(k);
    positioned_faces.insert(k);
    ++stats.face_pierces;
  }

  // Faces the blade crosses now: their mid node is the ENP and follows the blade.
  std::set<Key3> crossing_now;
  for (const auto& c : sweep_result_.crossings) {
    const Key3 k = sorted_key(c.nodes[0], c.nodes[1], c.nodes[2]);
    if (skip_sealed(k)) continue;
    if (!crossing_now.insert(k).second) continue;
    const Vec3 sample = face_bary(k, c.point);
    const Vec3 w = clamp_interior(sample, options_.min_face_bary);
    std::uint32_t id = face_node(mid_nodes_, k);
    if (id == kInvalidIndex) {
      id = create_cut_node(CutNode::Kind::Mid, k, w);
      mid_nodes_.emplace(k, id);
      changed_faces.insert(k);
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
    positioned_faces.insert(k);
  }
  std::set<std::uint32_t> left_faces_tets;  // tetrahedra of faces the blade left: maybe complete now
  for (const Key3& k : crossing_faces_) {
    if (crossing_now.count(k)) continue;
    cut_nodes_[mid_nodes_.at(k)].crossing = false;  // settle at the averaged trajectory (§5.2)
    positioned_faces.insert(k);
    for (const std::uint32_t t : coarse_tets_around(k)) left_faces_tets.insert(t);
  }
  crossing_faces_.clear();
  for (const Key3& k : crossing_now)
    if (cut_nodes_[mid_nodes_.at(k)].crossing) crossing_faces_.insert(k);

  // Tremble at faces (§5.1, the dotted transitions O1->O0, O2->O1, A2->A1, B2->B1): a tip
  // that leaves by the face it entered before any edge of that face is cut undoes the face's
  // subdivision.
  for (const Key3& k : tip_left) {
    const std::uint32_t mid = face_node(mid_nodes_, k);
    if (face_has_edge_node(k) || (mid != kInvalidIndex && cut_nodes_[mid].opened)) {
      ++stats.recrossed_faces;  // the tip crosses a cut face again: the recursive case (§6)
      continue;
    }
    undo_face(k, !crossing_faces_.count(k));
    changed_faces.insert(k);
    ++stats.undone_faces;
  }

  // Every face around a new cut edge carries the trace of the swept surface through it.
  for (const Key3& k : new_edges) {
    for (const std::uint32_t t : coarse_tets_around(k)) affected.insert(t);
    for (const Key3& fk : faces_around_edge(k)) {
      positioned_faces.insert(fk);
      if (face_node(mid_nodes_, fk) == kInvalidIndex) {
        mid_nodes_.emplace(fk, create_cut_node(CutNode::Kind::Mid, fk, Vec3::Constant(1.0 / 3.0)));
        changed_faces.insert(fk);
      }
    }
  }

  // Place mid nodes; a mid node that moves to another part of an entry-split face changes topology.
  for (const Key3& k : positioned_faces) {
    const std::uint32_t id = face_node(mid_nodes_, k);
    if (id == kInvalidIndex) continue;
    const int before = cut_nodes_[id].entry_subtriangle;
    update_face_position(id);
    if (cut_nodes_[id].entry_subtriangle != before) changed_faces.insert(k);
  }
  for (const Key3& k : changed_faces)
    for (const std::uint32_t t : coarse_tets_around(k)) affected.insert(t);

  stats.sealed_events = sealed_now.size();
  std::size_t removed = commit(affected, left_faces_tets, stats);
  removed += remove_undone_nodes();
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

CutStepStats CutEngine::impose(std::uint32_t t, const CutTopology& local, bool complete) {
  CutStepStats stats;
  changes_.clear();
  const std::size_t nodes_before = mesh_.node_count();
  const auto& v = coarse_.tet_vertex_indices(t);
  std::set<Key3> faces;
  auto make = [&](std::map<Key3, std::uint32_t>& map, CutNode::Kind kind, const Key3& k, const Vec3& w) {
    const auto [it, fresh] = map.try_emplace(k, 0u);
    if (fresh) it->second = create_cut_node(kind, k, w);
    return it->second;
  };
  for (int e = 0; e < 6; ++e) {
    if (!(local.edges & (1u << e))) continue;
    const auto& ev = kEdgeVertices[static_cast<size_t>(e)];
    const double param = 0.3 + 0.07 * e;
    const Key3 k = edge_key(v[static_cast<size_t>(ev[0])], v[static_cast<size_t>(ev[1])]);
    make(edge_nodes_, CutNode::Kind::Edge, k, Vec3(1 - param, param, 0));
    for (const Key3& fk : faces_around_edge(k)) faces.insert(fk);
  }
  for (int f = 0; f < 4; ++f) {
    const auto fv = face_vertex_indices(coarse_, t, f);
    const Key3 k = sorted_key(fv[0], fv[1], fv[2]);
    if (local.entries & (1u << f)) {
      make(entry_nodes_, CutNode::Kind::Entry, k, Vec3(0.2, 0.35, 0.45));
      ++stats.face_pierces;
    }
    if (local.faces & (1u << f)) faces.insert(k);
  }
  std::set<std::uint32_t> affected;
  for (const Key3& k : faces) {
    const std::uint32_t id = make(mid_nodes_, CutNode::Kind::Mid, k, Vec3(0.45, 0.3, 0.25));
    CutNode& n = cut_nodes_[id];
    if (n.samples == 0) {
      n.sample_sum = n.bary;
      n.samples = 1;
    }
    n.crossing = !complete;
    if (n.crossing) crossing_faces_.insert(k);
    update_face_position(id);
  }
  for (const Key3& k : faces)
    for (const std::uint32_t a : coarse_tets_around(k)) affected.insert(a);
  for (const auto& [k, id] : entry_nodes_)
    for (const std::uint32_t a : coarse_tets_around(k)) affected.insert(a);
  affected.insert(t);
  const std::size_t removed = commit(affected, {}, stats);
  stats.nodes_created = mesh_.node_count() + removed - nodes_before;
  totals_.add(stats);
  return stats;
}

bool CutEngine::face_has_edge_node(const Key3& k) const {
  return edge_node(k[0], k[1]) != kInvalidIndex || edge_node(k[1], k[2]) != kInvalidIndex ||
         edge_node(k[0], k[2]) != kInvalidIndex;
}

void CutEngine::undo_face(const Key3& k, bool mid) {
  const auto entry = entry_nodes_.find(k);
  if (entry != entry_nodes_.end()) {
    undone_.push_back(entry->second);
    entry_nodes_.erase(entry);
  }
  const std::uint32_t m = face_node(mid_nodes_, k);
  if (m == kInvalidIndex) return;
  if (mid) {
    undone_.push_back(m);
    mid_nodes_.erase(k);
    crossing_faces_.erase(k);
  } else {
    cut_nodes_[m].entry_subtriangle = -1;
    update_face_position(m);
  }
}

// Removes the real nodes of undone cut nodes, which no element uses any more after the rebuild;
// returns how many.
std::size_t CutEngine::remove_undone_nodes() {
  if (undone_.empty()) return 0;
  std::vector<NodeId> dead;
  for (const std::uint32_t id : undone_) {
    CutNode& n = cut_nodes_[id];
    for (const NodeId c : n.copies) {
      if (!mesh_.node_tets(c).empty())
        throw std::logic_error("CutEngine: an undone cut node is still in use");
      dead.push_back(c);
    }
    n.copies.clear();
    n.group_of.clear();
  }
  undone_.clear();
  return remove_nodes(dead);
}

// Removes real nodes no element uses. One made in this step leaves the step's changes; the tissue
// model learns of the others by the removed elements that held them.
std::size_t CutEngine::remove_nodes(const std::vector<NodeId>& dead) {
  if (dead.empty()) return 0;
  auto is_dead = [&](NodeId x) { return std::find(dead.begin(), dead.end(), x) != dead.end(); };
  for (std::size_t i = changes_.added_nodes.size(); i-- > 0;)
    if (is_dead(changes_.added_nodes[i])) {
      changes_.added_nodes.erase(changes_.added_nodes.begin() + static_cast<std::ptrdiff_t>(i));
      changes_.added_node_parents.erase(changes_.added_node_parents.begin() + static_cast<std::ptrdiff_t>(i));
    }
  std::erase_if(changes_.moved_nodes, is_dead);
  for (const NodeId x : dead) mesh_.remove_node(x);
  return dead.size();
}

// A new cut node with one real copy, interpolated from its coarse nodes with weights `bary`.
std::uint32_t CutEngine::create_cut_node(CutNodeKind kind, const Key3& key, const Vec3& bary) {
  CutNode n;
  n.kind = kind;
  n.key = key;
  n.bary = bary;
  n.copies.push_back(add_node(key_parents(mesh_, key, bary)));
  n.placed_bary = bary;  // the copy is interpolated at `bary` by add_node
  n.stroke = stroke_;
  cut_nodes_.push_back(std::move(n));
  return static_cast<std::uint32_t>(cut_nodes_.size() - 1);
}

NodeId CutEngine::add_node(const NodeParents& parents) {
  const NodeId n = mesh_.add_interpolated_node(parents);
  changes_.added_nodes.push_back(n);
  changes_.added_node_parents.push_back(parents);
  return n;
}

std::vector<Vec3> CutEngine::cut_points() const {
  std::vector<Vec3> out;
  for (const CutNode& n : cut_nodes_)
    if (n.kind != CutNode::Kind::Mid && !n.copies.empty()) out.push_back(mesh_.rest(n.copies[0]));
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
    const auto it = cut_tets_.find(unit);
    if (it == cut_tets_.end()) {
      at = mesh_.tet_handle(unit_live_[unit]);
      return true;
    }
    for (const TetId t : it->second.live)
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
  const auto& v = original_[out.original];
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
  const std::uint32_t mid = face_node(mid_nodes_, k);
  if (mid != kInvalidIndex && cut_nodes_[mid].sheet_normal.squaredNorm() > 0)
    return cut_nodes_[mid].sheet_normal;
  for (const auto& [a, b] : {std::pair{k[0], k[1]}, std::pair{k[1], k[2]}, std::pair{k[0], k[2]}}) {
    const std::uint32_t e = edge_node(a, b);
    if (e != kInvalidIndex && cut_nodes_[e].sheet_normal.squaredNorm() > 0) return cut_nodes_[e].sheet_normal;
  }
  return Vec3::Zero();
}

std::map<std::uint32_t, bool> CutEngine::recursive_units(const BladePose& prev, const BladePose& pose) const {
  std::map<std::uint32_t, bool> out;
  const auto& x = coarse_.positions();
  auto point_of = [&](const CutNode& n) {
    Vec3 p = Vec3::Zero();
    for (int i = 0; i < (n.kind == CutNode::Kind::Edge ? 2 : 3); ++i)
      p += n.bary[i] * x[n.key[static_cast<size_t>(i)]];
    return p;
  };
  // Whether a new cut at `point` in unit `c` extends the surface already cut there (the blade
  // returning to a cut it left, along it: the basic machine goes on) rather than starting another.
  auto extends = [&](const CoarseTet& c, const Vec3& point, const Vec3& normal, double size) {
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
      const auto it = cut_tets_.find(t);
      if (it == cut_tets_.end()) continue;
      if (!only_complete || (it->second.complete && !extends(it->second, point, normal, size)))
        out[t] |= !only_complete;
    }
  };
  const Vec3 blade = pose.tip - pose.back;
  auto face_size = [&](const Key3& k) {
    return std::max({(x[k[0]] - x[k[1]]).norm(), (x[k[1]] - x[k[2]]).norm(), (x[k[0]] - x[k[2]]).norm()});
  };
  // A new cut on a face: a second surface there if the face is cut already, otherwise new only
  // to units whose subdivision is final.
  auto face_event = [&](const Key3& k, const Vec3& point, const Vec3& normal) {
    if (sealed(k)) return;
    const std::uint32_t mid = face_node(mid_nodes_, k);
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
    if (sealed(k) || along_former_cut(e, prev, pose)) continue;
    const std::uint32_t id = edge_node(e.a, e.b);
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
    if (face_node(entry_nodes_, k) != kInvalidIndex) continue;  // the tip's own way back (§5.1)
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
    cut_tets_.at(out[i]).any_cut_node([&](std::uint32_t id) {
      if (nodes_seen.insert(id).second)
        for (const std::uint32_t u : coarse_tets_around(cut_nodes_[id].key))
          if (cut_tets_.count(u) && seen.insert(u).second) out.push_back(u);
      return false;
    });
  std::sort(out.begin(), out.end());
  return out;
}

NodeId CutEngine::unit_node(NodeId live) {
  while (!coarse_.node_slot_alive(live.index)) (void)coarse_.add_node(Vec3::Zero());
  const NodeId u = coarse_.node_handle(live.index);
  coarse_.set_rest(u, mesh_.rest(live));
  coarse_.set_position(u, mesh_.position(live));
  return u;
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
    return last_touch_[t] + options_.finished_after_steps < step_count_ || last_touch_[t] < stroke_start_;
  };
  // A unit where the cut ends (a cut node in it has not opened): promoted, those nodes could not
  // open any more, and a new cut that starts there (Fig. 12) would stay joined to the old one. The
  // basic machine continues such a unit, unless the new cut crosses the old one there or another
  // unit of its component is promoted.
  auto at_boundary = [&](std::uint32_t t) {
    return cut_tets_.at(t).any_cut_node(
        [&](std::uint32_t id) { return opens(id) && !cut_nodes_[id].opened; });
  };
  for (const auto& [seed, crosses] : units) {
    if (refused.count(seed) || !cut_tets_.count(seed) || (!crosses && at_boundary(seed))) continue;
    const std::vector<std::uint32_t> comp = cut_component(seed);
    std::vector<std::uint32_t> part, rest;
    for (const std::uint32_t t : comp) (left_behind(t) ? part : rest).push_back(t);
    bool too_deep = false;
    for (const std::uint32_t t : part) too_deep |= level_[t] >= options_.max_recursion_depth;
    if (!left_behind(seed) || too_deep) {
      refused.insert(comp.begin(), comp.end());
      if (left_behind(seed) && too_deep) ++stats.recursion_fallbacks;
      continue;
    }
    // Cut nodes of the promoted part; those the rest shares stay cut nodes there, pinned.
    std::set<std::uint32_t> ids, kept;
    for (const std::uint32_t t : part)
      cut_tets_.at(t).any_cut_node([&](std::uint32_t id) {
        ids.insert(id);
        return false;
      });
    for (const std::uint32_t t : rest)
      cut_tets_.at(t).any_cut_node([&](std::uint32_t id) {
        if (ids.count(id)) {
          kept.insert(id);
          cut_nodes_[id].pinned = true;
        }
        return false;
      });
    for (const std::uint32_t t : part) seal(t, rest);
    // The crack faces stay part of the cut surface.
    for (const CrackFace& f : crack_faces(part))
      retired_crack_faces_.push_back(face_without(cut_tets_.at(f.unit).real[f.sub], f.face));
    for (const std::uint32_t t : part) {
      const CoarseTet c = std::move(cut_tets_.at(t));
      cut_tets_.erase(t);
      const TetId unit = coarse_.tet_handle(t);
      const int region = coarse_.region(unit);
      const std::uint8_t level = static_cast<std::uint8_t>(level_[t] + 1);
      sweep_->on_tet_removed(t);
      coarse_.remove_tet(unit);
      for (std::size_t s = 0; s < c.live.size(); ++s) {
        std::array<NodeId, 4> nodes{};
        for (int i = 0; i < 4; ++i)
          nodes[static_cast<size_t>(i)] = unit_node(c.real[s][static_cast<size_t>(i)]);
        const TetId child = coarse_.add_tet(nodes, region);
        if (unit_live_.size() <= child.index) {
          unit_live_.resize(child.index + 1, kInvalidIndex);
          level_.resize(child.index + 1, 0);
          last_touch_.resize(child.index + 1, 0);
        }
        unit_live_[child.index] = c.live[s].index;
        level_[child.index] = level;
        last_touch_[child.index] = 0;
        live_to_coarse_[c.live[s].index] = child.index;
        sweep_->on_tet_added(child.index);
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
      auto& map = n.kind == CutNode::Kind::Edge  ? edge_nodes_
                  : n.kind == CutNode::Kind::Mid ? mid_nodes_
                                                 : entry_nodes_;
      const auto it = map.find(n.key);
      if (it != map.end() && it->second == id) map.erase(it);
      if (n.kind == CutNode::Kind::Mid) crossing_faces_.erase(n.key);
      n.crossing = false;
    }
    // Seals whose unit has been promoted now are lifted.
    std::erase_if(seals_, [&](const auto& s) { return coarse_tets_around(s.second).empty(); });
    ++stats.recursions;
    if (!rest.empty()) ++stats.stroke_recursions;
    stats.promoted_tets += part.size();
    refused.insert(rest.begin(), rest.end());
    any = true;
  }
  return any;
}

// Seals the faces and edges of unit `t` (about to be promoted) that a unit of `rest` holds whole
// while `t`'s subdivision splits them: those holding cut data. Each of their pieces in `t`'s
// subdivision is sealed with them.
void CutEngine::seal(std::uint32_t t, const std::vector<std::uint32_t>& rest) {
  const CoarseTet& c = cut_tets_.at(t);
  const auto& v = coarse_.tet_vertex_indices(t);
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
    add_seal(edge_key(a, b), outer);
    add_seal(edge_key(b, d), outer);
    add_seal(edge_key(a, d), outer);
  };
  for (int f = 0; f < 4; ++f) {
    const auto fv = face_vertex_indices(coarse_, t, f);
    const Key3 face = sorted_key(fv[0], fv[1], fv[2]);
    const bool cut = face_node(mid_nodes_, face) != kInvalidIndex ||
                     face_node(entry_nodes_, face) != kInvalidIndex || face_has_edge_node(face);
    if (!cut || !held_by_rest(face)) continue;
    add_seal(face, face);
    seal_edges(face[0], face[1], face[2], face);
    for (std::size_t s = 0; s < c.subs.size(); ++s)
      for (int j = 0; j < 4; ++j) {
        const auto g = face_without(c.subs[s], j);
        if (!lies_on(g[0], face) || !lies_on(g[1], face) || !lies_on(g[2], face)) continue;
        const auto r = face_without(c.real[s], j);
        add_seal(sorted_key(r[0].index, r[1].index, r[2].index), face);
        seal_edges(r[0].index, r[1].index, r[2].index, face);
      }
  }
  for (const auto& ev : kEdgeVertices) {
    const Key3 edge = edge_key(v[static_cast<size_t>(ev[0])], v[static_cast<size_t>(ev[1])]);
    if (edge_node(edge[0], edge[1]) == kInvalidIndex || !held_by_rest(edge)) continue;
    add_seal(edge, edge);
    for (std::size_t s = 0; s < c.subs.size(); ++s)
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j)
          if (lies_on(c.subs[s][static_cast<size_t>(i)], edge) &&
              lies_on(c.subs[s][static_cast<size_t>(j)], edge))
            add_seal(
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
  const auto& x = coarse_.positions();
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

void CutEngine::add_seal(const Key3& key, const Key3& outer) {
  seals_.emplace(key, outer);
}

bool CutEngine::has_seal(const Key3& key) const {
  const auto it = seals_.lower_bound({key, Key3{}});
  return it != seals_.end() && it->first == key;
}

bool CutEngine::sealed(const Key3& key) const {
  for (auto it = seals_.lower_bound({key, Key3{}}); it != seals_.end() && it->first == key; ++it)
    if (!coarse_tets_around(it->second).empty()) return true;
  return false;
}

std::string CutEngine::check_faithful(double tolerance) const {
  std::string out;
  for (std::size_t id = 0; id < cut_nodes_.size(); ++id) {
    const CutNode& n = cut_nodes_[id];
    const int count = n.kind == CutNode::Kind::Edge ? 2 : 3;
    Vec3 expect = Vec3::Zero();
    double sum = 0.0, lo = 1.0;
    for (int i = 0; i < count; ++i) {
      expect += n.bary[i] * mesh_.rest(mesh_.node_handle(n.key[static_cast<size_t>(i)]));
      sum += n.bary[i];
      lo = std::min(lo, n.bary[i]);
    }
    const bool weights_ok = lo > 0.0 && std::abs(sum - 1.0) <= 1e-12 && (count == 3 || n.bary[2] == 0.0);
    for (const NodeId c : n.copies) {
      const double d = (mesh_.rest(c) - expect).norm();
      if (weights_ok && d <= tolerance) continue;
      out += "cut node " + std::to_string(id) + " (node " + std::to_string(c.index) + "): off its parent " +
             (count == 2 ? "edge" : "face") + " by " + std::to_string(d) + " m, weights (" +
             std::to_string(n.bary[0]) + ", " + std::to_string(n.bary[1]) + ", " + std::to_string(n.bary[2]) +
             ")\n";
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
