#include "mesh/generators.hpp"

#include <stdexcept>

namespace scalpel {

namespace {

// Cube corner c = i + 2j + 4k for (i, j, k) in {0,1}^3.
constexpr int kKuhn[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                             {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
constexpr int kFiveEven[5][4] = {{0, 3, 5, 6}, {1, 0, 3, 5}, {2, 0, 3, 6}, {4, 0, 5, 6}, {7, 3, 5, 6}};
constexpr int kFiveOdd[5][4] = {{1, 2, 4, 7}, {0, 1, 2, 4}, {3, 1, 2, 7}, {5, 1, 4, 7}, {6, 2, 4, 7}};

// Tetrahedralises the grid xs x ys x zs; region_of_layer[k] is the region of cell layer k.
TetMesh make_grid(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<double>& zs,
                  const std::vector<int>& region_of_layer, CubeSplit split) {
  const int nx = static_cast<int>(xs.size()) - 1, ny = static_cast<int>(ys.size()) - 1,
            nz = static_cast<int>(zs.size()) - 1;
  if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("grid needs at least one cell per axis");
  TetMesh mesh;
  std::vector<NodeId> node(static_cast<size_t>((nx + 1) * (ny + 1) * (nz + 1)));
  auto at = [&](int i, int j, int k) -> NodeId& {
    return node[static_cast<size_t>(i + (nx + 1) * (j + (ny + 1) * k))];
  };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i)
        at(i, j, k) = mesh.add_node(
            Vec3(xs[static_cast<size_t>(i)], ys[static_cast<size_t>(j)], zs[static_cast<size_t>(k)]));

  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        NodeId corner[8];
        for (int c = 0; c < 8; ++c) corner[c] = at(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
        const bool six = split == CubeSplit::Six;
        const int count = six ? 6 : 5;
        const auto& table = six ? kKuhn : ((i + j + k) % 2 == 0 ? kFiveEven : kFiveOdd);
        for (int t = 0; t < count; ++t) {
          std::array<NodeId, 4> v{corner[table[t][0]], corner[table[t][1]], corner[table[t][2]],
                                  corner[table[t][3]]};
          const Vec3 a = mesh.rest(v[0]);
          if ((mesh.rest(v[1]) - a).dot((mesh.rest(v[2]) - a).cross(mesh.rest(v[3]) - a)) < 0)
            std::swap(v[2], v[3]);
          mesh.add_tet(v, region_of_layer[static_cast<size_t>(k)]);
        }
      }
  return mesh;
}

std::vector<double> linspace(double a, double b, int cells) {
  std::vector<double> v(static_cast<size_t>(cells) + 1);
  for (int i = 0; i <= cells; ++i) v[static_cast<size_t>(i)] = a + (b - a) * i / cells;
  v.back() = b;
  return v;
}

}  // namespace

TetMesh make_box(const BoxSpec& spec) {
  for (int a = 0; a < 3; ++a) {
    if (spec.cells[static_cast<size_t>(a)] < 1) throw std::invalid_argument("box: cells must be >= 1");
    if (!(spec.max[a] > spec.min[a])) throw std::invalid_argument("box: max must exceed min");
  }
  const auto zs = linspace(spec.min.z(), spec.max.z(), spec.cells[2]);
  return make_grid(linspace(spec.min.x(), spec.max.x(), spec.cells[0]),
                   linspace(spec.min.y(), spec.max.y(), spec.cells[1]), zs,
                   std::vector<int>(static_cast<size_t>(spec.cells[2]), spec.region), spec.split);
}

TetMesh make_slab(const SlabSpec& spec) {
  if (spec.layers.empty()) throw std::invalid_argument("slab: at least one layer");
  if (spec.cells[0] < 1 || spec.cells[1] < 1) throw std::invalid_argument("slab: cells must be >= 1");
  if (!(spec.size_x > 0) || !(spec.size_y > 0)) throw std::invalid_argument("slab: size must be positive");
  // z grows upwards; the top of the first layer is z = 0. Build bottom-up.
  double depth = 0.0;
  for (const auto& l : spec.layers) {
    if (!(l.thickness > 0) || l.cells < 1)
      throw std::invalid_argument("slab: layer '" + l.name + "' is empty");
    depth += l.thickness;
  }
  std::vector<double> zs{-depth};
  std::vector<int> regions;
  double z = -depth;
  for (int li = static_cast<int>(spec.layers.size()) - 1; li >= 0; --li) {
    const auto& l = spec.layers[static_cast<size_t>(li)];
    const double top = li == 0 ? 0.0 : z + l.thickness;
    for (int c = 1; c <= l.cells; ++c) {
      zs.push_back(c == l.cells ? top : z + (top - z) * c / l.cells);
      regions.push_back(li);
    }
    z = top;
  }
  return make_grid(linspace(-spec.size_x / 2, spec.size_x / 2, spec.cells[0]),
                   linspace(-spec.size_y / 2, spec.size_y / 2, spec.cells[1]), zs, regions, spec.split);
}

std::vector<Vec3> incision_path(const Vec3& start, double bottom, const Vec3& along, double length,
                                double step) {
  std::vector<Vec3> path;
  Vec3 tip = start;
  for (; tip.z() > bottom; tip.z() -= step) path.push_back(tip);
  for (double u = 0; u < length; u += step) path.push_back(tip + u * along);
  for (Vec3 t = tip + length * along; t.z() < start.z(); t.z() += step) path.push_back(t);
  return path;
}

}  // namespace scalpel
