// Whether a tetrahedral mesh is a manifold the cutter can work on: around every vertex and every
// edge, the tetrahedra that share it are joined through faces that share it too. A "bow-tie" (two
// tetrahedra, or two clusters, meeting at a vertex or along an edge only) is not: cutting cannot
// say on which side of the cut such a vertex or edge lies, and the invariants of docs/invariants.md
// assume it never happens.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

struct ManifoldReport {
  // Vertices whose tetrahedra fall into more than one face-connected cluster (node indices).
  std::vector<std::uint32_t> pinched_vertices;
  // Edges (node indices, first < second) whose tetrahedra fall into more than one cluster.
  std::vector<std::array<std::uint32_t, 2>> pinched_edges;

  [[nodiscard]] bool ok() const { return pinched_vertices.empty() && pinched_edges.empty(); }
  // One line for people: the counts and the first few, with their rest positions.
  [[nodiscard]] std::string summary(const TetMesh& mesh) const;
};

[[nodiscard]] ManifoldReport check_manifold(const TetMesh& mesh);

}  // namespace scalpel
