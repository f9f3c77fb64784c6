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

// Sign of det[u1-u0, v1-v0, w1-w0], the differences formed exactly: the side of the plane spanned
// by directions u and v (through any point) on which w points. The separating-axis test of two
// tetrahedra (mesh/overlap.cpp) asks it for the cross product of two edges.
[[nodiscard]] int orient_directions(const Vec3& u0, const Vec3& u1, const Vec3& v0, const Vec3& v1,
                                    const Vec3& w0, const Vec3& w1);

// How many orient3d calls the float filter could not decide (for statistics and tests).
[[nodiscard]] unsigned long long orient3d_exact_fallbacks();

}  // namespace scalpel
