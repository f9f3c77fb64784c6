// The cut nodes (paper sections 4.1, 5 and 5.2): where they sit, how mid nodes slide with the
// blade and settle at the average of their samples, and how tremble takes them out again (5.1).
#include "cutting/cut_nodes.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "cutting/cut_engine_internal.hpp"

namespace scalpel {

using namespace cut_internal;

CutNodes::CutNodes(TetMesh& mesh, const TetMesh& coarse, CutChanges& changes, double min_face_bary)
    : mesh_(mesh), coarse_(coarse), changes_(changes), min_face_bary_(min_face_bary) {}

std::uint32_t CutNode::group(std::uint32_t coarse, std::uint32_t sub) const {
  const auto it = std::lower_bound(group_of.begin(), group_of.end(), GroupEntry{coarse, sub, 0});
  return it != group_of.end() && it->coarse == coarse && it->sub == sub ? it->group : 0;
}

std::uint32_t CutNodes::edge(std::uint32_t a, std::uint32_t b) const {
  return find(CutNodeKind::Edge, edge_key(a, b));
}

std::uint32_t CutNodes::mid(const Key& face) const {
  return find(CutNodeKind::Mid, face);
}

std::uint32_t CutNodes::entry(const Key& face) const {
  return find(CutNodeKind::Entry, face);
}

const std::map<CutNodes::Key, std::uint32_t>& CutNodes::map_of(CutNodeKind kind) const {
  return kind == CutNodeKind::Edge ? edges_ : kind == CutNodeKind::Mid ? mids_ : entries_;
}

std::uint32_t CutNodes::find(CutNodeKind kind, const Key& key) const {
  const auto& map = map_of(kind);
  const auto it = map.find(key);
  return it == map.end() ? kInvalidIndex : it->second;
}

std::map<CutNodes::Key, std::uint32_t>& CutNodes::map_of(CutNodeKind kind) {
  return const_cast<std::map<Key, std::uint32_t>&>(std::as_const(*this).map_of(kind));
}

// Places every copy of a cut node at its weights over the coarse nodes (docs/architecture.md: the
// cut is made in the current configuration and carried to the rest one by the same weights). The
// rest position is the weighted one. In the current configuration a copy goes where the tissue has
// put the material point of its new rest position: the piecewise-linear map of the live elements
// around it. So it keeps the displacement the tissue gave it, and sliding along the face leaves the
// field the elements interpolate as it was, up to re-interpolation. The coarse face's corners are no
// measure of that map once a crack or a strained element lies between them; they move only a copy
// no element holds yet.
void CutNodes::place(std::uint32_t id) {
  CutNode& n = nodes_[id];
  const int count = n.kind == CutNode::Kind::Edge ? 2 : 3;
  Vec3 r = Vec3::Zero(), dx_face = Vec3::Zero();
  for (int i = 0; i < count; ++i) {
    const NodeId p = mesh_.node_handle(n.key[static_cast<size_t>(i)]);
    r += n.bary[i] * mesh_.rest(p);
    dx_face += (n.bary[i] - n.placed_bary[i]) * mesh_.position(p);
  }
  const NodeParents parents = key_parents(mesh_, n.key, n.bary);
  for (const NodeId c : n.copies) {
    const std::optional<Vec3> x = current_position_of(c, r);
    mesh_.set_rest(c, r);
    mesh_.interpolate_fields(c, parents);
    mesh_.set_position(c, x ? *x : Vec3(mesh_.position(c) + dx_face));
    changes_.moved_nodes.push_back(c);
    changes_.touched_nodes.push_back(c.index);
  }
  n.placed_bary = n.bary;
}

// Where the live elements around real node c put rest point `rest` now: the element of c's star
// that holds it in the rest configuration (the one it is deepest in), interpolated at its current
// corners. None if c has no element of positive rest volume, or the point lies far outside them all.
std::optional<Vec3> CutNodes::current_position_of(NodeId c, const Vec3& rest) const {
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
void CutNodes::update_face_position(std::uint32_t id) {
  CutNode& n = nodes_[id];
  if (n.opened || n.pinned) return;  // the crack has opened here, or promoted units hold it
  const Key& k = n.key;
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
      const std::uint32_t en = edge(k[static_cast<size_t>(e[0])], k[static_cast<size_t>(e[1])]);
      if (en == kInvalidIndex) continue;
      Vec3 b = Vec3::Zero();
      b[e[0]] = nodes_[en].bary[0];  // key order of an edge is ascending, as in the face key
      b[e[1]] = nodes_[en].bary[1];
      ends.push_back(b);
      single_edge = en;
    }
    const std::uint32_t entry_id = entry(k);
    if (entry_id != kInvalidIndex) ends.push_back(nodes_[entry_id].bary);
    if (ends.size() >= 2) {
      w = Vec3::Zero();
      for (const auto& b : ends) w += b / static_cast<double>(ends.size());
    } else if (single_edge != kInvalidIndex) {
      // One cut edge: follow the swept surface's plane from the cut point across the face.
      const Vec3 start = ends[0];
      const Vec3 x = start[0] * pa + start[1] * pb + start[2] * pc;
      const Vec3& normal = nodes_[single_edge].sheet_normal;
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
  w = clamp_interior(w, min_face_bary_);

  // With an entry node on the face, the mid node lies in one of the three parts the entry node
  // cuts the face into; keep it clearly inside that part.
  const std::uint32_t entry_id = entry(k);
  if (entry_id != kInvalidIndex) {
    const Vec3 e = nodes_[entry_id].bary;
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
    best_local = clamp_interior(best_local, min_face_bary_);
    w = best_local[0] * e;
    w[(best + 1) % 3] += best_local[1];
    w[(best + 2) % 3] += best_local[2];
    n.entry_subtriangle = best;
  }
  n.bary = w;
  place(id);
}

bool CutNodes::face_has_edge_node(const Key& k) const {
  return edge(k[0], k[1]) != kInvalidIndex || edge(k[1], k[2]) != kInvalidIndex ||
         edge(k[0], k[2]) != kInvalidIndex;
}

void CutNodes::undo_face(const Key& k, bool with_mid) {
  const auto entry_it = entries_.find(k);
  if (entry_it != entries_.end()) {
    undone_.push_back(entry_it->second);
    entries_.erase(entry_it);
  }
  const std::uint32_t m = mid(k);
  if (m == kInvalidIndex) return;
  if (with_mid) {
    undone_.push_back(m);
    mids_.erase(k);
    crossing_.erase(k);
  } else {
    nodes_[m].entry_subtriangle = -1;
    update_face_position(m);
  }
}

// Removes the real nodes of undone cut nodes, which no element uses any more after the rebuild;
// returns how many.
std::size_t CutNodes::remove_undone() {
  if (undone_.empty()) return 0;
  std::vector<NodeId> dead;
  for (const std::uint32_t id : undone_) {
    CutNode& n = nodes_[id];
    for (const NodeId c : n.copies) {
      if (!mesh_.node_tets(c).empty()) throw std::logic_error("CutNodes: an undone cut node is still in use");
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
std::size_t CutNodes::remove_nodes(const std::vector<NodeId>& dead) {
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

std::uint32_t CutNodes::add(CutNodeKind kind, const Key& key, const Vec3& bary, std::uint64_t stroke) {
  auto& map = map_of(kind);
  if (map.count(key) != 0)
    throw std::logic_error("CutNodes::add: the face or edge holds a cut node of that kind already");
  const auto id = static_cast<std::uint32_t>(nodes_.size());
  CutNode n;
  n.kind = kind;
  n.key = key;
  n.bary = bary;
  n.copies.push_back(add_real_node(key_parents(mesh_, key, bary)));
  n.placed_bary = bary;  // the copy is interpolated at `bary`
  n.stroke = stroke;
  nodes_.push_back(std::move(n));
  map.emplace(key, id);
  return id;
}

NodeId CutNodes::add_real_node(const NodeParents& parents) {
  const NodeId n = mesh_.add_interpolated_node(parents);
  changes_.added_nodes.push_back(n);
  changes_.added_node_parents.push_back(parents);
  return n;
}

void CutNodes::forget(std::uint32_t id) {
  CutNode& n = nodes_[id];
  auto& map = map_of(n.kind);
  const auto it = map.find(n.key);
  if (it != map.end() && it->second == id) map.erase(it);
  if (n.kind == CutNodeKind::Mid) crossing_.erase(n.key);
  n.crossing = false;
}

void CutNodes::set_crossing(std::uint32_t mid_id, bool crossing) {
  CutNode& n = nodes_[mid_id];
  n.crossing = crossing;
  if (crossing) crossing_.insert(n.key);  // one that stops crossing leaves at update_crossings()
}

void CutNodes::update_crossings(const FlatSet<Key>& now) {
  for (const Key& k : crossing_)
    if (!now.contains(k)) nodes_[mids_.at(k)].crossing = false;  // settle at the averaged trajectory (§5.2)
  crossing_.clear();
  for (const Key& k : now)
    if (nodes_[mids_.at(k)].crossing) crossing_.insert(k);
}

void CutNodes::on_piece_removed(const std::vector<std::uint32_t>& removed) {
  for (std::uint32_t id = 0; id < nodes_.size(); ++id) {
    CutNode& n = nodes_[id];
    const std::size_t copies = n.copies.size();
    std::erase_if(n.copies, [&](NodeId c) { return !mesh_.alive(c); });
    // A cut node still in use indexes its copies by group: none of its copies may go.
    const auto it = map_of(n.kind).find(n.key);
    if (n.copies.size() != copies && it != map_of(n.kind).end() && it->second == id)
      throw std::logic_error("CutNodes::on_piece_removed: a removed piece held a copy of a cut node in use");
    for (const std::uint32_t k : n.key)
      if (std::binary_search(removed.begin(), removed.end(), k)) n.parent_removed = true;
  }
}

std::vector<Vec3> CutNodes::cut_points() const {
  std::vector<Vec3> out;
  for (const CutNode& n : nodes_)
    if (n.kind != CutNode::Kind::Mid && !n.copies.empty()) out.push_back(mesh_.rest(n.copies[0]));
  return out;
}

std::string CutNodes::check_faithful(double tolerance) const {
  std::string out;
  for (std::size_t id = 0; id < nodes_.size(); ++id) {
    const CutNode& n = nodes_[id];
    if (n.copies.empty() || n.parent_removed) continue;  // undone, or beside a removed piece
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

// A sub-tetrahedron face on the cut surface: three cut nodes, none crossed only by the blunt side.
// Faces with an entry node are the strip between the tip's path and the cut above it: without them
// the crack would end at the mid nodes half a face above the tip (§4.1, the cut surface reaches the
// tool). Entry nodes themselves never open (the surface ends there), and such a face must lie on one
// stroke's surface: an entry node beside a node of an earlier cut joins two surfaces that meet there
// only, and would free a chip neither encloses.
bool CutNodes::is_crack_face(GNode a, GNode b, GNode c) const {
  const CutNode* entry = nullptr;
  for (const GNode g : {a, b, c}) {
    if (!(g & kCutBit)) return false;
    const CutNode& n = nodes_[static_cast<std::uint32_t>(g & ~kCutBit)];
    if (n.registered) return false;
    if (n.kind == CutNode::Kind::Entry) entry = &n;
  }
  if (entry == nullptr) return true;
  for (const GNode g : {a, b, c})
    if (nodes_[static_cast<std::uint32_t>(g & ~kCutBit)].stroke != entry->stroke) return false;
  return true;
}

// Entry nodes lie on the tip's path, where the cut surface ends, and registered edge nodes were
// crossed only by the blunt side: neither ever separates.
bool CutNodes::opens(std::uint32_t id) const {
  const CutNode& n = nodes_[id];
  return n.kind != CutNode::Kind::Entry && !n.registered;
}

}  // namespace scalpel
