// The implicit step's 3x3 diagonal system blocks checked and inverted four vertices at a time, one
// vertex per 256-bit lane (AVX2, no FMA), chosen at run time (session 11, issue #3). Design note:
// CorotationalFem::advance asks, per vertex block D of (1 + h alpha) M + h (beta + h) K', for Eigen's
// determinant (the SSOR test: det > 0, D00 > 0, D00 D11 > D01 D10) and for Eigen's inverse (the
// block-Jacobi preconditioner and SSOR's D^-1), both closed-form cofactor expressions (Eigen 3.4's
// determinant_impl<3> and compute_inverse<3>). Each lane performs exactly those multiplications,
// subtractions and the one division in their order, separately rounded (compiled for "avx2" without
// "fma": GCC would contract a * b - c otherwise), so every result is the scalar code's bit for bit
// (tested: diagonal_block_kernels_test). A lane whose block the scalar code would not invert (a fixed
// vertex, or det <= 0 or NaN) inverts the identity instead, so no lane divides by zero or overflows
// where the scalar code does not (the tests run with floating-point traps), and gets the scalar's
// zero block. A -march=native build reports the kernel unavailable (its scalar code contracts).
#pragma once

#include <cstddef>

#include "sim/math_types.h"

namespace pliant {

/// True when this CPU runs invert_diagonal_blocks_avx2 and it is the scalar code's bit for bit.
bool diagonal_block_kernels_available();

/// For each of the n blocks D = blocks[i] (read before anything is written, so `inverses` may be
/// `blocks`): diagonal[i] = fixed[i] ? I : D; inverses[i] = D.inverse() unless fixed[i] or
/// !(D.determinant() > 0), the zero block then. Returns whether every block with fixed[i] == 0
/// passes SSOR's test det > 0, D00 > 0, D00 D11 > D01 D10 (det = D.determinant()).
bool invert_diagonal_blocks_avx2(const Mat3* blocks, const char* fixed, size_t n, Mat3* diagonal, Mat3* inverses);

}  // namespace pliant
