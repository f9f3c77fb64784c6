// One pose of the tool as a device reports it (docs/architecture.md and docs/formats.md).
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace scalpel {

struct ToolSample {
  double t = 0.0;                                                   // [s] device time
  Eigen::Vector3d position = Eigen::Vector3d::Zero();               // [m] tool frame origin, world
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // tool -> world, (w, x, y, z)
  std::uint32_t buttons = 0;                                        // bitmask
  Eigen::Vector3d force = Eigen::Vector3d::Zero();                  // [N] force sent to the device
};

// Finite position and orientation, and an orientation of unit norm within `tolerance`.
[[nodiscard]] bool is_valid(const ToolSample& s, double tolerance = 1e-6);

}  // namespace scalpel
