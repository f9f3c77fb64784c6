// Seals (paper section 6, the continuation within a stroke). When a stroke continues recursively
// in the part of a cut it has left while it still cuts the units beyond, the faces and edges between
// the two parts are split on the promoted side and held whole on the other. A crossing there would
// put a cut node on one side's triangulation only (a hanging node), so it is ignored while a unit
// still holds the face or edge whole; the seal lifts once that unit has been promoted too.
#pragma once

#include <array>
#include <cstdint>
#include <set>
#include <utility>

#include "mesh/mesh.hpp"

namespace scalpel {

class Seals {
 public:
  using Key = std::array<std::uint32_t, 3>;  // sorted node slots; an edge has kInvalidIndex third

  // `units`: the mesh of units (CutEngine::coarse()), whose node slots the keys name.
  explicit Seals(const TetMesh& units) : units_(units) {}

  // Seals the face or edge `key` while a unit holds the face or edge `outer` (which contains it)
  // whole. One key can be sealed by several (an edge of two sealed faces): it stays sealed while any
  // of them holds.
  void add(const Key& key, const Key& outer) { seals_.emplace(key, outer); }
  // Whether a crossing of `key` is to be ignored: a unit still holds whole a face or edge it was
  // sealed by.
  [[nodiscard]] bool sealed(const Key& key) const;
  // Whether `key` has a seal, held or not.
  [[nodiscard]] bool recorded(const Key& key) const;
  // Lifts the seals whose face or edge no unit holds whole any more (after a promotion).
  void lift_released();

 private:
  [[nodiscard]] bool held(const Key& outer) const;

  const TetMesh& units_;
  std::set<std::pair<Key, Key>> seals_;  // (key, outer)
};

}  // namespace scalpel
