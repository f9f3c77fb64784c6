#include "sim/surface_probe.hpp"

#include <algorithm>

#include <cmath>
#include <limits>

#include "mesh/closest_point.hpp"
#include "mesh/topology.hpp"

namespace scalpel {

SurfaceProbe::SurfaceProbe(const TetMesh& uncut) {
  for (const BoundaryFace& f : boundary_faces(uncut)) faces_.push_back(f.nodes);
}

void SurfaceProbe::drop_faces_of(std::span<const std::uint32_t> removed) {
  std::erase_if(faces_, [&](const std::array<std::uint32_t, 3>& f) {
    return std::any_of(f.begin(), f.end(), [&](std::uint32_t n) {
      return std::binary_search(removed.begin(), removed.end(), n);
    });
  });
}

namespace {

// The nearest crossing of the blade's line, from `tip` towards `back`, with a triangle of `faces` in
// positions `x`: its distance from the tip and the triangle's (unnormalised, outward) normal, with
// the line's unit direction and the blade's length. None for a blade of no length.
struct BladeCrossing {
  double t = std::numeric_limits<double>::infinity();
  Vec3 normal = Vec3::Zero();
  std::array<std::uint32_t, 3> face{};
  Vec3 dir = Vec3::Zero();
  double length = 0;
  [[nodiscard]] bool leaving() const { return normal.dot(dir) > 0.0; }
};

std::optional<BladeCrossing> first_crossing(const std::vector<std::array<std::uint32_t, 3>>& faces,
                                            const std::vector<Vec3>& x, const Vec3& tip, const Vec3& back) {
  BladeCrossing best;
  best.length = (back - tip).norm();
  if (!(best.length > 0.0)) return std::nullopt;
  const Vec3 dir = (back - tip) / best.length;
  best.dir = dir;
  for (const auto& f : faces) {
    const Vec3 &a = x[f[0]], &b = x[f[1]], &c = x[f[2]];
    // Moller-Trumbore, edges inclusive, so a ray through an edge or a vertex still meets the surface.
    const Vec3 e1 = b - a, e2 = c - a;
    const Vec3 pv = dir.cross(e2);
    const double det = e1.dot(pv);
    if (det == 0.0) continue;
    const Vec3 tv = tip - a;
    const double u = tv.dot(pv) / det;
    if (u < 0.0 || u > 1.0) continue;
    const Vec3 qv = tv.cross(e1);
    const double v = dir.dot(qv) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t = e2.dot(qv) / det;
    if (t < 0.0 || t >= best.t) continue;
    best.t = t;
    best.normal = e1.cross(e2);
    best.face = f;
  }
  return best;
}

}  // namespace

std::optional<SurfaceHit> SurfaceProbe::above(const std::vector<Vec3>& x, const Vec3& tip,
                                              const Vec3& back) const {
  // The nearest crossing of the surface either way: the tip is under the surface when the ray first
  // leaves the tissue, not when it first enters it (a tip above a fold of the organ).
  const auto c = first_crossing(faces_, x, tip, back);
  if (!c || !c->leaving()) return std::nullopt;
  const Vec3 normal = c->normal.normalized();
  return SurfaceHit{c->t * c->dir.dot(normal), tip + c->t * c->dir, normal};
}

std::optional<Vec3> SurfaceProbe::deepest_in_tissue(const std::vector<Vec3>& x, const Vec3& tip,
                                                    const Vec3& back) const {
  const auto c = first_crossing(faces_, x, tip, back);
  if (!c || !std::isfinite(c->t)) return std::nullopt;
  if (c->leaving()) return tip;  // the tip is in the tissue
  if (c->t <= c->length) return Vec3(tip + c->t * c->dir);
  return std::nullopt;
}

std::optional<SurfaceHit> SurfaceProbe::entry(const std::vector<Vec3>& x, const Vec3& from,
                                              const Vec3& to) const {
  const auto c = first_crossing(faces_, x, from, to);
  if (!c || !(c->t <= c->length) || c->leaving()) return std::nullopt;
  const Vec3 normal = c->normal.normalized();
  return SurfaceHit{(c->length - c->t) * -c->dir.dot(normal), from + c->t * c->dir, normal, c->face};
}

SurfaceHit SurfaceProbe::nearest(const std::vector<Vec3>& x, const Vec3& p, const Vec3& up) const {
  SurfaceHit best;
  double best_d2 = std::numeric_limits<double>::infinity();
  const double up_norm = up.norm();
  for (const auto& f : faces_) {
    const Vec3 &a = x[f[0]], &b = x[f[1]], &c = x[f[2]];
    const Vec3 n = (b - a).cross(c - a);
    if (!(n.squaredNorm() > 0) || !(n.dot(up) > kFacingCos * n.norm() * up_norm)) continue;
    const Vec3 q = closest_point_on_triangle(p, a, b, c);
    const double d2 = (q - p).squaredNorm();
    if (d2 >= best_d2) continue;
    best_d2 = d2;
    best = {std::sqrt(d2), q, n.normalized(), f};
  }
  return best;
}

}  // namespace scalpel
