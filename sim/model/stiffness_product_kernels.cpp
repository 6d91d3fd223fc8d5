#include "sim/model/stiffness_product_kernels.h"

#include "sim/model/exact_avx2.h"

namespace pliant {

#if defined(PLIANT_EXACT_AVX2_KERNELS)

bool stiffness_product_kernels_available() { return exact_avx2_kernels_available(); }

namespace {

using exact_lanes::load3;
using exact_lanes::store3;

/// B d for the columns c0..c2 of B, in Eigen's order (exact_lanes::product_column).
PLIANT_AVX2_ONLY inline __m256d block_times(__m256d c0, __m256d c1, __m256d c2, const Vec3& d) {
  return exact_lanes::product_column(c0, c1, c2, d.x(), d.y(), d.z());
}

}  // namespace

PLIANT_AVX2_ONLY void stiffness_row_product_avx2(const Mat3* blocks, const int* cols, size_t count, size_t j,
                                                 const Vec3& dj, const int* entry, const Vec3* d, double* sum) {
  const __m256d dx = _mm256_set1_pd(dj.x()), dy = _mm256_set1_pd(dj.y()), dz = _mm256_set1_pd(dj.z());
  const __m256d zero = _mm256_setzero_pd();
  // sum[j] is written only by this row (every other sum this row touches is a column c > j), so it
  // stays in a register; its terms are added in the scalar loop's order.
  const double* K = blocks[0].data();
  __m256d sum_j = _mm256_add_pd(load3(sum + 3 * j),
                                block_times(_mm256_loadu_pd(K), _mm256_loadu_pd(K + 3), load3(K + 6), dj));
  for (size_t b = 1; b < count; ++b) {
    const double* B = blocks[b].data();  // column-major
    const __m256d c0 = _mm256_loadu_pd(B), c1 = _mm256_loadu_pd(B + 3), c2 = load3(B + 6);
    // Rows of B (lanes 0..2) by a transpose in registers: r_k = (B(k, 0), B(k, 1), B(k, 2)).
    const __m256d t0 = _mm256_unpacklo_pd(c0, c1);    // B00 B01 B20 B21
    const __m256d t1 = _mm256_unpackhi_pd(c0, c1);    // B10 B11  .   .
    const __m256d t2 = _mm256_unpacklo_pd(c2, zero);  // B02  0  B22  0
    const __m256d t3 = _mm256_unpackhi_pd(c2, zero);  // B12  0   0   0
    const __m256d r0 = _mm256_permute2f128_pd(t0, t2, 0x20), r1 = _mm256_permute2f128_pd(t1, t3, 0x20),
                  r2 = _mm256_permute2f128_pd(t0, t2, 0x31);
    // K'_jc^T d_j: (B(0, i) d_0 + B(1, i) d_1) + B(2, i) d_2 in lane i: B^T's columns are B's rows.
    const __m256d bt = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(r0, dx), _mm256_mul_pd(r1, dy)), _mm256_mul_pd(r2, dz));
    double* sc = sum + 3 * static_cast<size_t>(cols[b]);
    store3(sc, _mm256_add_pd(load3(sc), bt));
    const int e = entry[cols[b]];
    if (e >= 0) sum_j = _mm256_add_pd(sum_j, block_times(c0, c1, c2, d[static_cast<size_t>(e)]));
  }
  store3(sum + 3 * j, sum_j);
}

#else

bool stiffness_product_kernels_available() { return false; }

void stiffness_row_product_avx2(const Mat3*, const int*, size_t, size_t, const Vec3&, const int*, const Vec3*,
                                double*) {}

#endif

}  // namespace pliant
