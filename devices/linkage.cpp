#include "devices/linkage.hpp"

#include <cmath>

namespace scalpel {

Eigen::Vector3d Linkage::position(const Eigen::Vector3d& q) const noexcept {
  const double r = arm * std::sin(q[1]) + forearm * std::sin(q[2]);
  return Eigen::Vector3d(r * std::cos(q[0]), r * std::sin(q[0]),
                         base + arm * std::cos(q[1]) - forearm * std::cos(q[2])) -
         origin;
}

Eigen::Matrix3d Linkage::jacobian(const Eigen::Vector3d& q) const noexcept {
  const double ca = std::cos(q[0]), sa = std::sin(q[0]);
  const double r = arm * std::sin(q[1]) + forearm * std::sin(q[2]);
  Eigen::Matrix3d j;
  j.col(0) << -r * sa, r * ca, 0.0;
  j.col(1) << arm * std::cos(q[1]) * ca, arm * std::cos(q[1]) * sa, -arm * std::sin(q[1]);
  j.col(2) << forearm * std::cos(q[2]) * ca, forearm * std::cos(q[2]) * sa, forearm * std::sin(q[2]);
  return j;
}

Eigen::Vector3d Linkage::currents(const Eigen::Vector3d& q, const Eigen::Vector3d& force) const noexcept {
  // Virtual work: a joint torque tau does tau dq = f . dx, so tau = J^T f; the motor turns
  // 1/ratio times as far as its joint, so it needs ratio times the torque.
  const Eigen::Vector3d tau = jacobian(q).transpose() * force;
  Eigen::Vector3d amps;
  for (int i = 0; i < 3; ++i)
    amps[i] = tau[i] * ratio[static_cast<std::size_t>(i)] / torque_constant[static_cast<std::size_t>(i)];
  if (!amps.allFinite()) return Eigen::Vector3d::Zero();
  // Over the limit, all three scale down together: the joint torques, and so the force, keep their
  // direction (clamping each alone would turn the force).
  const double peak = amps.cwiseAbs().maxCoeff();
  if (peak > max_current) amps *= max_current / peak;
  return amps;
}

}  // namespace scalpel
