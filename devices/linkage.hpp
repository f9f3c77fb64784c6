// The serial arm of an open force-feedback device (the WoodenHaptics and Polhem designs): a base
// that turns about the vertical (joint a), an arm (b) and a forearm (c), each driven through a
// capstan by its own motor. Joint angles come from the motors' encoders (a profile field's scale
// turns counts into radians), the tip's position from the angles, and a force at the tip becomes
// motor currents through the transposed Jacobian and each capstan's ratio.
//
// Geometry (z up): with r = arm sin(b) + forearm sin(c), the tip is
//   (r cos(a), r sin(a), base + arm cos(b) - forearm cos(c)) - origin,
// so at b = 0 the arm points up and at c = 0 the forearm hangs down.
#pragma once

#include <array>

#include <Eigen/Core>

namespace scalpel {

struct Linkage {
  double base = 0.0, arm = 0.0, forearm = 0.0;       // [m] lengths
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // [m] taken off the tip: the workspace's centre
  // Joint turn per motor turn, signed (a capstan's diameter over its body's): a motor torque is
  // the joint's torque times this.
  std::array<double, 3> ratio{1.0, 1.0, 1.0};
  std::array<double, 3> torque_constant{1.0, 1.0, 1.0};  // [N m / A] of each motor
  double max_current = 0.0;                              // [A] no motor is driven harder

  // The tip's position [m] at joint angles q [rad].
  [[nodiscard]] Eigen::Vector3d position(const Eigen::Vector3d& q) const noexcept;
  // d position / d q.
  [[nodiscard]] Eigen::Matrix3d jacobian(const Eigen::Vector3d& q) const noexcept;
  // The motor currents [A] that put force [N] on the tip at joint angles q (static: J^T f), scaled
  // down together where one would pass max_current, so the force keeps its direction; none for a
  // force that is not finite.
  [[nodiscard]] Eigen::Vector3d currents(const Eigen::Vector3d& q,
                                         const Eigen::Vector3d& force) const noexcept;
};

}  // namespace scalpel
