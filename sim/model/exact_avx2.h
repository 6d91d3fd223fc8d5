// The shared preamble of the exact AVX2 kernels (tet_gradient_kernels, diagonal_block_kernels,
// query_stress_kernels, stiffness_product_kernels; sessions 10-11). Design note: each kernel runs
// a few tets or blocks in the lanes of 256-bit registers, each lane the scalar code's operations
// in its order, inside functions compiled for "avx2" alone: with "fma" enabled GCC would contract
// a * b + c (its C++ default is -ffp-contract=fast) and the lanes would no longer give the scalar
// code's bits. Only portable GCC x86-64 builds get them (a build with AVX on everywhere contracts
// its scalar code too, so there is nothing exact to match).
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__AVX__)
#include <immintrin.h>
#define PLIANT_EXACT_AVX2_KERNELS 1
#define PLIANT_AVX2_ONLY __attribute__((target("avx2")))
#endif

namespace pliant {

/// True when the exact AVX2 kernels are built in and this CPU runs AVX2 (checked once).
bool exact_avx2_kernels_available();

#if defined(PLIANT_EXACT_AVX2_KERNELS)
/// The pieces the exact kernels share (one xyz triple or one 3x3 column per 4-lane vector).
namespace exact_lanes {

/// The triple at v in lanes 0..2, lane 3 zero (a masked load: no read past the triple).
PLIANT_AVX2_ONLY inline __m256d load3(const double* v) {
  return _mm256_maskload_pd(v, _mm256_set_epi64x(0, -1, -1, -1));
}

/// Stores lanes 0..2 at v.
PLIANT_AVX2_ONLY inline void store3(double* v, __m256d x) {
  _mm_storeu_pd(v, _mm256_castpd256_pd128(x));
  v[2] = _mm_cvtsd_f64(_mm256_extractf128_pd(x, 1));
}

/// a_0 b_0 + a_1 b_1 + a_2 b_2 in Eigen's order for a 3x3 matrix (columns a_k) times a vector b:
/// rows 0 and 1 (a_0 b_0 + a_1 b_1) + a_2 b_2 (its SSE2 packet), row 2 a_0 b_0 + (a_1 b_1 + a_2 b_2).
PLIANT_AVX2_ONLY inline __m256d product_column(__m256d a0, __m256d a1, __m256d a2, double b0, double b1, double b2) {
  const __m256d p0 = _mm256_mul_pd(a0, _mm256_set1_pd(b0));
  const __m256d p1 = _mm256_mul_pd(a1, _mm256_set1_pd(b1));
  const __m256d p2 = _mm256_mul_pd(a2, _mm256_set1_pd(b2));
  const __m256d packet_rows = _mm256_add_pd(_mm256_add_pd(p0, p1), p2);
  const __m256d scalar_row = _mm256_add_pd(p0, _mm256_add_pd(p1, p2));
  return _mm256_blend_pd(packet_rows, scalar_row, 0x4);
}

}  // namespace exact_lanes
#endif

}  // namespace pliant
