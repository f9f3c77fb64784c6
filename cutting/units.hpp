// The units (paper sections 3 and 6): the tetrahedra the state machine works on. They are a mesh of
// their own, which starts as the original mesh and goes one level deeper where the recursive
// continuation promotes a cut's live sub-tetrahedra to units. Unit node slots mirror live node slots
// (a promoted sub-tetrahedron keeps its live nodes), so a unit's corners are live nodes and its
// faces and edges are named by the same slots in both meshes.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

class Units {
 public:
  // The units of `original`, each standing for the live element of its slot, at level 0.
  explicit Units(const TetMesh& original);

  [[nodiscard]] const TetMesh& mesh() const { return mesh_; }
  // Takes the current positions of the live mesh (the tissue moved the nodes).
  void follow(const TetMesh& live);

  // The live element of a unit the blade has not cut (its slot in the live mesh).
  [[nodiscard]] std::uint32_t live(std::uint32_t unit) const { return live_[unit]; }
  // How many promotions deep a unit lies (0: a tetrahedron of the original mesh).
  [[nodiscard]] int level(std::uint32_t unit) const { return level_[unit]; }
  // The last step whose sweep touched a unit (CutOptions::finished_after_steps).
  [[nodiscard]] std::uint64_t last_touch(std::uint32_t unit) const { return last_touch_[unit]; }
  void touch(std::uint32_t unit, std::uint64_t step) { last_touch_[unit] = step; }

  // Promotion (§6): removes a unit, then adds its live sub-tetrahedra as units one level deeper.
  void remove(std::uint32_t unit);
  // Removes the unit node mirroring live node slot `live`, if there is one (no unit may use it).
  void remove_node(std::uint32_t live);
  // A unit on the live element `live` (slot) with live nodes `nodes`, in `region`, at `level`;
  // returns its slot.
  std::uint32_t add(const TetMesh& live_mesh, const std::array<NodeId, 4>& nodes, std::uint32_t live,
                    int region, int level);

 private:
  // The unit node mirroring live node `live` (same slot), created on first use.
  NodeId node_of(const TetMesh& live_mesh, NodeId live);

  TetMesh mesh_;
  // By unit slot.
  std::vector<std::uint32_t> live_;
  std::vector<std::uint8_t> level_;
  std::vector<std::uint64_t> last_touch_;
};

}  // namespace scalpel
