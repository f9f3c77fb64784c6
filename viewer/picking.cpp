#include "viewer/picking.hpp"

#include <Eigen/LU>
#include <cmath>
#include <limits>

namespace scalpel {

Ray camera_ray(const Camera& camera, double x, double y, int width, int height) {
  const double aspect = static_cast<double>(width) / std::max(height, 1);
  const Eigen::Matrix4d inverse = (camera.projection(aspect) * camera.view()).inverse();
  const double ndc_x = 2.0 * x / width - 1.0, ndc_y = 1.0 - 2.0 * y / height;
  const auto unproject = [&](double ndc_z) {
    const Eigen::Vector4d p = inverse * Eigen::Vector4d(ndc_x, ndc_y, ndc_z, 1.0);
    return Vec3(p.head<3>() / p.w());
  };
  const Vec3 near_point = unproject(-1.0), far_point = unproject(1.0);
  return {near_point, (far_point - near_point).normalized()};
}

std::optional<PieceHit> pick_piece(const FrameSnapshot& s, const Ray& ray) {
  if (s.triangle_piece.empty()) return std::nullopt;
  const auto point = [&](std::size_t v) {
    const auto& p = s.surface[v].position;
    return Vec3(p[0], p[1], p[2]);
  };
  std::optional<PieceHit> best;
  std::size_t best_triangle = 0;
  for (std::size_t t = 0; t < s.triangle_piece.size(); ++t) {
    // Möller and Trumbore: the ray's parameter and the barycentrics in one solve.
    const Vec3 a = point(3 * t), b = point(3 * t + 1), c = point(3 * t + 2);
    const Vec3 e1 = b - a, e2 = c - a;
    if (e1.cross(e2).dot(ray.direction) >= 0.0) continue;  // faces away: culled
    const Vec3 p = ray.direction.cross(e2);
    const double det = e1.dot(p);
    if (det == 0.0) continue;
    const Vec3 q = ray.origin - a;
    const double u = q.dot(p) / det;
    if (u < 0.0 || u > 1.0) continue;
    const Vec3 r = q.cross(e1);
    const double v = ray.direction.dot(r) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double d = e2.dot(r) / det;
    if (d <= 0.0 || (best && d >= best->distance)) continue;
    best = PieceHit{s.triangle_piece[t], ray.origin + d * ray.direction, Vec3::Zero(), d};
    best_triangle = t;
  }
  if (!best) return std::nullopt;
  // Just behind the face, towards the piece's inside: far below a tetrahedron's size, far above
  // rounding at the model's scale.
  const Vec3 a = point(3 * best_triangle), b = point(3 * best_triangle + 1), c = point(3 * best_triangle + 2);
  const Vec3 n = (b - a).cross(c - a).normalized();
  const double size = (s.bounds_max - s.bounds_min).norm();
  best->inside = best->surface - 1e-6 * size * n;
  return best;
}

std::optional<Vec3> ray_plane(const Ray& ray, const Vec3& point, const Vec3& normal) {
  const double along = ray.direction.dot(normal);
  if (std::abs(along) < 1e-9) return std::nullopt;
  const double d = (point - ray.origin).dot(normal) / along;
  return ray.origin + d * ray.direction;
}

void move_piece_preview(FrameSnapshot& s, std::uint32_t piece, const Eigen::Matrix3d& rotation,
                        const Vec3& translation) {
  if (piece >= s.pieces.size()) return;
  const Vec3 centre = s.pieces[piece].centroid;
  const auto move = [&](std::array<float, 3>& p) {
    const Vec3 x = centre + rotation * (Vec3(p[0], p[1], p[2]) - centre) + translation;
    p = {static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z())};
  };
  const auto turn = [&](std::array<float, 3>& n) {
    const Vec3 x = rotation * Vec3(n[0], n[1], n[2]);
    n = {static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z())};
  };
  for (std::size_t t = 0; t < s.triangle_piece.size(); ++t) {
    if (s.triangle_piece[t] != piece) continue;
    for (std::size_t k = 3 * t; k < 3 * t + 3; ++k) {
      move(s.surface[k].position);
      turn(s.surface[k].normal);
    }
  }
  for (std::size_t e = 0; e < s.edge_piece.size(); ++e)
    if (s.edge_piece[e] == piece) {
      move(s.edges[2 * e]);
      move(s.edges[2 * e + 1]);
    }
}

}  // namespace scalpel
