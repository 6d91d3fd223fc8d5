#include "sim/model/diagonal_block_kernels.h"

#include "sim/model/exact_avx2.h"

#if defined(PLIANT_EXACT_AVX2_KERNELS)
#include "sim/model/matrix_entry_lanes.h"
#endif

namespace pliant {

#if defined(PLIANT_EXACT_AVX2_KERNELS)

bool diagonal_block_kernels_available() { return exact_avx2_kernels_available(); }

namespace {

using matrix_lanes::load_entries;
using matrix_lanes::store_entries;

/// Lane-wise a * b - c * d (Eigen's 2x2 minors: both products rounded, then the difference).
PLIANT_AVX2_ONLY inline __m256d minor2(__m256d a, __m256d b, __m256d c, __m256d d) {
  return _mm256_sub_pd(_mm256_mul_pd(a, b), _mm256_mul_pd(c, d));
}

/// Entry (r, c) of a column-major block held as entry vectors.
inline int at(int r, int c) { return r + 3 * c; }

/// Eigen's cofactor_3x3<i, j>: m(i1, j1) m(i2, j2) - m(i1, j2) m(i2, j1), i1 = i+1, i2 = i+2 mod 3.
PLIANT_AVX2_ONLY inline __m256d cofactor(const __m256d m[9], int i, int j) {
  const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
  return minor2(m[at(i1, j1)], m[at(i2, j2)], m[at(i1, j2)], m[at(i2, j1)]);
}

/// Four blocks, one per lane. Returns the lanes' SSOR test as a 4-bit mask (bit l: block l passes).
PLIANT_AVX2_ONLY int invert_lanes(const Mat3* blocks, const char* fixed, Mat3* diagonal, Mat3* inverses) {
  __m256d m[9];
  load_entries(blocks[0].data(), blocks[1].data(), blocks[2].data(), blocks[3].data(), m);
  // Eigen's determinant(): m00 (m11 m22 - m12 m21) - m01 (m10 m22 - m12 m20) + m02 (m10 m21 - m11 m20)
  const __m256d det3_012 = _mm256_mul_pd(m[at(0, 0)], minor2(m[at(1, 1)], m[at(2, 2)], m[at(1, 2)], m[at(2, 1)]));
  const __m256d det3_102 = _mm256_mul_pd(m[at(0, 1)], minor2(m[at(1, 0)], m[at(2, 2)], m[at(1, 2)], m[at(2, 0)]));
  const __m256d det3_201 = _mm256_mul_pd(m[at(0, 2)], minor2(m[at(1, 0)], m[at(2, 1)], m[at(1, 1)], m[at(2, 0)]));
  const __m256d det = _mm256_add_pd(_mm256_sub_pd(det3_012, det3_102), det3_201);
  const __m256d zero = _mm256_setzero_pd();
  const __m256d fixed_lanes = _mm256_castsi256_pd(
      _mm256_cmpgt_epi64(_mm256_set_epi64x(fixed[3] != 0, fixed[2] != 0, fixed[1] != 0, fixed[0] != 0),
                         _mm256_setzero_si256()));
  const __m256d positive = _mm256_cmp_pd(det, zero, _CMP_GT_OQ);
  // Lanes the scalar inverts (not fixed, det > 0) keep D; the others take the identity from here on
  // (no division by zero, no overflow the scalar would not meet) and end as zero blocks.
  const __m256d inverted = _mm256_andnot_pd(fixed_lanes, positive);
  const __m256d one = _mm256_set1_pd(1.0);
  __m256d a[9];
  for (int k = 0; k < 9; ++k) a[k] = _mm256_blendv_pd((k % 4 == 0) ? one : zero, m[k], inverted);
  // SSOR's test, fixed || (det > 0 && D00 > 0 && D00 D11 > D01 D10) (ordered compares: false for
  // NaN, as the scalar's >); its products only where the scalar reaches them (in the other lanes
  // the mask is decided by fixed or det already).
  const __m256d passes = _mm256_or_pd(
      fixed_lanes,
      _mm256_and_pd(_mm256_and_pd(positive, _mm256_cmp_pd(m[at(0, 0)], zero, _CMP_GT_OQ)),
                    _mm256_cmp_pd(_mm256_mul_pd(a[at(0, 0)], a[at(1, 1)]), _mm256_mul_pd(a[at(0, 1)], a[at(1, 0)]),
                                  _CMP_GT_OQ)));
  // diagonal = fixed ? I : D
  __m256d d[9];
  for (int k = 0; k < 9; ++k) d[k] = _mm256_blendv_pd(m[k], (k % 4 == 0) ? one : zero, fixed_lanes);
  store_entries(d, diagonal[0].data(), diagonal[1].data(), diagonal[2].data(), diagonal[3].data());
  // compute_inverse<3>: cofactors of column 0, det = (c00 m00 + c10 m10) + c20 m20 (Eigen's
  // vectorised 3-term sum: a packet of two, then the third), inverse(r, c) = cofactor(c, r) / det.
  const __m256d c00 = cofactor(a, 0, 0), c10 = cofactor(a, 1, 0), c20 = cofactor(a, 2, 0);
  const __m256d inverse_det = _mm256_div_pd(
      one, _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(c00, a[at(0, 0)]), _mm256_mul_pd(c10, a[at(1, 0)])),
                         _mm256_mul_pd(c20, a[at(2, 0)])));
  __m256d inv[9];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const __m256d cof = c == 0 && r == 0 ? c00 : (r == 0 && c == 1) ? c10 : (r == 0 && c == 2) ? c20 : cofactor(a, c, r);
      inv[at(r, c)] = _mm256_and_pd(inverted, _mm256_mul_pd(cof, inverse_det));
    }
  }
  store_entries(inv, inverses[0].data(), inverses[1].data(), inverses[2].data(), inverses[3].data());
  return _mm256_movemask_pd(passes);
}

}  // namespace

PLIANT_AVX2_ONLY bool invert_diagonal_blocks_avx2(const Mat3* blocks, const char* fixed, size_t n, Mat3* diagonal,
                                                  Mat3* inverses) {
  bool all_pass = true;
  size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    all_pass = (invert_lanes(blocks + i, fixed + i, diagonal + i, inverses + i) == 0xF) && all_pass;
  }
  if (i < n) {
    // The last 1-3 blocks padded to four with fixed identity blocks (which pass and end as zero).
    Mat3 rest[4] = {Mat3::Identity(), Mat3::Identity(), Mat3::Identity(), Mat3::Identity()};
    char rest_fixed[4] = {1, 1, 1, 1};
    Mat3 rest_diagonal[4], rest_inverses[4];
    for (size_t l = 0; i + l < n; ++l) {
      rest[l] = blocks[i + l];
      rest_fixed[l] = fixed[i + l];
    }
    all_pass = (invert_lanes(rest, rest_fixed, rest_diagonal, rest_inverses) == 0xF) && all_pass;
    for (size_t l = 0; i + l < n; ++l) {
      diagonal[i + l] = rest_diagonal[l];
      inverses[i + l] = rest_inverses[l];
    }
  }
  return all_pass;
}

#else

bool diagonal_block_kernels_available() { return false; }

bool invert_diagonal_blocks_avx2(const Mat3*, const char*, size_t, Mat3*, Mat3*) { return false; }

#endif

}  // namespace pliant
