// Closest points on simplices, for the cutter's tetrahedron search and the score's surface probe.
#pragma once

#include "mesh/mesh.hpp"

namespace scalpel {

// The point of triangle abc nearest to p (Ericson, "Real-Time Collision Detection", 2005, 5.1.5).
[[nodiscard]] Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace scalpel
