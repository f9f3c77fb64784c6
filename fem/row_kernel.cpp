#include "fem/row_kernel.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace scalpel {

namespace {

// The scalar block functions, block by block: the reference, and the kernel where AVX2 is missing.
void corotational_row_portable(const CorotationalState& s, int a, double h, const std::array<Mat3*, 4>& out) {
  const Vec3 ca = s.c.col(a);
  const Vec3 u = (h * s.lambda_volume) * ca, w = (h * s.mu_volume) * ca;
  const Mat3 n = twist_factor(s, a, h);
  for (int b = 0; b < 4; ++b) {
    Mat3& k = *out[static_cast<std::size_t>(b)];
    add_corotational_block(k, u, w, s.c.col(b));
    add_twist_block(k, n, s.c.col(b));
  }
}

#if defined(__x86_64__)  // not i386, whose scalar code may round in x87 registers
#define SCALPEL_ROW_AVX2 1

// Lane b of e[m] <- entry m of block b (column-major, m = i + 3 j), for m = 4 q .. 4 q + 3: a 4 x 4
// transpose of the blocks' q-th quarter. Its own inverse.
[[gnu::target("avx2")]] inline void transpose4(__m256d& r0, __m256d& r1, __m256d& r2, __m256d& r3) {
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
  r0 = _mm256_permute2f128_pd(t0, t2, 0x20);
  r1 = _mm256_permute2f128_pd(t1, t3, 0x20);
  r2 = _mm256_permute2f128_pd(t0, t2, 0x31);
  r3 = _mm256_permute2f128_pd(t1, t3, 0x31);
}

// One lane per block b. For every entry (i, j), in add_corotational_block()'s and
// add_twist_block()'s order: k += u_i c_j; k += c_i w_j; k_ii += w . c; row r: k += c x n_r.
// AVX2 without FMA: a fused multiply-add rounds once where the scalar functions round twice.
[[gnu::target("avx2")]] void corotational_row_avx2(const CorotationalState& s, int a, double h,
                                                   const std::array<Mat3*, 4>& out) {
  const Vec3 ca = s.c.col(a);
  const Vec3 u = (h * s.lambda_volume) * ca, w = (h * s.mu_volume) * ca;
  const Mat3 n = twist_factor(s, a, h);
  __m256d c[3];
  for (int i = 0; i < 3; ++i) c[i] = _mm256_set_pd(s.c(i, 3), s.c(i, 2), s.c(i, 1), s.c(i, 0));
  double* const d0 = out[0]->data();
  double* const d1 = out[1]->data();
  double* const d2 = out[2]->data();
  double* const d3 = out[3]->data();
  __m256d e[9];
  for (int q = 0; q < 2; ++q) {
    e[4 * q] = _mm256_loadu_pd(d0 + 4 * q);
    e[4 * q + 1] = _mm256_loadu_pd(d1 + 4 * q);
    e[4 * q + 2] = _mm256_loadu_pd(d2 + 4 * q);
    e[4 * q + 3] = _mm256_loadu_pd(d3 + 4 * q);
    transpose4(e[4 * q], e[4 * q + 1], e[4 * q + 2], e[4 * q + 3]);
  }
  e[8] = _mm256_set_pd(d3[8], d2[8], d1[8], d0[8]);
  const auto k = [&](int i, int j) -> __m256d& { return e[i + 3 * j]; };
  for (int j = 0; j < 3; ++j) {
    const __m256d wj = _mm256_set1_pd(w[j]);
    for (int i = 0; i < 3; ++i) {
      k(i, j) = _mm256_add_pd(k(i, j), _mm256_mul_pd(_mm256_set1_pd(u[i]), c[j]));
      k(i, j) = _mm256_add_pd(k(i, j), _mm256_mul_pd(c[i], wj));
    }
  }
  // Eigen's dot of two 3-vectors: (w0 c0 + w1 c1) + w2 c2.
  const __m256d dot = _mm256_add_pd(
      _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(w[0]), c[0]), _mm256_mul_pd(_mm256_set1_pd(w[1]), c[1])),
      _mm256_mul_pd(_mm256_set1_pd(w[2]), c[2]));
  for (int i = 0; i < 3; ++i) k(i, i) = _mm256_add_pd(k(i, i), dot);
  for (int r = 0; r < 3; ++r) {
    const __m256d m0 = _mm256_set1_pd(n(r, 0)), m1 = _mm256_set1_pd(n(r, 1)), m2 = _mm256_set1_pd(n(r, 2));
    k(r, 0) = _mm256_add_pd(k(r, 0), _mm256_sub_pd(_mm256_mul_pd(c[1], m2), _mm256_mul_pd(c[2], m1)));
    k(r, 1) = _mm256_add_pd(k(r, 1), _mm256_sub_pd(_mm256_mul_pd(c[2], m0), _mm256_mul_pd(c[0], m2)));
    k(r, 2) = _mm256_add_pd(k(r, 2), _mm256_sub_pd(_mm256_mul_pd(c[0], m1), _mm256_mul_pd(c[1], m0)));
  }
  for (int q = 0; q < 2; ++q) {
    transpose4(e[4 * q], e[4 * q + 1], e[4 * q + 2], e[4 * q + 3]);
    _mm256_storeu_pd(d0 + 4 * q, e[4 * q]);
    _mm256_storeu_pd(d1 + 4 * q, e[4 * q + 1]);
    _mm256_storeu_pd(d2 + 4 * q, e[4 * q + 2]);
    _mm256_storeu_pd(d3 + 4 * q, e[4 * q + 3]);
  }
  alignas(32) double last[4];
  _mm256_store_pd(last, e[8]);
  d0[8] = last[0];
  d1[8] = last[1];
  d2[8] = last[2];
  d3[8] = last[3];
}
#endif

}  // namespace

bool avx2_available() {
#ifdef SCALPEL_ROW_AVX2
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

CorotationalRowKernel corotational_row_kernel(RowIsa isa) {
#ifdef SCALPEL_ROW_AVX2
  if (isa == RowIsa::Avx2 && avx2_available()) return &corotational_row_avx2;
#endif
  (void)isa;
  return &corotational_row_portable;
}

CorotationalRowKernel corotational_row_kernel() {
  static const CorotationalRowKernel best = corotational_row_kernel(RowIsa::Avx2);
  return best;
}

}  // namespace scalpel
