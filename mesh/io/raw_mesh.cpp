#include "mesh/io/raw_mesh.hpp"

#include <map>
#include <set>
#include <utility>

#include "base/input_error.hpp"
#include "mesh/predicates.hpp"

namespace scalpel::mesh_io {

TetMesh build_mesh(RawMesh& raw, MeshFileInfo* info) {
  // Region ids: sorted distinct tags (std::set: deterministic), or the tags themselves.
  std::set<int> distinct(raw.tags.begin(), raw.tags.end());
  std::map<int, int> id_of_tag;
  MeshFileInfo out;
  int next_id = 0;
  for (const int tag : distinct) {
    const int id = raw.tags_are_ids ? tag : next_id++;
    id_of_tag[tag] = id;
    out.regions.push_back({id, tag, {}});
  }

  // Vertex checks and orientation (Invariant 1 needs orient3d > 0 in the rest configuration).
  const std::vector<Vec3>& at_rest = raw.rest.empty() ? raw.points : raw.rest;
  out.has_rest_positions = !raw.rest.empty();
  for (std::size_t t = 0; t < raw.tets.size(); ++t) {
    auto& v = raw.tets[t];
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (v[static_cast<std::size_t>(i)] == v[static_cast<std::size_t>(j)])
          throw InputError(raw.tet_file, raw.lines[t], 0, "tetrahedron",
                           "repeated vertex (local vertices " + std::to_string(i + 1) + " and " +
                               std::to_string(j + 1) + ")");
    const int s = orient3d(at_rest[v[0]], at_rest[v[1]], at_rest[v[2]], at_rest[v[3]]);
    if (s == 0) throw InputError(raw.tet_file, raw.lines[t], 0, "tetrahedron", "degenerate (zero volume)");
    if (s < 0) {
      std::swap(v[2], v[3]);
      ++out.reoriented_tets;
    }
  }

  // Only the nodes the tetrahedra use, in file order.
  std::vector<std::uint8_t> used(raw.points.size(), 0);
  for (const auto& v : raw.tets)
    for (const std::uint32_t n : v) used[n] = 1;
  TetMesh mesh;
  std::vector<NodeId> node(raw.points.size());
  for (std::size_t i = 0; i < raw.points.size(); ++i) {
    if (!used[i]) {
      ++out.unused_points;
      continue;
    }
    node[i] = mesh.add_node(at_rest[i], raw.points[i]);
  }
  for (std::size_t t = 0; t < raw.tets.size(); ++t) {
    const auto& v = raw.tets[t];
    mesh.add_tet({node[v[0]], node[v[1]], node[v[2]], node[v[3]]}, id_of_tag[raw.tags[t]]);
  }
  out.skipped_elements = raw.skipped;
  if (info) *info = std::move(out);
  return mesh;
}

}  // namespace scalpel::mesh_io
