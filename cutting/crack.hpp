// The crack (paper section 4.1): the units the blade has cut, each with its state, its subdivision
// and the live elements that stand for it, built from the copies of the cut nodes the virtual nodes
// chose (VirtualNodes); the way back from a live element to its unit; and the cut surface, the faces
// of the subdivisions whose three nodes are cut nodes.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cutting/cut_changes.hpp"
#include "cutting/cut_nodes.hpp"
#include "cutting/subdivision.hpp"
#include "mesh/mesh.hpp"

namespace scalpel {

class Crack {
 public:
  using CutUnits = std::unordered_map<std::uint32_t, CutUnit>;  // by unit slot

  // `mesh`: the live mesh, whose elements rebuild() replaces (recorded in `changes`); `units`: the
  // mesh of units, whose live elements are at first the ones of the same slot.
  Crack(TetMesh& mesh, const TetMesh& units, const CutNodes& nodes, CutChanges& changes);

  // The cut units.
  [[nodiscard]] const CutUnits& units() const { return cut_; }
  [[nodiscard]] const CutUnit* find(std::uint32_t unit) const;
  [[nodiscard]] CutUnit* find(std::uint32_t unit);
  [[nodiscard]] const CutUnit& at(std::uint32_t unit) const { return cut_.at(unit); }
  [[nodiscard]] bool contains(std::uint32_t unit) const { return cut_.count(unit) != 0; }
  // A unit cut for the first time, standing in the live mesh as the single element `live`.
  CutUnit& start(std::uint32_t unit, TetId live);
  // Before the continuation promotes `units` (§6): their crack faces stay in the cut surface.
  void retire(const std::vector<std::uint32_t>& units);
  // Takes a unit out (promoted, §6).
  CutUnit take(std::uint32_t unit);

  // Replaces the live elements of a cut unit by those of its subdivision at the copies its cut
  // nodes' groups use; an element whose nodes did not change stays. Returns how many it created and
  // removed.
  struct Rebuilt {
    std::size_t created = 0, removed = 0;
  };
  Rebuilt rebuild(std::uint32_t unit);

  // The unit a live element belongs to (by live slot; kInvalidIndex if none).
  [[nodiscard]] std::uint32_t unit_of(std::uint32_t live_slot) const;
  void set_unit_of(std::uint32_t live_slot, std::uint32_t unit);

  // The cut surface's triangles on one side (one lip's real nodes), each once: the crack faces of
  // the cut units and those of units promoted since (on the lip still there where a piece has been
  // removed; none where both have).
  [[nodiscard]] std::vector<std::array<NodeId, 3>> cut_surface_faces() const;

 private:
  // Crack faces of the subdivisions of `units`, each once (face `face` of sub-tetrahedron `sub`).
  struct CrackFace {
    std::uint32_t unit, sub;
    int face;
  };
  [[nodiscard]] std::vector<CrackFace> crack_faces(const std::vector<std::uint32_t>& units) const;

  TetMesh& mesh_;
  const TetMesh& units_;
  const CutNodes& nodes_;
  CutChanges& changes_;
  CutUnits cut_;
  std::vector<std::uint32_t> unit_of_;  // by live tet slot
  // Crack faces of promoted units, for the cut surface: each lip's real nodes (the same twice where
  // the crack has not opened).
  std::vector<std::array<std::array<NodeId, 3>, 2>> retired_faces_;
  // Scratch of rebuild(), kept to avoid allocating on every step.
  struct {
    std::vector<std::array<NodeId, 4>> real;
    std::vector<std::pair<std::array<NodeId, 4>, std::size_t>> old_by_nodes;
    std::vector<TetId> live;
    std::vector<std::uint8_t> kept;
    std::vector<std::size_t> to_add;
  } scratch_;
};

}  // namespace scalpel
