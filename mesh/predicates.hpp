// Exact geometric predicates.
//
// orient3d follows Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric
// Predicates" (1997): a floating-point evaluation with a static error bound decides the sign when it
// can; otherwise the determinant is evaluated exactly with rational arithmetic (GMP), so the sign is
// always that of the exact determinant of the given doubles.
#pragma once

#include "mesh/mesh.hpp"

namespace scalpel {

// Sign of det[b-a, c-a, d-a]: +1 when d lies on the side of plane (a, b, c) that its right-hand
// normal (b-a)x(c-a) points to; this is a positively oriented tetrahedron (a, b, c, d).
[[nodiscard]] int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

// Sign of the 2D orientation of (a, b, c) projected onto the coordinate plane that drops axis `drop`.
[[nodiscard]] int orient2d_projected(const Vec3& a, const Vec3& b, const Vec3& c, int drop);

// How many orient3d calls the float filter could not decide (for statistics and tests).
[[nodiscard]] unsigned long long orient3d_exact_fallbacks();

}  // namespace scalpel
