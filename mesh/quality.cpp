#include "mesh/quality.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "mesh/topology.hpp"

namespace scalpel {

double tet_quality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const double v = signed_volume(a, b, c, d);
  const double l2 = ((b - a).squaredNorm() + (c - a).squaredNorm() + (d - a).squaredNorm() +
                     (c - b).squaredNorm() + (d - b).squaredNorm() + (d - c).squaredNorm()) /
                    6.0;
  if (l2 <= 0) return 0.0;
  return 6.0 * std::sqrt(2.0) * v / std::pow(l2, 1.5);
}

MeshSummary summarize(const TetMesh& m) {
  MeshSummary s;
  s.nodes = m.node_count();
  s.tets = m.tet_count();
  s.boundary_faces = boundary_faces(m).size();
  s.components = connected_components(m).count();
  const auto& r = m.rest_positions();
  std::set<int> regions;
  double qsum = 0;
  s.quality_min = std::numeric_limits<double>::infinity();
  s.quality_max = -std::numeric_limits<double>::infinity();
  s.edge_min = std::numeric_limits<double>::infinity();
  s.edge_max = 0;
  s.box_min = Vec3::Constant(std::numeric_limits<double>::infinity());
  s.box_max = -s.box_min;
  for (const TetId t : m.tets()) {
    const auto& v = m.tet_vertex_indices(t.index);
    regions.insert(m.region(t));
    s.rest_volume += m.rest_volume(t);
    s.current_volume += m.current_volume(t);
    const double q = tet_quality(r[v[0]], r[v[1]], r[v[2]], r[v[3]]);
    qsum += q;
    s.quality_min = std::min(s.quality_min, q);
    s.quality_max = std::max(s.quality_max, q);
    s.slivers += q < 0.1 ? 1 : 0;
    for (const auto& e : kEdgeVertices) {
      const double l = (r[v[static_cast<size_t>(e[0])]] - r[v[static_cast<size_t>(e[1])]]).norm();
      s.edge_min = std::min(s.edge_min, l);
      s.edge_max = std::max(s.edge_max, l);
    }
    for (const auto n : v) {
      s.box_min = s.box_min.cwiseMin(r[n]);
      s.box_max = s.box_max.cwiseMax(r[n]);
    }
  }
  s.regions = regions.size();
  if (s.tets == 0) {
    s.quality_min = s.quality_max = s.edge_min = 0;
    s.box_min = s.box_max = Vec3::Zero();
  } else {
    s.quality_mean = qsum / static_cast<double>(s.tets);
  }
  return s;
}

}  // namespace scalpel
