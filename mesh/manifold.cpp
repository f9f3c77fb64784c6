#include "mesh/manifold.hpp"

#include <algorithm>
#include <numeric>
#include <sstream>
#include <utility>

namespace scalpel {

namespace {

// Union-find over the few tetrahedra around one vertex or edge.
struct Clusters {
  std::vector<std::size_t> parent;
  explicit Clusters(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  std::size_t find(std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void join(std::size_t a, std::size_t b) { parent[find(a)] = find(b); }
  std::size_t count() {
    std::size_t n = 0;
    for (std::size_t i = 0; i < parent.size(); ++i) n += find(i) == i ? 1 : 0;
    return n;
  }
};

// Joins the entries that share a key: `keyed` holds (key, entry) pairs.
template <typename Key>
void join_by_key(std::vector<std::pair<Key, std::size_t>>& keyed, Clusters& clusters) {
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t i = 1; i < keyed.size(); ++i)
    if (keyed[i].first == keyed[i - 1].first) clusters.join(keyed[i].second, keyed[i - 1].second);
}

}  // namespace

ManifoldReport check_manifold(const TetMesh& mesh) {
  ManifoldReport out;
  std::vector<std::pair<std::array<std::uint32_t, 2>, std::size_t>> vertex_faces;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> around;  // (other vertex, tetrahedron)
  std::vector<std::pair<std::uint32_t, std::size_t>> edge_faces;
  for (const NodeId n : mesh.nodes()) {
    const std::uint32_t a = n.index;
    const std::vector<std::uint32_t>& tets = mesh.node_tets(n);
    if (tets.size() < 2) continue;
    // Around the vertex: tetrahedra joined by a face through it (the other two vertices match).
    vertex_faces.clear();
    around.clear();
    for (std::size_t i = 0; i < tets.size(); ++i) {
      std::array<std::uint32_t, 3> others{};
      int k = 0;
      for (const std::uint32_t v : mesh.tet_vertex_indices(tets[i]))
        if (v != a) others[static_cast<std::size_t>(k++)] = v;
      std::sort(others.begin(), others.end());
      vertex_faces.push_back({{others[0], others[1]}, i});
      vertex_faces.push_back({{others[0], others[2]}, i});
      vertex_faces.push_back({{others[1], others[2]}, i});
      for (const std::uint32_t b : others)
        if (b > a) around.push_back({b, tets[i]});
    }
    Clusters at_vertex(tets.size());
    join_by_key(vertex_faces, at_vertex);
    if (at_vertex.count() > 1) out.pinched_vertices.push_back(a);

    // Around each edge (a, b), b > a: tetrahedra joined by a face through it (the third vertex).
    std::sort(around.begin(), around.end());
    for (std::size_t begin = 0; begin < around.size();) {
      std::size_t end = begin;
      while (end < around.size() && around[end].first == around[begin].first) ++end;
      if (end - begin > 1) {
        const std::uint32_t b = around[begin].first;
        edge_faces.clear();
        for (std::size_t i = begin; i < end; ++i)
          for (const std::uint32_t v : mesh.tet_vertex_indices(around[i].second))
            if (v != a && v != b) edge_faces.push_back({v, i - begin});
        Clusters at_edge(end - begin);
        join_by_key(edge_faces, at_edge);
        if (at_edge.count() > 1) out.pinched_edges.push_back({a, b});
      }
      begin = end;
    }
  }
  return out;
}

std::string ManifoldReport::summary(const TetMesh& mesh) const {
  std::ostringstream s;
  s.precision(6);
  const auto at = [&](std::uint32_t i) {
    const Vec3& p = mesh.rest_positions()[i];
    std::ostringstream q;
    q.precision(6);
    q << "node " << i << " at (" << p.x() << ", " << p.y() << ", " << p.z() << ")";
    return q.str();
  };
  s << pinched_vertices.size() << " vertices and " << pinched_edges.size()
    << " edges where tetrahedra meet without a shared face (a bow-tie)";
  if (!pinched_vertices.empty()) s << "; first vertex: " << at(pinched_vertices.front());
  if (!pinched_edges.empty())
    s << "; first edge: " << at(pinched_edges.front()[0]) << " - " << at(pinched_edges.front()[1]);
  return s.str();
}

}  // namespace scalpel
