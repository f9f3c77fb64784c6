// The assembly's inner kernel (docs/tissue.md, "Assembly"): row a of a co-rotational element,
// the four blocks h K_ab, b = 0..3, added at once with one SIMD lane per b.
//
// The lanes do, per block, the operations add_corotational_block() and add_twist_block() do, in
// the same order and with no fused multiply-add, so the AVX2 kernel gives the same bits as those
// scalar functions (tests/fem/test_row_kernel.cpp): a replay does not depend on the machine. It is
// chosen at run time where the processor has AVX2; elsewhere the portable kernel is the scalar
// functions themselves. The blocks of the four lanes are transposed in registers on the way in and
// out: gathering them entry by entry cost more than the arithmetic saved.
#pragma once

#include <array>

#include "fem/element.hpp"

namespace scalpel {

enum class RowIsa { Portable, Avx2 };

// Adds h K_ab of s's row a to *out[b] for b = 0..3 (four distinct blocks) [N/m].
using CorotationalRowKernel = void (*)(const CorotationalState& s, int a, double h,
                                       const std::array<Mat3*, 4>& out);

// The kernel for an instruction set; Avx2 only where avx2_available().
[[nodiscard]] CorotationalRowKernel corotational_row_kernel(RowIsa isa);
[[nodiscard]] bool avx2_available();
// The best kernel this processor runs.
[[nodiscard]] CorotationalRowKernel corotational_row_kernel();

}  // namespace scalpel
