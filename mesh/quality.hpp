// Mesh statistics for `scalpelsim inspect` and reports.
#pragma once

#include <cstddef>

#include "mesh/mesh.hpp"
#include "mesh/validate.hpp"

namespace scalpel {

struct MeshSummary {
  std::size_t nodes = 0, tets = 0, boundary_faces = 0, components = 0, regions = 0;
  double rest_volume = 0.0;                             // [m^3]
  double current_volume = 0.0;                          // [m^3]
  Vec3 box_min = Vec3::Zero(), box_max = Vec3::Zero();  // rest bounding box [m]
  // Shape quality q = 6 sqrt(2) V / l_rms^3 (1 for a regular tetrahedron, 0 for a flat one), rest.
  double quality_min = 0.0, quality_mean = 0.0, quality_max = 0.0;
  std::size_t slivers = 0;                // q < 0.1
  double edge_min = 0.0, edge_max = 0.0;  // rest edge lengths [m]
};

// Shape quality of one tetrahedron (see MeshSummary), rest configuration.
[[nodiscard]] double tet_quality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

[[nodiscard]] MeshSummary summarize(const TetMesh& mesh);

}  // namespace scalpel
