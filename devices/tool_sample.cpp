#include "devices/tool_sample.hpp"

#include <cmath>

namespace scalpel {

bool is_valid(const ToolSample& s, double tolerance) {
  if (!std::isfinite(s.t) || !s.position.allFinite() || !s.orientation.coeffs().allFinite() ||
      !s.force.allFinite())
    return false;
  return std::abs(s.orientation.norm() - 1.0) <= tolerance;
}

}  // namespace scalpel
