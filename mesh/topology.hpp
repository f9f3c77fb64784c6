// Boundary surface and connected components of a TetMesh.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

struct BoundaryFace {
  std::uint32_t tet;                   // slot of the tetrahedron that owns the face
  int local_face;                      // its local face index
  std::array<std::uint32_t, 3> nodes;  // node slots, outward-oriented
};

// Faces of exactly one tetrahedron, in tet slot order.
[[nodiscard]] std::vector<BoundaryFace> boundary_faces(const TetMesh& mesh);

struct Components {
  std::vector<std::uint32_t> of_tet;   // component id per tet slot (kInvalidIndex for free slots)
  std::vector<double> rest_volume;     // per component
  std::vector<std::size_t> tet_count;  // per component
  [[nodiscard]] std::size_t count() const { return rest_volume.size(); }
};

// Components of the face-adjacency graph, numbered in order of their lowest tet slot.
[[nodiscard]] Components connected_components(const TetMesh& mesh);

// Pieces of nodes joined by shared tetrahedra (a vertex is enough: what stays together when a piece
// is moved or held): per node slot, a representative node slot of its piece, the same for every node
// of one piece. Free slots and nodes of no tetrahedron are their own pieces.
[[nodiscard]] std::vector<std::uint32_t> node_pieces(const TetMesh& mesh);

// The tetrahedra of a piece, added one by one: their volume and centroid of volume where they lie
// now (where a move turns the piece), their rest volume and their count.
struct PieceTally {
  Vec3 moment = Vec3::Zero();  // [m^4] sum of volume times centroid
  double volume = 0.0;         // [m^3] now
  double rest_volume = 0.0;    // [m^3]
  std::size_t tets = 0;
  void add(const TetMesh& mesh, std::uint32_t tet_slot);
  [[nodiscard]] Vec3 centroid() const { return moment / volume; }
};

}  // namespace scalpel
