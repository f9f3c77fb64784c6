// Subdivision (paper sections 4.2 and 4.4): a unit's state from the cut nodes on its edges and
// faces, and its sub-tetrahedra from the lookup table's program run in the reference labels of its
// canonical state through the absolute transformation, so that the 24 permutations of a state share
// one entry of the table. The subdivision is a function of the cut data alone: neighbours sharing a
// face triangulate it alike.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "cutting/cut_nodes.hpp"
#include "cutting/cut_state.hpp"
#include "cutting/cut_table.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

// A unit the blade has cut: its subdivision and the live elements that stand for it.
struct CutUnit {
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

class Subdivision {
 public:
  // `units`: the mesh of units; `nodes`: the cut nodes on their edges and faces; `table`: the
  // state machine's lookup table.
  Subdivision(const TetMesh& units, const CutNodes& nodes, const CutTable& table)
      : units_(units), nodes_(nodes), table_(table) {}

  // Which edges, faces and entry faces of `unit` hold cut nodes, in its local labels.
  [[nodiscard]] CutTopology topology(std::uint32_t unit) const;
  // The sub-tetrahedra of `unit` in `state` (the canonical form of topology(unit)): stellar splits
  // at its entry nodes, then its mid nodes, then its edge nodes, as the table's program says.
  void subdivide(std::uint32_t unit, const CanonicalState& state,
                 std::vector<std::array<GNode, 4>>& out) const;

 private:
  const TetMesh& units_;
  const CutNodes& nodes_;
  const CutTable& table_;
};

}  // namespace scalpel
