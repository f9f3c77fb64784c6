// An orbit camera about a target point, z up (the scenarios' convention: the skin surface is the
// xy plane). yaw turns the eye about z (0: on the +x side, -90 degrees: on the -y side), pitch
// raises it above the xy plane (90 degrees: straight down). Perspective, or orthographic when
// ortho_half_height > 0 (a top view in which pixels map linearly to the xy plane).
#pragma once

#include <Eigen/Core>

#include "mesh/mesh.hpp"

namespace scalpel {

struct Camera {
  Vec3 target = Vec3::Zero();        // [m]
  double distance = 0.1;             // [m] from the target to the eye
  double yaw = -1.5707963267948966;  // [rad]
  double pitch = 0.7;                // [rad]
  double fov_y = 0.6;                // [rad] vertical field of view (perspective)
  double ortho_half_height = 0.0;    // [m] > 0: orthographic, this much above and below the target

  [[nodiscard]] Vec3 eye() const;
  [[nodiscard]] Eigen::Matrix4d view() const;
  [[nodiscard]] Eigen::Matrix4d projection(double aspect) const;
  // Where a world point lands in a width x height picture: pixel x right, y down, and the depth
  // (negative behind the eye).
  [[nodiscard]] Eigen::Vector3d project(const Vec3& p, int width, int height) const;

  // Mouse gestures of the window: turn (radians), pan (fractions of the view's height), zoom (a
  // factor on the distance).
  void orbit(double d_yaw, double d_pitch);
  void pan(double right, double up);
  void zoom(double factor);
};

}  // namespace scalpel
