// Four column-major 3x3 matrices as nine 4-lane vectors, one per entry (lane l = matrix l), and
// back: the one-tet (or one-vertex) per lane layout of the session-11 kernels (tet_gradient_kernels,
// diagonal_block_kernels). Two 4x4 transposes for entries 0-3 and 4-7 and the ninth entry by
// lanes. Include only inside a kernel source's x86-64 GCC guard: the functions are compiled for
// "avx2".
#pragma once

#include <immintrin.h>

namespace pliant::matrix_lanes {

/// e[k] lane l = m_l[k] for the four column-major 3x3 matrices m_0..m_3 (9 doubles each).
__attribute__((target("avx2"))) inline void load_entries(const double* m0, const double* m1, const double* m2,
                                                         const double* m3, __m256d e[9]) {
  for (int o = 0; o < 8; o += 4) {  // entries 0-3, 4-7: a 4x4 transpose
    const __m256d r0 = _mm256_loadu_pd(m0 + o), r1 = _mm256_loadu_pd(m1 + o);
    const __m256d r2 = _mm256_loadu_pd(m2 + o), r3 = _mm256_loadu_pd(m3 + o);
    const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
    const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
    e[o] = _mm256_permute2f128_pd(t0, t2, 0x20);
    e[o + 1] = _mm256_permute2f128_pd(t1, t3, 0x20);
    e[o + 2] = _mm256_permute2f128_pd(t0, t2, 0x31);
    e[o + 3] = _mm256_permute2f128_pd(t1, t3, 0x31);
  }
  e[8] = _mm256_set_pd(m3[8], m2[8], m1[8], m0[8]);
}

/// The inverse of load_entries: m_l[k] = e[k] lane l.
__attribute__((target("avx2"))) inline void store_entries(const __m256d e[9], double* m0, double* m1, double* m2,
                                                          double* m3) {
  for (int o = 0; o < 8; o += 4) {
    const __m256d t0 = _mm256_unpacklo_pd(e[o], e[o + 1]), t1 = _mm256_unpackhi_pd(e[o], e[o + 1]);
    const __m256d t2 = _mm256_unpacklo_pd(e[o + 2], e[o + 3]), t3 = _mm256_unpackhi_pd(e[o + 2], e[o + 3]);
    _mm256_storeu_pd(m0 + o, _mm256_permute2f128_pd(t0, t2, 0x20));
    _mm256_storeu_pd(m1 + o, _mm256_permute2f128_pd(t1, t3, 0x20));
    _mm256_storeu_pd(m2 + o, _mm256_permute2f128_pd(t0, t2, 0x31));
    _mm256_storeu_pd(m3 + o, _mm256_permute2f128_pd(t1, t3, 0x31));
  }
  const __m128d lo = _mm256_castpd256_pd128(e[8]), hi = _mm256_extractf128_pd(e[8], 1);
  _mm_storel_pd(m0 + 8, lo);
  _mm_storeh_pd(m1 + 8, lo);
  _mm_storel_pd(m2 + 8, hi);
  _mm_storeh_pd(m3 + 8, hi);
}

/// The sum of the nine entries of each lane's column-major 3x3 matrix in Eigen 3.4's order for
/// M.sum() in the portable build (redux with SSE2 packets of two: ((p_0 + p_1) + (p_2 + p_3)) over the
/// packets p_j = (e_2j, e_2j+1), then lane 0 + lane 1, then + e_8), so the same bits per lane.
__attribute__((target("avx2"))) inline __m256d entry_sum9(const __m256d e[9]) {
  const __m256d even = _mm256_add_pd(_mm256_add_pd(e[0], e[2]), _mm256_add_pd(e[4], e[6]));
  const __m256d odd = _mm256_add_pd(_mm256_add_pd(e[1], e[3]), _mm256_add_pd(e[5], e[7]));
  return _mm256_add_pd(_mm256_add_pd(even, odd), e[8]);
}

}  // namespace pliant::matrix_lanes
