// Topological cut state of a tetrahedron and its absolute transformation (paper §4.2, docs/state_machine.md).
//
// A state is the set of cut edges (6-bit mask over kEdgeVertices), the faces carrying a mid node
// (4-bit mask over local faces) and the faces carrying an entry node (4-bit mask). Symmetric states
// are one state: a tetrahedron stores the canonical representative and the permutation of S4 that
// maps the reference labels onto its own vertices. The 24 permutations and the canonical forms are
// computed, not tabulated.
#pragma once

#include <array>
#include <cstdint>

namespace scalpel {

// A permutation of the four vertex labels: perm[i] is the local vertex that reference vertex i maps to.
struct Perm4 {
  std::array<std::uint8_t, 4> p{0, 1, 2, 3};

  [[nodiscard]] static const std::array<Perm4, 24>& all();
  [[nodiscard]] Perm4 compose(const Perm4& then) const;  // (then ∘ this): apply this first
  [[nodiscard]] Perm4 inverse() const;
  [[nodiscard]] bool odd() const;  // odd permutations are mirrors (docs/state_machine.md)
  friend bool operator==(const Perm4&, const Perm4&) = default;
};

struct CutTopology {
  std::uint8_t edges = 0;    // bit e: local edge e is cut
  std::uint8_t faces = 0;    // bit f: local face f has a mid node
  std::uint8_t entries = 0;  // bit f: local face f has an entry node (the tip pierced it)
  friend bool operator==(const CutTopology&, const CutTopology&) = default;
};

// The topology seen through a permutation: reference element i of the result is element perm(i).
[[nodiscard]] CutTopology permute(const CutTopology& t, const Perm4& perm);
// Local edge joining local vertices a and b.
[[nodiscard]] int edge_index(int a, int b);

struct CanonicalState {
  CutTopology reference;  // the representative (smallest encoding among the 24 images)
  Perm4 transform;        // reference label i is local vertex transform.p[i]
};
[[nodiscard]] CanonicalState canonicalize(const CutTopology& t);

// The 11 classes of edge masks under S4 (docs/state_machine.md), in the order of kEdgeClassNames.
enum class EdgeClass : std::uint8_t {
  None,
  One,
  TwoAdjacent,
  TwoOpposite,
  ThreeAroundVertex,
  ThreeOnFace,
  ThreePath,
  FourLoop,
  FourNotLoop,
  Five,
  Six
};
[[nodiscard]] EdgeClass edge_class(std::uint8_t edge_mask);
[[nodiscard]] const char* edge_class_name(EdgeClass c);

}  // namespace scalpel
