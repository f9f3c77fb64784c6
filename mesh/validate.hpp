// Mesh invariants 1-4 of docs/invariants.md, checked on demand and, in SCALPEL_VALIDATE builds,
// after every mutation by the code that mutates.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

enum class Invariant : int { Oriented = 1, Conforming = 2, Watertight = 3, Volume = 4 };

struct Violation {
  Invariant invariant;
  std::uint32_t element;  // tet slot for 1, 2 and 4; node slot for 3 (the edge's first node)
  std::string what;
};

struct ValidationOptions {
  // Invariant 4: the original total rest volume, if known.
  std::optional<double> reference_volume;
  // Invariant 1 in the current configuration too (off once the tissue model may invert elements).
  bool check_current = false;
  // Stop collecting after this many violations.
  std::size_t max_violations = 64;
};

struct ValidationReport {
  std::vector<Violation> violations;
  std::array<bool, 5> passed{true, true, true, true, true};  // index = invariant number; [0] unused
  [[nodiscard]] bool ok() const { return violations.empty(); }
  // One line per violation: "invariant 2 (conforming), tet 17: ..."
  [[nodiscard]] std::string summary() const;
};

[[nodiscard]] ValidationReport validate(const TetMesh& mesh, const ValidationOptions& options = {});

// Invariants 1-3 in the neighbourhood of `nodes` (every tetrahedron holding one of them), and
// invariant 4 globally. After a local mutation of a mesh that was valid, passing the nodes of the
// removed and added tetrahedra checks everything the mutation can have broken, at a cost that does
// not grow with the mesh (but for the volume sum).
[[nodiscard]] ValidationReport validate_local(const TetMesh& mesh, std::span<const std::uint32_t> nodes,
                                              const ValidationOptions& options = {});

[[nodiscard]] const char* invariant_name(Invariant i);

}  // namespace scalpel
