// The co-rotational element's evaluation (element.hpp), written once over a number type: double for
// one element (namespace lanes::scalar), Lanes for four elements in the four lanes of an AVX2
// register (lanes::avx2; fem/element.cpp, evaluate_corotational4). fem/corotational_lanes.inc holds
// the functions; it is compiled into both namespaces, in the second for AVX2. Every lane does the
// IEEE operations the scalar instantiation does, in the same order, with no fused multiply-add, and
// a lane whose iteration has ended keeps its value: four elements evaluated at once give the bits
// each gives alone (tests/fem/test_element.cpp).
//
// Internal to fem/element.cpp. Every function is forced inline, so Lanes never pass through a call.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

#include "fem/element.hpp"

namespace scalpel::lanes {

using Lanes = double __attribute__((vector_size(4 * sizeof(double))));
using Mask = std::int64_t __attribute__((vector_size(4 * sizeof(double))));  // all ones: true
inline constexpr double kLargest = std::numeric_limits<double>::max();

template <class T>
struct M3 {
  T a[3][3];  // a[row][column]
};
template <class T>
struct V3 {
  T v[3];
};

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

}  // namespace scalpel::lanes

#define SCALPEL_LANES_SCALAR [[gnu::always_inline]] inline
namespace scalpel::lanes::scalar {
// The operations that differ between a double and four of them: one double.
SCALPEL_LANES_SCALAR double select(bool m, double a, double b) {
  return m ? a : b;
}
SCALPEL_LANES_SCALAR bool both(bool a, bool b) {
  return a && b;
}
SCALPEL_LANES_SCALAR bool negate(bool a) {
  return !a;
}
SCALPEL_LANES_SCALAR bool all_true(double) {
  return true;
}
SCALPEL_LANES_SCALAR bool any(bool a) {
  return a;
}
SCALPEL_LANES_SCALAR double root(double a) {
  return std::sqrt(a);
}
SCALPEL_LANES_SCALAR double magnitude(double a) {
  return std::abs(a);
}
SCALPEL_LANES_SCALAR void sine_cosine(double a, bool, double& s, double& c) {
  s = std::sin(a);
  c = std::cos(a);
}
#define SCALPEL_LANES_FN SCALPEL_LANES_SCALAR
#include "fem/corotational_lanes.inc"
#undef SCALPEL_LANES_FN
}  // namespace scalpel::lanes::scalar
#undef SCALPEL_LANES_SCALAR

#if defined(__x86_64__)  // not i386, whose scalar code may round in x87 registers
#define SCALPEL_LANES_HAVE_AVX2 1
#define SCALPEL_LANES_AVX2 [[gnu::always_inline, gnu::target("avx2")]] inline
namespace scalpel::lanes::avx2 {
// The same operations on four lanes.
SCALPEL_LANES_AVX2 Lanes select(Mask m, Lanes a, Lanes b) {
  return __builtin_bit_cast(Lanes, (__builtin_bit_cast(Mask, a) & m) | (__builtin_bit_cast(Mask, b) & ~m));
}
SCALPEL_LANES_AVX2 Mask both(Mask a, Mask b) {
  return a & b;
}
SCALPEL_LANES_AVX2 Mask negate(Mask a) {
  return ~a;
}
SCALPEL_LANES_AVX2 Mask all_true(Lanes) {
  return Mask{} - 1;
}
SCALPEL_LANES_AVX2 bool any(Mask a) {
  return (a[0] | a[1] | a[2] | a[3]) != 0;
}
SCALPEL_LANES_AVX2 Lanes root(Lanes a) {
  return Lanes{std::sqrt(a[0]), std::sqrt(a[1]), std::sqrt(a[2]), std::sqrt(a[3])};
}
SCALPEL_LANES_AVX2 Lanes magnitude(Lanes a) {
  return __builtin_bit_cast(Lanes, __builtin_bit_cast(Mask, a) & (Mask{} + INT64_MAX));
}
// sin and cos of a in the lanes of `active` (0 elsewhere: the lane's result is not used), from the
// functions the scalar code calls.
SCALPEL_LANES_AVX2 void sine_cosine(Lanes a, Mask active, Lanes& s, Lanes& c) {
  s = Lanes{} + 0.0;
  c = Lanes{} + 0.0;
  for (int l = 0; l < 4; ++l)
    if (active[l] != 0) {
      s[l] = std::sin(a[l]);
      c[l] = std::cos(a[l]);
    }
}
#define SCALPEL_LANES_FN SCALPEL_LANES_AVX2
#include "fem/corotational_lanes.inc"
#undef SCALPEL_LANES_FN
}  // namespace scalpel::lanes::avx2
#undef SCALPEL_LANES_AVX2
#endif
