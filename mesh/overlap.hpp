// Whether tetrahedra of a mesh overlap: two tetrahedra whose interiors share a point. A mesh file can
// hold such pairs without breaking the invariants checked face by face (docs/invariants.md): two
// components laid over each other, or a mesh folded onto itself around a vertex. The cutter takes
// each for tissue of its own, so a cut through the overlap would cut both and open phantom pieces.
//
// Exact: two tetrahedra are apart when a plane separates them (touching allowed), and the
// separating-axis theorem needs only the planes of their faces and the planes spanned by an edge of
// each; the sides are decided by exact predicates (mesh/predicates.hpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

struct OverlapReport {
  std::size_t pairs = 0;  // overlapping pairs found
  // The first few pairs (tetrahedron slot indices, first < second): for a mesh read from a file,
  // the tetrahedra's order among the file's tetrahedra, from 0.
  std::vector<std::array<std::uint32_t, 2>> first;

  [[nodiscard]] bool ok() const { return pairs == 0; }
  // One line for people: the count and the first pair, with the tetrahedra's centres.
  [[nodiscard]] std::string summary(const TetMesh& mesh) const;
};

// Whether the interiors of two tetrahedra, given by their vertices in the rest configuration, share
// a point. Each tetrahedron must be non-degenerate (either orientation).
[[nodiscard]] bool tetrahedra_overlap(const std::array<Vec3, 4>& a, const std::array<Vec3, 4>& b);

// Every pair of live tetrahedra of `mesh` whose rest interiors overlap; at most `keep` of them are
// listed in `first`.
[[nodiscard]] OverlapReport check_overlaps(const TetMesh& mesh, std::size_t keep = 8);

}  // namespace scalpel
