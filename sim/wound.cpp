#include "sim/wound.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mesh/topology.hpp"

namespace scalpel {

WoundMeter::WoundMeter(const TetMesh& uncut) {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const NodeId n : uncut.nodes()) {
    lo = lo.cwiseMin(uncut.rest(n));
    hi = hi.cwiseMax(uncut.rest(n));
  }
  // Cut nodes are interpolated on faces and edges of the mesh: they lie on its surface up to round-off.
  tolerance_ = 1e-9 * std::max((hi - lo).norm(), 1e-300);
  const auto& rest = uncut.rest_positions();
  for (const BoundaryFace& f : boundary_faces(uncut)) {
    Triangle t{rest[f.nodes[0]], rest[f.nodes[1]], rest[f.nodes[2]], {}, {}};
    t.lo = t.a.cwiseMin(t.b).cwiseMin(t.c) - Vec3::Constant(tolerance_);
    t.hi = t.a.cwiseMax(t.b).cwiseMax(t.c) + Vec3::Constant(tolerance_);
    surface_.push_back(t);
  }
}

bool WoundMeter::on_surface(const Vec3& p) const {
  for (const Triangle& t : surface_) {
    if ((p.array() < t.lo.array()).any() || (p.array() > t.hi.array()).any()) continue;
    const Vec3 n = (t.b - t.a).cross(t.c - t.a);
    const double area2 = n.norm();
    if (!(area2 > 0)) continue;
    if (std::abs((p - t.a).dot(n)) > tolerance_ * area2) continue;
    // Inside the triangle: the three sub-triangles with p keep the orientation of the face.
    const double slack =
        -tolerance_ * area2 / std::max({(t.b - t.a).norm(), (t.c - t.b).norm(), (t.a - t.c).norm()});
    if ((t.b - t.a).cross(p - t.a).dot(n) / area2 >= slack &&
        (t.c - t.b).cross(p - t.b).dot(n) / area2 >= slack &&
        (t.a - t.c).cross(p - t.c).dot(n) / area2 >= slack)
      return true;
  }
  return false;
}

WoundGape WoundMeter::measure(const TetMesh& mesh, std::span<const CutEngine::CutNodeCopies> cuts,
                              std::span<const Vec3> path, double band, double window) const {
  WoundGape out;
  const bool along = path.size() >= 2;
  std::vector<double> arc(path.size(), 0.0);  // arc length at each path point
  for (std::size_t i = 1; i < path.size(); ++i) arc[i] = arc[i - 1] + (path[i] - path[i - 1]).norm();
  double total = 0;
  for (const CutEngine::CutNodeCopies& c : cuts) {
    if (c.copies.empty() || !on_surface(c.rest)) continue;
    // The nearest point of the path in the xy plane: where along it, and the direction the gape is
    // taken across.
    WoundGape::Point point;
    Vec3 tangent = Vec3::Zero();
    if (along) {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i + 1 < path.size(); ++i) {
        const Vec3 d = path[i + 1] - path[i];
        const double len2 = d.squaredNorm();
        if (!(len2 > 0)) continue;
        const double u = std::clamp((c.rest - path[i]).dot(d) / len2, 0.0, 1.0);
        const double lateral = (c.rest - path[i] - u * d).head<2>().norm();
        if (lateral < best) {
          best = lateral;
          point.s = arc[i] + u * std::sqrt(len2);
          tangent = d / std::sqrt(len2);
        }
      }
      if (!(best <= band)) continue;
    }
    for (std::size_t i = 0; i < c.copies.size(); ++i)
      for (std::size_t j = i + 1; j < c.copies.size(); ++j) {
        const Vec3 d = mesh.position(c.copies[i]) - mesh.position(c.copies[j]);
        point.gape = std::max(point.gape, (d - d.dot(tangent) * tangent).norm());
      }
    point.bridge = c.copies.size() < 2;
    ++out.surface_nodes;
    out.bridges += point.bridge ? 1 : 0;
    total += point.gape;
    out.max = std::max(out.max, point.gape);
    if (along) out.profile.push_back(point);
  }
  out.mean = out.surface_nodes > 0 ? total / static_cast<double>(out.surface_nodes) : 0.0;
  std::stable_sort(out.profile.begin(), out.profile.end(),
                   [](const WoundGape::Point& a, const WoundGape::Point& b) { return a.s < b.s; });
  if (!out.profile.empty()) {
    const double mid = 0.5 * arc.back();
    double sum = 0, nearest = std::numeric_limits<double>::infinity();
    std::size_t n = 0;
    for (const WoundGape::Point& p : out.profile) {
      if (std::abs(p.s - mid) <= 0.5 * window) {
        sum += p.gape;
        ++n;
      }
      if (std::abs(p.s - mid) < nearest) {
        nearest = std::abs(p.s - mid);
        out.middle = p.gape;
      }
    }
    if (n > 0) out.middle = sum / static_cast<double>(n);
  }
  return out;
}

}  // namespace scalpel
