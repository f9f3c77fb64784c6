#include "viewer/camera.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace scalpel {

namespace {

constexpr double kMaxPitch = 1.5707963267948966;  // straight down

// The direction from the target to the eye.
Vec3 eye_direction(double yaw, double pitch) {
  return {std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch)};
}

}  // namespace

Vec3 Camera::eye() const {
  return target + distance * eye_direction(yaw, pitch);
}

Eigen::Matrix4d Camera::view() const {
  const Vec3 back = eye_direction(yaw, pitch);  // the camera looks along -back
  // Looking straight down (or up), z cannot be up: the screen's up is then the horizontal
  // direction away from the eye's side (+y for yaw -90 degrees from above), as just off vertical.
  Vec3 up = std::abs(back.z()) > 0.999
                ? Vec3(-std::copysign(1.0, back.z()) * Vec3(std::cos(yaw), std::sin(yaw), 0.0))
                : Vec3::UnitZ();
  const Vec3 right = up.cross(back).normalized();
  up = back.cross(right);
  Eigen::Matrix4d v = Eigen::Matrix4d::Identity();
  v.block<1, 3>(0, 0) = right.transpose();
  v.block<1, 3>(1, 0) = up.transpose();
  v.block<1, 3>(2, 0) = back.transpose();
  const Vec3 e = eye();
  v(0, 3) = -right.dot(e);
  v(1, 3) = -up.dot(e);
  v(2, 3) = -back.dot(e);
  return v;
}

Eigen::Matrix4d Camera::projection(double aspect) const {
  // Near and far planes bracket the target generously; depth precision is ample at these scales.
  const double near_plane = distance * 0.01, far_plane = distance * 10.0;
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  if (ortho_half_height > 0.0) {
    const double h = ortho_half_height, w = h * aspect;
    p(0, 0) = 1.0 / w;
    p(1, 1) = 1.0 / h;
    p(2, 2) = -2.0 / (far_plane - near_plane);
    p(2, 3) = -(far_plane + near_plane) / (far_plane - near_plane);
    p(3, 3) = 1.0;
  } else {
    const double f = 1.0 / std::tan(fov_y / 2);
    p(0, 0) = f / aspect;
    p(1, 1) = f;
    p(2, 2) = (far_plane + near_plane) / (near_plane - far_plane);
    p(2, 3) = 2.0 * far_plane * near_plane / (near_plane - far_plane);
    p(3, 2) = -1.0;
  }
  return p;
}

Eigen::Vector3d Camera::project(const Vec3& p, int width, int height) const {
  const Eigen::Vector4d v = view() * p.homogeneous();
  const Eigen::Vector4d c = projection(static_cast<double>(width) / height) * v;
  const double ndc_x = c.x() / c.w(), ndc_y = c.y() / c.w();
  return {(ndc_x + 1.0) / 2.0 * width, (1.0 - ndc_y) / 2.0 * height, -v.z()};
}

void Camera::orbit(double d_yaw, double d_pitch) {
  yaw += d_yaw;
  pitch = std::clamp(pitch + d_pitch, -kMaxPitch, kMaxPitch);
}

void Camera::pan(double right, double up) {
  const Eigen::Matrix4d v = view();
  const double height =
      ortho_half_height > 0.0 ? 2.0 * ortho_half_height : 2.0 * distance * std::tan(fov_y / 2);
  target += height * (right * v.block<1, 3>(0, 0).transpose() + up * v.block<1, 3>(1, 0).transpose());
}

void Camera::zoom(double factor) {
  distance = std::clamp(distance * factor, 1e-3, 10.0);
  if (ortho_half_height > 0.0) ortho_half_height *= factor;
}

}  // namespace scalpel
