#include "mesh/predicates.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include <gmp.h>

namespace scalpel {

namespace {

std::atomic<unsigned long long> g_fallbacks{0};

// A GMP rational; every finite double is one exactly.
class Rational {
 public:
  Rational() { mpq_init(v_); }
  explicit Rational(double d) {
    mpq_init(v_);
    mpq_set_d(v_, d);
  }
  Rational(const Rational&) = delete;
  Rational& operator=(const Rational&) = delete;
  ~Rational() { mpq_clear(v_); }
  mpq_t v_;
};

// Sign of the determinant of a 3x3 matrix of exact rationals, by cofactor expansion on row 0.
int det3_sign(Rational (&e)[3][3]) {
  Rational t1, t2, minor, acc;
  auto cofactor = [&](int r1, int c1, int r2, int c2) {
    mpq_mul(t1.v_, e[r1][c1].v_, e[r2][c2].v_);
    mpq_mul(t2.v_, e[r1][c2].v_, e[r2][c1].v_);
    mpq_sub(minor.v_, t1.v_, t2.v_);
  };
  cofactor(1, 1, 2, 2);
  mpq_mul(acc.v_, e[0][0].v_, minor.v_);
  cofactor(1, 0, 2, 2);
  mpq_mul(t1.v_, e[0][1].v_, minor.v_);
  mpq_sub(acc.v_, acc.v_, t1.v_);
  cofactor(1, 0, 2, 1);
  mpq_mul(t1.v_, e[0][2].v_, minor.v_);
  mpq_add(acc.v_, acc.v_, t1.v_);
  return mpq_sgn(acc.v_);
}

int exact_det3_sign(const double m[3][3]) {
  Rational e[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) mpq_set_d(e[i][j].v_, m[i][j]);
  return det3_sign(e);
}

// The differences b-a, c-a, d-a are formed exactly before the determinant.
int exact_orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  Rational e[3][3], ta, tb;
  const Vec3* rows[3] = {&b, &c, &d};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      mpq_set_d(ta.v_, (*rows[i])[j]);
      mpq_set_d(tb.v_, a[j]);
      mpq_sub(e[i][j].v_, ta.v_, tb.v_);
    }
  return det3_sign(e);
}

int exact_orient_directions(const Vec3* const (&from)[3], const Vec3* const (&to)[3]) {
  Rational e[3][3], ta, tb;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      mpq_set_d(ta.v_, (*to[i])[j]);
      mpq_set_d(tb.v_, (*from[i])[j]);
      mpq_sub(e[i][j].v_, ta.v_, tb.v_);
    }
  return det3_sign(e);
}

}  // namespace

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const double adx = b.x() - a.x(), ady = b.y() - a.y(), adz = b.z() - a.z();
  const double bdx = c.x() - a.x(), bdy = c.y() - a.y(), bdz = c.z() - a.z();
  const double cdx = d.x() - a.x(), cdy = d.y() - a.y(), cdz = d.z() - a.z();
  const double m1 = bdy * cdz - bdz * cdy;
  const double m2 = bdx * cdz - bdz * cdx;
  const double m3 = bdx * cdy - bdy * cdx;
  const double det = adx * m1 - ady * m2 + adz * m3;
  // Shewchuk's o3derrboundA, applied to the permanent of the same expansion.
  const double permanent = std::abs(adx) * (std::abs(bdy * cdz) + std::abs(bdz * cdy)) +
                           std::abs(ady) * (std::abs(bdx * cdz) + std::abs(bdz * cdx)) +
                           std::abs(adz) * (std::abs(bdx * cdy) + std::abs(bdy * cdx));
  constexpr double eps = std::numeric_limits<double>::epsilon() * 0.5;
  constexpr double bound = (7.0 + 56.0 * eps) * eps;
  // The bound already covers the rounded differences; the factor 2 is a margin.
  if (std::isfinite(det) && std::abs(det) > 2.0 * bound * permanent) return det > 0 ? 1 : -1;
  g_fallbacks.fetch_add(1, std::memory_order_relaxed);
  return exact_orient3d(a, b, c, d);
}

int orient_directions(const Vec3& u0, const Vec3& u1, const Vec3& v0, const Vec3& v1, const Vec3& w0,
                      const Vec3& w1) {
  const Vec3 u = u1 - u0, v = v1 - v0, w = w1 - w0;
  const double m1 = v.y() * w.z() - v.z() * w.y();
  const double m2 = v.x() * w.z() - v.z() * w.x();
  const double m3 = v.x() * w.y() - v.y() * w.x();
  const double det = u.x() * m1 - u.y() * m2 + u.z() * m3;
  const double permanent = std::abs(u.x()) * (std::abs(v.y() * w.z()) + std::abs(v.z() * w.y())) +
                           std::abs(u.y()) * (std::abs(v.x() * w.z()) + std::abs(v.z() * w.x())) +
                           std::abs(u.z()) * (std::abs(v.x() * w.y()) + std::abs(v.y() * w.x()));
  // Three rounded differences (one rounding each) on top of orient3d's own bound, with a wide margin.
  constexpr double eps = std::numeric_limits<double>::epsilon() * 0.5;
  if (std::isfinite(det) && std::abs(det) > 32.0 * eps * permanent) return det > 0 ? 1 : -1;
  // Every term has a zero factor (edges along the axes of a grid): zero exactly, unless a product
  // of components that are not zero underflowed, which none this far from 0 can.
  if (permanent == 0.0) {
    double smallest = std::numeric_limits<double>::infinity();
    for (const Vec3* x : {&u, &v, &w})
      for (int i = 0; i < 3; ++i)
        if ((*x)[i] != 0.0) smallest = std::min(smallest, std::abs((*x)[i]));
    if (smallest >= 1e-100) return 0;
  }
  g_fallbacks.fetch_add(1, std::memory_order_relaxed);
  const Vec3* const from[3] = {&u0, &v0, &w0};
  const Vec3* const to[3] = {&u1, &v1, &w1};
  return exact_orient_directions(from, to);
}

int orient2d_projected(const Vec3& a, const Vec3& b, const Vec3& c, int drop) {
  const int i = (drop + 1) % 3, j = (drop + 2) % 3;
  const double acx = a[i] - c[i], bcx = b[i] - c[i], acy = a[j] - c[j], bcy = b[j] - c[j];
  const double det = acx * bcy - acy * bcx;
  const double permanent = std::abs(acx * bcy) + std::abs(acy * bcx);
  constexpr double eps = std::numeric_limits<double>::epsilon() * 0.5;
  if (std::abs(det) > 8.0 * eps * permanent) return det > 0 ? 1 : -1;
  g_fallbacks.fetch_add(1, std::memory_order_relaxed);
  const double m[3][3] = {{a[i], a[j], 1.0}, {b[i], b[j], 1.0}, {c[i], c[j], 1.0}};
  return exact_det3_sign(m);
}

unsigned long long orient3d_exact_fallbacks() {
  return g_fallbacks.load(std::memory_order_relaxed);
}

}  // namespace scalpel
