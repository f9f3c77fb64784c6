// Structured tetrahedral meshes for scenarios, tests and benchmarks.
#pragma once

#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace scalpel {

enum class CubeSplit { Five = 5, Six = 6 };

struct BoxSpec {
  Vec3 min = Vec3::Zero();
  Vec3 max = Vec3::Ones();
  std::array<int, 3> cells{4, 4, 4};  // cubes along x, y, z
  CubeSplit split = CubeSplit::Six;
  int region = 0;
};

// A box of nx*ny*nz hexahedral cells, each split into 5 tetrahedra (alternating by cell parity so
// neighbouring cells agree on their shared face diagonals) or 6 (Kuhn split around the main
// diagonal, conforming by construction). All tetrahedra are positively oriented.
[[nodiscard]] TetMesh make_box(const BoxSpec& spec);

struct SlabLayer {
  std::string name;  // e.g. "epidermis"
  double thickness;  // [m]
  int cells;         // cell layers through the thickness
};

struct SlabSpec {
  double size_x = 0.04, size_y = 0.04;  // [m]
  std::array<int, 2> cells{16, 16};     // cells along x and y
  std::vector<SlabLayer> layers;        // from the top (z = 0) downwards
  CubeSplit split = CubeSplit::Six;
};

// A layered slab centred on x = y = 0 with its top surface at z = 0, layers stacked downwards;
// region id = index of the layer in spec.layers.
[[nodiscard]] TetMesh make_slab(const SlabSpec& spec);

// The tip's path of a straight incision, a point every `step` [m]: down from `start` while above
// the height `bottom`, then `length` [m] along the unit direction `along`, then up to the height of
// `start`. A trajectory for tests and benchmarks.
[[nodiscard]] std::vector<Vec3> incision_path(const Vec3& start, double bottom, const Vec3& along,
                                              double length, double step);

}  // namespace scalpel
