#include "mesh/topology.hpp"

#include <numeric>

namespace scalpel {

std::vector<BoundaryFace> boundary_faces(const TetMesh& mesh) {
  std::vector<BoundaryFace> out;
  for (const TetId t : mesh.tets())
    for (int f = 0; f < 4; ++f)
      if (mesh.neighbour(t, f).is_null()) out.push_back({t.index, f, face_vertex_indices(mesh, t.index, f)});
  return out;
}

std::vector<std::uint32_t> node_pieces(const TetMesh& mesh) {
  // Union-find over node slots, with path halving.
  std::vector<std::uint32_t> root(mesh.node_capacity());
  std::iota(root.begin(), root.end(), 0u);
  const auto find = [&](std::uint32_t i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  for (std::uint32_t t = 0; t < mesh.tet_capacity(); ++t) {
    if (!mesh.tet_slot_alive(t)) continue;
    const auto& v = mesh.tet_vertex_indices(t);
    for (int k = 1; k < 4; ++k) root[find(v[static_cast<std::size_t>(k)])] = find(v[0]);
  }
  for (std::uint32_t i = 0; i < root.size(); ++i) root[i] = find(i);
  return root;
}

void PieceTally::add(const TetMesh& mesh, std::uint32_t t) {
  const auto& x = mesh.positions();
  const auto& v = mesh.tet_vertex_indices(t);
  const double vol = signed_volume(x[v[0]], x[v[1]], x[v[2]], x[v[3]]);
  moment += vol * (x[v[0]] + x[v[1]] + x[v[2]] + x[v[3]]) / 4.0;
  volume += vol;
  rest_volume += mesh.rest_volume(mesh.tet_handle(t));
  ++tets;
}

Components connected_components(const TetMesh& mesh) {
  Components c;
  c.of_tet.assign(mesh.tet_capacity(), kInvalidIndex);
  std::vector<std::uint32_t> stack;
  for (std::uint32_t seed = 0; seed < mesh.tet_capacity(); ++seed) {
    if (!mesh.tet_slot_alive(seed) || c.of_tet[seed] != kInvalidIndex) continue;
    const auto id = static_cast<std::uint32_t>(c.rest_volume.size());
    c.rest_volume.push_back(0.0);
    c.tet_count.push_back(0);
    stack.push_back(seed);
    c.of_tet[seed] = id;
    while (!stack.empty()) {
      const std::uint32_t t = stack.back();
      stack.pop_back();
      const TetId h = mesh.tet_handle(t);
      c.rest_volume[id] += mesh.rest_volume(h);
      ++c.tet_count[id];
      for (int f = 0; f < 4; ++f) {
        const TetId n = mesh.neighbour(h, f);
        if (!n.is_null() && c.of_tet[n.index] == kInvalidIndex) {
          c.of_tet[n.index] = id;
          stack.push_back(n.index);
        }
      }
    }
  }
  return c;
}

}  // namespace scalpel
