// Progressive cutting of a tetrahedral mesh (paper §3-4, docs/state_machine.md).
//
// The engine keeps the original ("coarse") tetrahedra as the units the state machine works on. A
// coarse tetrahedron that the blade has touched is replaced in the live mesh by its subdivision,
// which is a function of the cut data on its edges and faces only:
//   - a cut edge holds one EdgeNode at parameter t (two or more real copies once the crack opens);
//   - a face holds a MidNode (the ENP of §4.1 while the blade crosses the face; afterwards left at
//     the averaged position of its sampled trajectory, §5.2) and optionally an EntryNode where the
//     tip pierced it.
// Face and edge data are shared by every tetrahedron that has the face or edge, so neighbours
// always agree on how a face is triangulated (docs/architecture.md).
//
// Subdivision rule: the program of the lookup-table script (config/cutting/state_machine.cut), run in
// the reference labels of the tetrahedron's canonical state through its absolute transformation:
// stellar splits, entry nodes, then mid nodes, then edge nodes. Each split replaces one vertex of a
// sub-tetrahedron by a point strictly inside a face or edge of it, which keeps every sub-tetrahedron
// positively oriented for any position of the cut nodes inside their faces and edges: a mid node can slide
// with the blade without re-meshing and without ever inverting an element.
//
// Opening the crack (the paper's virtual nodes, §4.1): a crack face is a sub-tetrahedron face whose
// three vertices are cut nodes. Around each cut node the sub-tetrahedra that contain it are grouped
// by face adjacency that does not cross a crack face; each group references its own real copy of
// the node. While the cut surface does not yet surround a node, its sub-tetrahedra form one group
// and the crack stays closed there; when the blade has passed, the groups separate. This re-points
// exactly the elements on one side, as the virtual nodes do, without a search outside the star of
// the node.
//
// Recursive continuation (§6): the units are a mesh of their own (`coarse()`), which starts as the
// original mesh and can go deeper. When a stroke reaches a cut it has left behind with an event the
// basic machine cannot represent there (a new surface in a unit whose subdivision is final, a
// second crossing of a cut edge or face by another surface), that cut's component (its cut units
// and all units sharing its cut nodes) is promoted: its live sub-tetrahedra become units one level
// deeper, its cut nodes their corners (the interconnection nodes), its crack a boundary between
// them, and collision runs again on them before the step goes on. The live mesh does not change,
// so the tissue model sees nothing. A component the stroke is still cutting is promoted only where
// the blade has left it; the cut nodes it shares with the rest are pinned and the faces and edges
// between the two parts sealed, which keeps the live mesh conforming (see promote()). The recursion
// ends: each pass promotes other units one level deeper, up to CutOptions::max_recursion_depth,
// beyond which the one-level subdivision is kept (valid, not exact). Around the blade a re-crossing
// of the stroke's own cut is tremble or a reversal (§5), handled by the basic machine.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/flat_set.hpp"
#include "cutting/blade_sweep.hpp"
#include "cutting/crack.hpp"
#include "cutting/cut_changes.hpp"
#include "cutting/cut_nodes.hpp"
#include "cutting/cut_state.hpp"
#include "cutting/cut_table.hpp"
#include "cutting/seals.hpp"
#include "cutting/subdivision.hpp"
#include "cutting/units.hpp"
#include "cutting/virtual_nodes.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

struct CutOptions {
  // Cut nodes are kept this far (relative) from the vertices of their edge or face, so that no
  // element degenerates to zero volume when the blade passes exactly through a vertex: edge
  // parameter t is clamped to [min_edge_param, 1 - min_edge_param], face barycentrics to at least
  // min_face_bary. Small enough that a planar cut stays planar to far below the volume tolerance
  // of docs/invariants.md; the remaining slivers are the tissue model's to condition (docs/tissue.md).
  double min_edge_param = 1e-6;
  double min_face_bary = 1e-6;
  // Recursive continuation (§6). A new surface in a tetrahedron whose subdivision is final, or a second
  // crossing of a cut edge or face by a different surface, continues the cut on the sub-tetrahedra:
  // they become units of their own, one level deeper. Beyond this depth the one-level subdivision
  // is kept (the fallback), which leaves a valid mesh but cannot follow the second surface exactly.
  int max_recursion_depth = 8;
  // Two crossings of one edge or face belong to the same cut surface (tremble, pulling back, a
  // re-cut along the same path) when their swept-surface normals differ by at most this angle and
  // the new crossing lies within `same_cut_distance` (relative to the edge or face size) of the old
  // surface's tangent plane. Below that the mesh cannot resolve two surfaces anyway.
  double same_cut_angle_deg = 30.0;
  double same_cut_distance = 0.5;
  // The same for a cut node an earlier stroke made (a stroke: one contact of the blade with the
  // tissue, from the first step whose sweep touches it to the first that touches nothing, or
  // place()). A second incision crossing the first at a small angle lies within the tolerances
  // above near the line where they meet, and would be taken there for the first one continued:
  // the pieces between them stayed joined. Tremble and reversals (§5) are the stroke's own.
  double earlier_cut_angle_deg = 2.0;
  double earlier_cut_distance = 0.02;
  // along_former_cut(): a crossing runs along an opened surface of a promoted cut only where the
  // blade's swept surface is within this angle of it (and within same_cut_distance).
  double along_cut_angle_deg = 10.0;
  // A cut tetrahedron is left behind, and a stroke reaching it again continues it recursively, once
  // the blade has not touched it for this many steps, or since place(). Within that time a tremor or
  // a pull-back that leaves and re-enters the cut is the basic machine's (§5) (1 kHz tool samples: a
  // quarter second, two periods of a 9 Hz tremor).
  std::uint64_t finished_after_steps = 250;
  // The state machine's table; null: the bundled config/cutting/state_machine.cut.
  const CutTable* table = nullptr;
};

// A point in the tissue, on the tetrahedron of the original mesh it lies in: that tetrahedron's
// slot, its corners (live nodes, never cut nodes) and the point's barycentric weights on them.
struct TetLocation {
  std::uint32_t original = 0;
  std::array<NodeId, 4> corners{};
  std::array<double, 4> weights{};  // >= 0, sum 1
};

// What one tool sample did.
struct CutStepStats {
  std::size_t edges_cut = 0;            // forward crossings that split an edge
  std::size_t backward_crossings = 0;   // crossings by the blunt side (Eq. 1): registered, not cut
  std::size_t replaced_crossings = 0;   // forward crossings of registered edges (§5, Fig. 9)
  std::size_t recrossed_edges = 0;      // crossings of an edge already cut (recursive case, §6)
  std::size_t recrossed_faces = 0;      // pierces or crossings of a face already cut through (§6)
  std::size_t face_pierces = 0;         // entry nodes created
  std::size_t undone_faces = 0;         // face subdivisions undone by tremble (§5.1)
  std::size_t recursions = 0;           // cut components whose sub-tetrahedra became units (§6)
  std::size_t promoted_tets = 0;        // units replaced by their sub-tetrahedra
  std::size_t recursion_fallbacks = 0;  // components at the depth bound that kept their subdivision
  std::size_t stroke_recursions = 0;    // of `recursions`: the part the stroke has left, within a stroke
  std::size_t sealed_events = 0;        // crossings of a sealed face or edge, ignored (§6 fallback)
  std::size_t final_pierces = 0;        // tip pierces into a unit whose cut is final, ignored (§4.4)
  int recursion_depth = 0;              // deepest level of the units created this step
  std::size_t tets_created = 0;
  std::size_t tets_removed = 0;
  std::size_t nodes_created = 0;
  std::size_t transitions = 0;   // coarse tetrahedra whose state changed (once per step each)
  std::size_t tets_touched = 0;  // coarse tetrahedra the sweep touched
};

struct CutTotals {
  std::size_t steps = 0;
  std::size_t edges_cut = 0, backward_crossings = 0, replaced_crossings = 0, recrossed_edges = 0,
              recrossed_faces = 0, face_pierces = 0, undone_faces = 0;
  std::size_t recursions = 0, promoted_tets = 0, recursion_fallbacks = 0, stroke_recursions = 0,
              sealed_events = 0, final_pierces = 0;
  int max_recursion_depth = 0;
  std::size_t tets_created = 0, tets_removed = 0, nodes_created = 0;
  std::size_t coarse_tets_cut = 0;
  // Changes of state, by full state (MachineState::key() of the state before and after the step):
  // what tests hold against the table's machine. By label: CutEngine::transitions_by_label().
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> state_transitions;
  void add(const CutStepStats& s);
};

class CutEngine {
 public:
  // The mesh as it is now becomes the coarse mesh. The engine keeps a reference to `mesh`.
  explicit CutEngine(TetMesh& mesh, CutOptions options = {});
  ~CutEngine();
  CutEngine(const CutEngine&) = delete;
  CutEngine& operator=(const CutEngine&) = delete;

  // Places the blade without cutting (the first sample of a session, or after the tool jumped).
  void place(const BladePose& pose);
  // Sweeps the blade from its last pose to `pose` and applies every event (§3 pseudo code).
  CutStepStats step(const BladePose& pose);
  // Puts coarse tetrahedron `coarse_slot` into a state without a blade (for the exhaustive table
  // test and tools): its cut edges at fixed parameters, mid and entry nodes at fixed barycentric
  // points; every face around a cut edge gains a mid node, as in a real cut. With `complete`, the
  // blade counts as having left.
  CutStepStats impose(std::uint32_t coarse_slot, const CutTopology& local, bool complete);
  // Call after the tissue model moved nodes: refits the collision structure to current positions.
  void refit();
  // Call instead of refit() after the tissue model moved nodes under the blade: refits, and cuts
  // what moved into the blade's edge (the blade's motion relative to the tissue, see the source).
  // changes() then holds what it changed. Within the stroke; not a tool sample.
  CutStepStats follow_tissue();
  // The last sweep touched the tissue: the stroke goes on.
  [[nodiscard]] bool in_contact() const { return in_contact_; }
  // Deletes a piece the cuts have severed (sculpting, paper section 7.3): `live_tets` (live slots)
  // must be every element of a part of the live mesh that shares no node with the rest, and the
  // blade must be out of the tissue (std::logic_error otherwise). The cut components reaching into
  // it are promoted (§6) first, so that each of its elements is a unit of its own; then its units,
  // elements and nodes are removed. Whatever the piece shared a cut unit with stays cut where it
  // was, one level deeper (past CutOptions::max_recursion_depth if need be). changes() holds the
  // removed elements. Returns the piece's rest volume [m^3], by which rest_volume() drops.
  double remove_piece(std::span<const std::uint32_t> live_tets);
  // [m^3] The rest volume every cut step keeps (invariant 4): the mesh's at construction, less the
  // pieces removed.
  [[nodiscard]] double rest_volume() const { return coarse_volume_; }

  [[nodiscard]] const CutTotals& totals() const { return totals_; }
  // CutTotals::state_transitions by the script's labels: "A0->B0": count.
  [[nodiscard]] std::map<std::string, std::size_t> transitions_by_label() const;
  [[nodiscard]] const TetMesh& coarse() const { return units_.mesh(); }
  // The state of a coarse tetrahedron (by slot): topology in local labels, or empty topology.
  [[nodiscard]] CutTopology topology(std::uint32_t coarse_slot) const;
  // Its state: the canonical topology and the absolute transformation (reference label i is local
  // vertex transform.p[i]).
  [[nodiscard]] CanonicalState state(std::uint32_t coarse_slot) const;
  [[nodiscard]] std::string state_label_of(std::uint32_t coarse_slot) const;
  [[nodiscard]] int state_code_of(std::uint32_t coarse_slot) const;  // CutTable::label_code()
  // The coarse tetrahedron a live tetrahedron belongs to (itself if never cut).
  [[nodiscard]] std::uint32_t coarse_of(TetId live) const;
  // Number of live sub-tetrahedra per cut coarse tetrahedron, for statistics.
  [[nodiscard]] std::vector<std::size_t> subdivision_sizes() const;
  // What the last step changed; moved nodes are mid nodes that slid with the blade, whose
  // elements need their rest data refreshed.
  [[nodiscard]] const CutChanges& changes() const { return changes_; }
  // Rest positions of the points the cut has reached: edge cut points and entry nodes (the tip's
  // path), in the order they were made (for task scoring).
  [[nodiscard]] std::vector<Vec3> cut_points() const { return cut_nodes_.cut_points(); }
  // Where point p is in the tissue, current configuration: none outside it or in an opened crack
  // wider than 2 `margin` [m] (a blade on its own cut lies on the crack faces, which may have
  // parted by a fraction of its thickness). Weights are on the corners of the original tetrahedron
  // (before any cut) that holds p, which carry the mass and stiffness of their neighbourhood,
  // unlike cut nodes; where cutting has deformed it so that it no longer encloses p, negative
  // weights are clamped. Where a removed piece (remove_piece()) took some of those corners, the
  // weights are on the corners of the live element holding p. Costs a tree descent (positions as of the last
  // refit()).
  [[nodiscard]] std::optional<TetLocation> locate(const Vec3& p, double margin = 0.0) const;
  // Cut-surface area [m^2] in the current configuration: sum of crack faces on one side.
  [[nodiscard]] double cut_surface_area() const;
  // The cut surface's triangles on one side (the live nodes of one lip), the faces that area sums.
  [[nodiscard]] std::vector<std::array<NodeId, 3>> cut_surface_faces() const {
    return crack_.cut_surface_faces();
  }
  // Each cut node (a point the cut surface passes through, in the order made) with its rest
  // position and the real copies live elements use: one while the crack is closed there, one per
  // side once it has opened (the lips of the wound).
  struct CutNodeCopies {
    Vec3 rest = Vec3::Zero();
    std::vector<NodeId> copies;
  };
  [[nodiscard]] std::vector<CutNodeCopies> cut_node_copies() const;
  // Invariant 5 (docs/invariants.md): every copy of every cut node lies, in the rest configuration,
  // on its parent coarse edge or face at non-negative weights summing to one (edge nodes strictly
  // inside their edge, face nodes inside their face). Returns one line per violation, empty if
  // none; `tolerance` [m] on the distance from the weighted parent point. A promoted cut node whose
  // edge or face lost a node to a removed piece has no parent left and is not checked.
  [[nodiscard]] std::string check_faithful(double tolerance) const {
    return cut_nodes_.check_faithful(tolerance);
  }

 private:
  // Sweeps the blade from its last pose to `pose` and applies every event; `tool_moved`: a tool
  // sample (false: the tissue moved under the blade).
  CutStepStats sweep_to(const BladePose& pose, bool tool_moved);
  // What the events of one step touch, for the stages after them. One instance, cleared at each
  // step: its storage is reused.
  struct StepEvents {
    FlatSet<std::array<std::uint32_t, 3>> changed_faces;     // topology (mid or entry node) is new
    FlatSet<std::array<std::uint32_t, 3>> positioned_faces;  // mid node to be placed again
    FlatSet<std::uint32_t> affected;                         // coarse tetrahedra to subdivide again
    std::vector<std::array<std::uint32_t, 3>> new_edges;     // edges that gained an edge node
    FlatSet<std::array<std::uint32_t, 3>> sealed_now;        // sealed faces and edges crossed
    FlatSet<std::array<std::uint32_t, 3>> tip_left;          // faces the tip left by the way it came
    FlatSet<std::array<std::uint32_t, 3>> crossing_now;      // faces the blade crosses
    FlatSet<std::uint32_t> left_faces_tets;  // tetrahedra of faces the blade left: maybe complete now
    void clear();
  };
  // The order in which edge_events() and pierce_events() take the sweep's events; their scratch.
  struct SweepOrder {
    std::vector<const EdgeCut*> edges;  // the sweep's edge crossings by u; empty between steps
    // The sweep's pierces by face key (sorted, sweep order within a face).
    struct Pierce {
      std::array<std::uint32_t, 3> face;
      std::uint32_t tet;
      bool entering;
      Vec3 point;
      std::uint32_t order;  // in the sweep
    };
    std::vector<Pierce> pierced;
  };
  // The stages of sweep_to(): the sweep and the continuation's passes, then each kind of event.
  void collide(const BladePose& prev, const BladePose& pose, bool tool_moved, CutStepStats& stats);
  void edge_events(const BladePose& prev, const BladePose& pose, StepEvents& ev, CutStepStats& stats);
  void pierce_events(StepEvents& ev, CutStepStats& stats);
  void crossing_events(const BladePose& prev, const BladePose& pose, StepEvents& ev, CutStepStats& stats);
  void tremble_at_faces(StepEvents& ev, CutStepStats& stats);
  void place_face_nodes(StepEvents& ev);
  // A crossing of a sealed face or edge is ignored (§6); counted once per step.
  bool skip_sealed(const std::array<std::uint32_t, 3>& key, StepEvents& ev) const;
  Vec3 face_bary(const std::array<std::uint32_t, 3>& key, const Vec3& point) const;
  // Calls f(unit slot, p's barycentric weights in it) for the units whose corners enclose p
  // (positions as of the last refit(); a point on a shared face is in either), until f returns
  // true; returns whether it did.
  template <class F>
  bool for_units_at(const Vec3& p, F&& f) const;
  // Returns how many real nodes it removed (copies no element uses any more).
  std::size_t commit(const FlatSet<std::uint32_t>& affected, const FlatSet<std::uint32_t>& left_faces_tets,
                     CutStepStats& stats);
  // The coarse tetrahedra holding a face or an edge (key {a, b, kInvalidIndex}): f(slot) for each,
  // in no particular order; coarse_tets_around() sorted.
  template <class F>
  void for_coarse_tets_around(const std::array<std::uint32_t, 3>& key, F&& f) const;
  std::vector<std::uint32_t> coarse_tets_around(const std::array<std::uint32_t, 3>& key) const;
  void coarse_tets_around(const std::array<std::uint32_t, 3>& key, std::vector<std::uint32_t>& out) const;
  // Whether a unit holding `face` is in an end state whose crack has opened wherever it can (§4.4).
  bool into_final(const std::array<std::uint32_t, 3>& face) const;
  // Faces of the coarse mesh holding an edge (key {a, b, kInvalidIndex}), sorted.
  std::vector<std::array<std::uint32_t, 3>> faces_around_edge(const std::array<std::uint32_t, 3>& key) const;

  // Recursive continuation (§6). The cut units that the sweep in `sweep_result_` reaches with an
  // event the basic machine cannot represent: a new surface in a unit whose subdivision is final,
  // or (true) a second crossing of a cut edge or face by another surface.
  std::map<std::uint32_t, bool> recursive_units(const BladePose& prev, const BladePose& pose) const;
  // The cut units that share cut nodes with `t`, transitively: what must change level together.
  std::vector<std::uint32_t> cut_component(std::uint32_t t) const;
  // Makes the sub-tetrahedra of every promotable component of `units` units of their own;
  // returns whether any was. Components that cannot be promoted join `refused` (counted once).
  bool promote(const std::map<std::uint32_t, bool>& units, std::set<std::uint32_t>& refused,
               CutStepStats& stats);
  void promote_part(const std::vector<std::uint32_t>& part, const std::vector<std::uint32_t>& rest,
                    CutStepStats& stats);
  // Seals the faces and edges of `unit`, about to be promoted, that a unit of `rest` holds whole.
  void seal(std::uint32_t unit, const std::vector<std::uint32_t>& rest);
  // Whether an edge crossing runs along an opened cut surface that holds both of the edge's ends,
  // promoted cut nodes of one surface (by same_cut()): a blade retracing a cut continued one level
  // deeper, which must not cut beside it.
  bool along_former_cut(const EdgeCut& e, const BladePose& prev, const BladePose& pose) const;
  // Whether a crossing at `point` with swept-surface normal `normal` lies on the surface a cut node
  // of stroke `stroke` was cut with (at `old_point`, `old_normal`): within same_cut_angle_deg and
  // same_cut_distance for the current stroke, earlier_cut_angle_deg and earlier_cut_distance for an
  // earlier one.
  bool same_cut(const Vec3& old_point, const Vec3& old_normal, const Vec3& point, const Vec3& normal,
                double size, std::uint64_t stroke) const;
  bool near_surface(const Vec3& old_point, const Vec3& old_normal, const Vec3& point, const Vec3& normal,
                    double size, double angle_deg, double distance) const;
  Vec3 face_sheet_normal(const std::array<std::uint32_t, 3>& key) const;

  TetMesh& mesh_;  // the live mesh
  CutOptions options_;
  const CutTable& table_;
  double coarse_volume_;  // [m^3] rest volume of the coarse mesh: every step keeps it (invariant 4)

  // The rooms of the paper's sections, each owning its data (docs/README.md).
  Units units_;                 // the tetrahedra the state machine works on (§3, §6)
  CutChanges changes_;          // what the current step changed in the live mesh
  CutNodes cut_nodes_;          // the cut's edge, mid and entry nodes (§4.1, §5, §5.2)
  Subdivision subdivision_;     // of a unit from its cut nodes (§4.2, §4.4)
  Crack crack_;                 // the cut units, their live elements and the cut surface (§4.1)
  Seals seals_;                 // between the promoted and the still cut part of a stroke (§6)
  VirtualNodes virtual_nodes_;  // the copies of cut nodes on either side of the crack (§4.1)
  // Promoted cut nodes, now corners of units, by node slot of each copy: the cut node (§6).
  std::unordered_map<std::uint32_t, std::uint32_t> former_;

  // The blade and its strokes (§3).
  std::unique_ptr<BladeSweep> sweep_;
  SweepResult sweep_result_;
  BladePose blade_{};
  bool placed_ = false;
  std::uint64_t step_count_ = 0, stroke_start_ = 0;
  std::uint64_t stroke_ = 0;     // the current stroke (see CutOptions::earlier_cut_angle_deg)
  bool in_contact_ = false;      // the last sweep touched the tissue: the stroke goes on
  Vec3 heading_ = Vec3::Zero();  // the blade's last motion across itself, unit (follow_tissue())
  std::vector<std::array<std::uint32_t, 4>> original_;  // by slot: the tetrahedra at construction (locate())
  std::vector<std::uint8_t> original_removed_;  // by slot: a node of the original mesh remove_piece() took
  // Scratch of sweep_to() and commit(), kept to avoid allocating on every step.
  StepEvents step_events_;
  SweepOrder sweep_order_;
  struct {
    std::vector<std::pair<std::uint32_t, MachineState>> before;  // by unit, sorted: its state before the step
    FlatSet<std::uint32_t> regroup_ids, rebuild;
    std::vector<std::uint32_t> regrouped, copy_index;
    std::vector<NodeId> unused;
  } commit_scratch_;
  CutTotals totals_;
};

}  // namespace scalpel
