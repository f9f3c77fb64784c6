// The cut nodes (paper sections 4.1, 5 and 5.2): the points where the cut surface meets the coarse
// mesh's edges (edge nodes) and faces (mid nodes, the ENP while the blade crosses the face, and
// entry nodes where the tip pierced it), found by the face or edge they lie on, with the real
// nodes of the live mesh that stand for them (one copy while the crack is closed there, one per
// side once it has opened). The store places every copy where its weights put it, lets a mid node
// slide with the blade and settle at the average of its samples, and takes a face's nodes out
// again when the tip trembles back (section 5.1). Which copy each sub-tetrahedron uses is the
// crack's business (VirtualNodes::regroup()); the store only keeps the answer.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "base/flat_set.hpp"
#include "cutting/cut_changes.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

enum class CutNodeKind : std::uint8_t { Edge, Mid, Entry };

// A node of a subdivision: a corner of its unit (a node slot of the units' mesh) or a cut node
// (kCutBit | its index in CutNodes).
using GNode = std::uint64_t;
inline constexpr GNode kCutBit = GNode{1} << 63;

// Which copy of a cut node sub-tetrahedron `sub` of unit `coarse` uses.
struct CutNodeGroup {
  std::uint32_t coarse, sub, group;  // group: the index into the cut node's copies
  friend bool operator<(const CutNodeGroup& a, const CutNodeGroup& b) {
    return a.coarse != b.coarse ? a.coarse < b.coarse : a.sub < b.sub;
  }
};

struct CutNode {
  using Kind = CutNodeKind;
  Kind kind = Kind::Edge;
  std::array<std::uint32_t, 3> key{};  // sorted coarse node slots; an edge has key[2] = kInvalidIndex
  Vec3 bary = Vec3::Zero();            // weights of the key nodes
  Vec3 placed_bary = Vec3::Zero();     // the weights its copies were last placed at
  std::uint32_t into = kInvalidIndex;  // entry node: the coarse tetrahedron the tip went into
  Vec3 sample_sum = Vec3::Zero();      // mid node: sum of sampled ENP barycentrics (§5.2)
  int samples = 0;
  bool crossing = false;             // mid node: the blade crosses the face now (CutNodes::set_crossing)
  bool registered = false;           // edge node crossed only backward so far (§5, Eq. 1)
  int entry_subtriangle = -1;        // mid node on a face with an entry node: which part holds it
  Vec3 sheet_normal = Vec3::Zero();  // normal of the swept surface where it was cut (last sample)
  std::uint64_t stroke = 0;          // the stroke that cut it (last sample)
  // Shared with units promoted within a stroke (§6): it stays where it is and gains no copy.
  bool pinned = false;
  // Promoted, and a removed piece took a node of its edge or face: no parent to hold it to any more
  // (it no longer moves either: promoted cut nodes are corners of units).
  bool parent_removed = false;
  std::vector<NodeId> copies;  // real nodes, one per group (group_of says which)
  // It has had two copies: the cut has gone through here, even where its groups joined again
  // and the copy no element used has gone.
  bool opened = false;
  using GroupEntry = CutNodeGroup;
  std::vector<GroupEntry> group_of;  // sorted by (coarse, sub)
  // The copy sub-tetrahedron `sub` of coarse tetrahedron `coarse` uses (0 if not grouped).
  [[nodiscard]] std::uint32_t group(std::uint32_t coarse, std::uint32_t sub) const;
};

class CutNodes {
 public:
  using Key = std::array<std::uint32_t, 3>;  // sorted node slots; an edge has kInvalidIndex third

  // `mesh`: the live mesh the copies are nodes of; `coarse`: the units, whose node slots the keys
  // name; `changes`: the step's record of added, moved and removed nodes. Face weights are kept at
  // least `min_face_bary` (CutOptions).
  CutNodes(TetMesh& mesh, const TetMesh& coarse, CutChanges& changes, double min_face_bary);

  // The cut node on an edge or face, or kInvalidIndex.
  [[nodiscard]] std::uint32_t edge(std::uint32_t a, std::uint32_t b) const;
  [[nodiscard]] std::uint32_t mid(const Key& face) const;
  [[nodiscard]] std::uint32_t entry(const Key& face) const;
  [[nodiscard]] bool face_has_edge_node(const Key& face) const;
  // The cut node of `kind` on `key` (an edge's key {a, b, kInvalidIndex}), or kInvalidIndex.
  [[nodiscard]] std::uint32_t find(CutNodeKind kind, const Key& key) const;
  // Whether cut node `id` can open: entry nodes lie on the tip's path, where the cut surface ends,
  // and registered edge nodes were crossed only by the blunt side; neither ever separates.
  [[nodiscard]] bool opens(std::uint32_t id) const;
  // Whether a face of a subdivision is cut surface (a crack face, §4.1).
  [[nodiscard]] bool is_crack_face(GNode a, GNode b, GNode c) const;
  // The entry nodes by face.
  [[nodiscard]] const std::map<Key, std::uint32_t>& entries() const { return entries_; }

  // Every cut node made, in the order made (undone ones keep their index, without copies).
  CutNode& operator[](std::uint32_t id) { return nodes_[id]; }
  const CutNode& operator[](std::uint32_t id) const { return nodes_[id]; }
  [[nodiscard]] std::size_t size() const { return nodes_.size(); }
  [[nodiscard]] auto begin() const { return nodes_.begin(); }
  [[nodiscard]] auto end() const { return nodes_.end(); }

  // A new cut node of `kind` on `key` (which holds none of that kind) with one real copy,
  // interpolated from its coarse nodes at weights `bary`; made by stroke `stroke`.
  std::uint32_t add(CutNodeKind kind, const Key& key, const Vec3& bary, std::uint64_t stroke);
  // A real node of the live mesh interpolated from `parents`, recorded in the step's changes.
  NodeId add_real_node(const NodeParents& parents);
  // Takes a cut node out of the lookup by face or edge: its units were promoted (§6), and its
  // copies are now their corners. It keeps its index and copies.
  void forget(std::uint32_t id);
  // After a piece was removed (CutEngine::remove_piece): drops the copies the live mesh no longer
  // has and marks the nodes whose edge or face lost a node of `removed` (sorted node slots). Call
  // only once every cut node touching the piece has been forgotten.
  void on_piece_removed(const std::vector<std::uint32_t>& removed);

  // Mid nodes of the faces the blade crosses now, which follow the blade (§4.1).
  [[nodiscard]] const FlatSet<Key>& crossing_faces() const { return crossing_; }
  // Sets whether a mid node's face is crossed; a face that stops being crossed stays among the
  // crossing faces until update_crossings() settles it.
  void set_crossing(std::uint32_t mid_id, bool crossing);
  // After a step's crossings: the faces in `now` whose mid node crosses are the crossing faces;
  // the mid nodes of the others settle (§5.2).
  void update_crossings(const FlatSet<Key>& now);

  // Places every copy of a cut node at its weights `bary` (rest and current position).
  void place(std::uint32_t id);
  // Where a mid node stands (§4.1, §5.2), then places it.
  void update_face_position(std::uint32_t id);
  // Takes the face's entry node (and its mid node, with `with_mid`) out of the cut data; their real nodes
  // are removed by remove_undone() once the step has rebuilt the elements around the face (§5.1).
  void undo_face(const Key& face, bool with_mid);
  // Removes the real nodes of the cut nodes undone this step; returns how many.
  std::size_t remove_undone();
  // Removes real nodes no element uses; returns how many.
  std::size_t remove_nodes(const std::vector<NodeId>& dead);

  // Rest positions of edge and entry nodes, in the order made (CutEngine::cut_points()).
  [[nodiscard]] std::vector<Vec3> cut_points() const;
  // Invariant 5 (CutEngine::check_faithful()).
  [[nodiscard]] std::string check_faithful(double tolerance) const;

 private:
  [[nodiscard]] std::optional<Vec3> current_position_of(NodeId c, const Vec3& rest) const;
  [[nodiscard]] std::map<Key, std::uint32_t>& map_of(CutNodeKind kind);
  [[nodiscard]] const std::map<Key, std::uint32_t>& map_of(CutNodeKind kind) const;

  TetMesh& mesh_;
  const TetMesh& coarse_;
  CutChanges& changes_;
  double min_face_bary_;
  std::vector<CutNode> nodes_;
  std::map<Key, std::uint32_t> edges_;    // key {a, b, kInvalidIndex}, a < b
  std::map<Key, std::uint32_t> mids_;     // key: sorted face slots
  std::map<Key, std::uint32_t> entries_;  // key: sorted face slots
  FlatSet<Key> crossing_;                 // faces the blade crosses now
  std::vector<std::uint32_t> undone_;     // cut nodes taken out this step, their copies to be removed
};

}  // namespace scalpel
