// The co-rotational element's evaluation (element.hpp), written once over a number type: double for
// one element, Lanes for four elements in the four lanes of an AVX2 register (fem/element.cpp,
// evaluate_corotational4). Every lane does the IEEE operations the scalar instantiation does, in the
// same order, with no fused multiply-add, and a lane whose iteration has ended keeps its value: four
// elements evaluated at once give the bits each gives alone (tests/fem/test_element.cpp).
//
// Internal to fem/element.cpp. Every function is forced inline so that it is compiled for the
// instruction set of the function that calls it, and Lanes never pass through a call.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>

#include "fem/element.hpp"

namespace scalpel::lanes {

#define SCALPEL_LANES_INLINE [[gnu::always_inline]] inline

using Lanes = double __attribute__((vector_size(4 * sizeof(double))));
using Mask = std::int64_t __attribute__((vector_size(4 * sizeof(double))));  // all ones: true

// The few operations that differ between a double and four of them.
SCALPEL_LANES_INLINE double select(bool m, double a, double b) {
  return m ? a : b;
}
SCALPEL_LANES_INLINE Lanes select(Mask m, Lanes a, Lanes b) {
  return std::bit_cast<Lanes>((std::bit_cast<Mask>(a) & m) | (std::bit_cast<Mask>(b) & ~m));
}
SCALPEL_LANES_INLINE bool both(bool a, bool b) {
  return a && b;
}
SCALPEL_LANES_INLINE Mask both(Mask a, Mask b) {
  return a & b;
}
SCALPEL_LANES_INLINE bool negate(bool a) {
  return !a;
}
SCALPEL_LANES_INLINE Mask negate(Mask a) {
  return ~a;
}
SCALPEL_LANES_INLINE bool all_true(double) {
  return true;
}
SCALPEL_LANES_INLINE Mask all_true(Lanes) {
  return Mask{} - 1;
}
SCALPEL_LANES_INLINE bool any(bool a) {
  return a;
}
SCALPEL_LANES_INLINE bool any(Mask a) {
  return (a[0] | a[1] | a[2] | a[3]) != 0;
}
SCALPEL_LANES_INLINE double root(double a) {
  return std::sqrt(a);
}
SCALPEL_LANES_INLINE Lanes root(Lanes a) {
  return Lanes{std::sqrt(a[0]), std::sqrt(a[1]), std::sqrt(a[2]), std::sqrt(a[3])};
}
SCALPEL_LANES_INLINE double magnitude(double a) {
  return std::abs(a);
}
SCALPEL_LANES_INLINE Lanes magnitude(Lanes a) {
  return std::bit_cast<Lanes>(std::bit_cast<Mask>(a) & (Mask{} + INT64_MAX));
}
// sin and cos of a, in the lanes of `active` (0 elsewhere: the lane's result is not used).
SCALPEL_LANES_INLINE void sine_cosine(double a, bool, double& s, double& c) {
  s = std::sin(a);
  c = std::cos(a);
}
SCALPEL_LANES_INLINE void sine_cosine(Lanes a, Mask active, Lanes& s, Lanes& c) {
  s = Lanes{} + 0.0;
  c = Lanes{} + 0.0;
  for (int l = 0; l < 4; ++l)
    if (active[l] != 0) {
      s[l] = std::sin(a[l]);
      c[l] = std::cos(a[l]);
    }
}

template <class T>
struct M3 {
  T a[3][3];  // a[row][column]
};
template <class T>
struct V3 {
  T v[3];
};

template <class T>
SCALPEL_LANES_INLINE T det(const M3<T>& m) {
  return m.a[0][0] * (m.a[1][1] * m.a[2][2] - m.a[1][2] * m.a[2][1]) -
         m.a[0][1] * (m.a[1][0] * m.a[2][2] - m.a[1][2] * m.a[2][0]) +
         m.a[0][2] * (m.a[1][0] * m.a[2][1] - m.a[1][1] * m.a[2][0]);
}

// Sylvester's criterion for a symmetric m > 0.
template <class T>
SCALPEL_LANES_INLINE auto positive_definite(const M3<T>& m) {
  return both(both(m.a[0][0] > 0.0, m.a[0][0] * m.a[1][1] - m.a[0][1] * m.a[1][0] > 0.0), det(m) > 0.0);
}

// The inverse by cofactors (where det != 0).
template <class T>
SCALPEL_LANES_INLINE M3<T> inverse(const M3<T>& m) {
  M3<T> c;
  c.a[0][0] = m.a[1][1] * m.a[2][2] - m.a[1][2] * m.a[2][1];
  c.a[0][1] = m.a[0][2] * m.a[2][1] - m.a[0][1] * m.a[2][2];
  c.a[0][2] = m.a[0][1] * m.a[1][2] - m.a[0][2] * m.a[1][1];
  c.a[1][0] = m.a[1][2] * m.a[2][0] - m.a[1][0] * m.a[2][2];
  c.a[1][1] = m.a[0][0] * m.a[2][2] - m.a[0][2] * m.a[2][0];
  c.a[1][2] = m.a[0][2] * m.a[1][0] - m.a[0][0] * m.a[1][2];
  c.a[2][0] = m.a[1][0] * m.a[2][1] - m.a[1][1] * m.a[2][0];
  c.a[2][1] = m.a[0][1] * m.a[2][0] - m.a[0][0] * m.a[2][1];
  c.a[2][2] = m.a[0][0] * m.a[1][1] - m.a[0][1] * m.a[1][0];
  const T d = m.a[0][0] * c.a[0][0] + m.a[0][1] * c.a[1][0] + m.a[0][2] * c.a[2][0];
  const T inv = 1.0 / d;
  for (auto& row : c.a)
    for (T& x : row) x = x * inv;
  return c;
}

// a b, a^T b.
template <class T>
SCALPEL_LANES_INLINE M3<T> product(const M3<T>& a, const M3<T>& b) {
  M3<T> p;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      p.a[i][j] = (a.a[i][0] * b.a[0][j] + a.a[i][1] * b.a[1][j]) + a.a[i][2] * b.a[2][j];
  return p;
}
template <class T>
SCALPEL_LANES_INLINE M3<T> transposed_product(const M3<T>& a, const M3<T>& b) {
  M3<T> p;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      p.a[i][j] = (a.a[0][i] * b.a[0][j] + a.a[1][i] * b.a[1][j]) + a.a[2][i] * b.a[2][j];
  return p;
}
// a b^T.
template <class T>
SCALPEL_LANES_INLINE M3<T> product_transposed(const M3<T>& a, const M3<T>& b) {
  M3<T> p;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      p.a[i][j] = (a.a[i][0] * b.a[j][0] + a.a[i][1] * b.a[j][1]) + a.a[i][2] * b.a[j][2];
  return p;
}

template <class T>
SCALPEL_LANES_INLINE T trace(const M3<T>& m) {
  return (m.a[0][0] + m.a[1][1]) + m.a[2][2];
}

// The unit quaternion's rotation matrix.
template <class T>
SCALPEL_LANES_INLINE M3<T> rotation(const T& w, const T& x, const T& y, const T& z) {
  const T tx = 2.0 * x, ty = 2.0 * y, tz = 2.0 * z;
  const T twx = tx * w, twy = ty * w, twz = tz * w;
  const T txx = tx * x, txy = ty * x, txz = tz * x;
  const T tyy = ty * y, tyz = tz * y, tzz = tz * z;
  M3<T> r;
  r.a[0][0] = 1.0 - (tyy + tzz);
  r.a[0][1] = txy - twz;
  r.a[0][2] = txz + twy;
  r.a[1][0] = txy + twz;
  r.a[1][1] = 1.0 - (txx + tzz);
  r.a[1][2] = tyz - twx;
  r.a[2][0] = txz - twy;
  r.a[2][1] = tyz + twx;
  r.a[2][2] = 1.0 - (txx + tyy);
  return r;
}

// Müller, Bender, Chentanez, Macklin 2016 with the Newton step where it is safe: element.cpp,
// extract_rotation(), whose comment explains the iteration. q = (w, x, y, z), in and out.
template <class T>
SCALPEL_LANES_INLINE void extract_rotation(const M3<T>& f, T q[4], int max_iterations) {
  // A warm start that is not finite or far from unit length (|q|^2 outside [1/4, 4]) starts from
  // the identity.
  const T qq = ((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]) + q[3] * q[3];
  const auto bad = negate(both(qq >= 0.25, qq <= 4.0));
  q[0] = select(bad, T{} + 1.0, q[0]);
  for (int k = 1; k < 4; ++k) q[k] = select(bad, T{} + 0.0, q[k]);
  auto active = all_true(qq);
  for (int it = 0; it < max_iterations && any(active); ++it) {
    const M3<T> r = rotation(q[0], q[1], q[2], q[3]);
    const M3<T> g = transposed_product(r, f);
    const V3<T> two_a{{g.a[2][1] - g.a[1][2], g.a[0][2] - g.a[2][0], g.a[1][0] - g.a[0][1]}};
    M3<T> m;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m.a[i][j] = -(0.5 * (g.a[i][j] + g.a[j][i]));
    const T tr_s = -trace(m);
    for (int i = 0; i < 3; ++i) m.a[i][i] = m.a[i][i] + tr_s;
    const auto newton = positive_definite(m);
    const M3<T> mi = inverse(m);
    const T damping = magnitude(trace(g)) + 1e-300;
    V3<T> phi;
    for (int i = 0; i < 3; ++i)
      phi.v[i] = select(newton, (mi.a[i][0] * two_a.v[0] + mi.a[i][1] * two_a.v[1]) + mi.a[i][2] * two_a.v[2],
                        two_a.v[i] / damping);
    const T w = root((phi.v[0] * phi.v[0] + phi.v[1] * phi.v[1]) + phi.v[2] * phi.v[2]);
    active = both(active, w > 1e-15);
    if (!any(active)) break;
    T s, c;
    sine_cosine(0.5 * w, active, s, c);
    const T dx = s * (phi.v[0] / w), dy = s * (phi.v[1] / w), dz = s * (phi.v[2] / w);
    T n[4];
    n[0] = ((q[0] * c - q[1] * dx) - q[2] * dy) - q[3] * dz;
    n[1] = ((q[0] * dx + q[1] * c) + q[2] * dz) - q[3] * dy;
    n[2] = ((q[0] * dy - q[1] * dz) + q[2] * c) + q[3] * dx;
    n[3] = ((q[0] * dz + q[1] * dy) - q[2] * dx) + q[3] * c;
    const T norm = root(((n[0] * n[0] + n[1] * n[1]) + n[2] * n[2]) + n[3] * n[3]);
    for (int k = 0; k < 4; ++k) q[k] = select(active, n[k] / norm, q[k]);
    active = both(active, negate(both(newton, w < 1e-3)));
  }
}

// One element's data in the lanes' layout: grad[i][a] = b_a(i), x[a][i].
template <class T>
struct Element {
  T grad[3][4];
  T volume, mu, lambda;
  T x[4][3];
  T q[4];  // (w, x, y, z): the warm start in, the rotation out
};

// What evaluate() forms: c, and where nothing is clamped (the mask it returns) force, energy and
// twist as evaluate_corotational() states them; r and eps for the general case elsewhere.
template <class T>
struct Evaluation {
  T c[3][4];
  T force[3][4];
  M3<T> twist, r, eps;
  T energy;
};

// evaluate_corotational() up to its general case (element.cpp).
template <class T>
SCALPEL_LANES_INLINE auto evaluate(Element<T>& e, Evaluation<T>& out) {
  M3<T> f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      f.a[i][j] = ((e.x[0][i] * e.grad[j][0] + e.x[1][i] * e.grad[j][1]) + e.x[2][i] * e.grad[j][2]) +
                  e.x[3][i] * e.grad[j][3];
  extract_rotation(f, e.q, 100);
  const M3<T> r = rotation(e.q[0], e.q[1], e.q[2], e.q[3]);
  const M3<T> rtf = transposed_product(r, f);
  M3<T>& eps = out.eps;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) eps.a[i][j] = 0.5 * (rtf.a[i][j] + rtf.a[j][i]) - (i == j ? 1.0 : 0.0);
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 4; ++a)
      out.c[i][a] = (r.a[i][0] * e.grad[0][a] + r.a[i][1] * e.grad[1][a]) + r.a[i][2] * e.grad[2][a];
  out.r = r;
  // evaluate_unclamped() (element.cpp): nothing clamped, the twist without an eigen-decomposition.
  const T tr = trace(eps);
  M3<T> below, above;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      below.a[i][j] = (i == j ? kStrainLimit : 0.0) - eps.a[i][j];
      above.a[i][j] = (i == j ? kStrainLimit : 0.0) + eps.a[i][j];
    }
  auto ok = both(magnitude(tr) < kStrainLimit, both(positive_definite(below), positive_definite(above)));
  const T two_mu = 2.0 * e.mu, lambda_tr = e.lambda * tr;
  M3<T> sigma;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) sigma.a[i][j] = two_mu * eps.a[i][j] + (i == j ? lambda_tr : T{} + 0.0);
  const T tr_sigma = trace(sigma), tr_u = 2.0 + tr;
  M3<T> t, u, u_floor;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      t.a[i][j] = (i == j ? tr_sigma : T{} + 0.0) - sigma.a[i][j];
      u.a[i][j] = (i == j ? tr_u : T{} + 0.0) - eps.a[i][j];
      u_floor.a[i][j] = u.a[i][j] - (i == j ? kTwistStretchFloor : 0.0);
    }
  ok = both(ok, both(positive_definite(t), positive_definite(u_floor)));
  const M3<T> tu = product(t, inverse(u));
  const T half_volume = 0.5 * e.volume;
  M3<T> sym;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) sym.a[i][j] = 0.5 * (half_volume * tu.a[i][j] + half_volume * tu.a[j][i]);
  out.twist = product_transposed(product(r, sym), r);
  const M3<T> rs = product(r, sigma);
  const T minus_volume = -e.volume;
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 4; ++a)
      out.force[i][a] = minus_volume *
                        ((rs.a[i][0] * e.grad[0][a] + rs.a[i][1] * e.grad[1][a]) + rs.a[i][2] * e.grad[2][a]);
  T eps2 = eps.a[0][0] * eps.a[0][0];
  for (int k = 1; k < 9; ++k) eps2 = eps2 + eps.a[k / 3][k % 3] * eps.a[k / 3][k % 3];
  out.energy = e.volume * (e.mu * eps2 + 0.5 * e.lambda * tr * tr);
  return ok;
}

}  // namespace scalpel::lanes

#undef SCALPEL_LANES_INLINE
