#include "sim/model/tet_gradient_kernels.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__AVX__)
#include <immintrin.h>
#define PLIANT_TET_GRADIENT_KERNELS 1
// AVX2 without "fma": with FMA enabled GCC would contract a * b + c (its C++ default is
// -ffp-contract=fast) and the products would no longer be the scalar code's.
#define PLIANT_AVX2_ONLY __attribute__((target("avx2")))
#endif

namespace pliant {

#if defined(PLIANT_TET_GRADIENT_KERNELS)

bool tet_gradient_kernels_available() {
  static const bool available = __builtin_cpu_supports("avx2");
  return available;
}

namespace {

/// Lanes 0..2 of a 4-lane mask load (no read past a triple or a matrix).
PLIANT_AVX2_ONLY inline __m256i first_three() { return _mm256_set_epi64x(0, -1, -1, -1); }

/// The triple at v in lanes 0..2, lane 3 zero.
PLIANT_AVX2_ONLY inline __m256d load3(const double* v) { return _mm256_maskload_pd(v, first_three()); }

/// Stores lanes 0..2 at v.
PLIANT_AVX2_ONLY inline void store3(double* v, __m256d x) {
  _mm_storeu_pd(v, _mm256_castpd256_pd128(x));
  v[2] = _mm_cvtsd_f64(_mm256_extractf128_pd(x, 1));
}

/// Column j of the 3x3 product A B in Eigen's order, a_k the columns of A, b_k = B(k, j):
/// rows 0 and 1 (a_0 b_0 + a_1 b_1) + a_2 b_2, row 2 a_0 b_0 + (a_1 b_1 + a_2 b_2).
PLIANT_AVX2_ONLY inline __m256d product_column(__m256d a0, __m256d a1, __m256d a2, double b0, double b1, double b2) {
  const __m256d p0 = _mm256_mul_pd(a0, _mm256_set1_pd(b0));
  const __m256d p1 = _mm256_mul_pd(a1, _mm256_set1_pd(b1));
  const __m256d p2 = _mm256_mul_pd(a2, _mm256_set1_pd(b2));
  const __m256d packet_rows = _mm256_add_pd(_mm256_add_pd(p0, p1), p2);
  const __m256d scalar_row = _mm256_add_pd(p0, _mm256_add_pd(p1, p2));
  return _mm256_blend_pd(packet_rows, scalar_row, 0x4);
}

/// Stores the columns c0, c1, c2 (lanes 0..2 each) into the column-major 3x3 C, in this order: the
/// 4-lane stores of c0 and c1 write a stray lane 3 into the next column's first entry, which the
/// next store overwrites (full stores: a masked store is slow on some AMD cores).
PLIANT_AVX2_ONLY inline void store_columns(__m256d c0, __m256d c1, __m256d c2, double* C) {
  _mm256_storeu_pd(C, c0);
  _mm256_storeu_pd(C + 3, c1);
  _mm_storeu_pd(C + 6, _mm256_castpd256_pd128(c2));
  C[8] = _mm_cvtsd_f64(_mm256_extractf128_pd(c2, 1));
}

/// C = A B^T (columns a_k of A; B column-major).
PLIANT_AVX2_ONLY inline void product_transposed(__m256d a0, __m256d a1, __m256d a2, const double* B, double* C) {
  // B^T(k, j) = B(j, k) = B[j + 3 k]
  store_columns(product_column(a0, a1, a2, B[0], B[3], B[6]), product_column(a0, a1, a2, B[1], B[4], B[7]),
                product_column(a0, a1, a2, B[2], B[5], B[8]), C);
}

}  // namespace

PLIANT_AVX2_ONLY void deformation_gradients_avx2(const double* x, const TetIndices* tets,
                                                 const Mat3* rest_shape_inverse, size_t count, Mat3* F) {
  for (size_t l = 0; l < count; ++l) {
    const TetIndices& tet = tets[l];
    const __m256d x0 = load3(x + 3 * static_cast<size_t>(tet[0]));
    const __m256d d0 = _mm256_sub_pd(load3(x + 3 * static_cast<size_t>(tet[1])), x0);
    const __m256d d1 = _mm256_sub_pd(load3(x + 3 * static_cast<size_t>(tet[2])), x0);
    const __m256d d2 = _mm256_sub_pd(load3(x + 3 * static_cast<size_t>(tet[3])), x0);
    const double* B = rest_shape_inverse[l].data();  // B(k, j) = B[k + 3 j]
    store_columns(product_column(d0, d1, d2, B[0], B[1], B[2]), product_column(d0, d1, d2, B[3], B[4], B[5]),
                  product_column(d0, d1, d2, B[6], B[7], B[8]), F[l].data());
  }
}

PLIANT_AVX2_ONLY void rotated_gradients_avx2(const Quat* q, const Mat3* rest_shape_inverse, size_t count, Mat3* G) {
  for (size_t l = 0; l < count; ++l) {
    const Mat3 R = q[l].toRotationMatrix();  // scalar: Eigen's expressions, 12 products and 9 sums
    const double* r = R.data();
    product_transposed(_mm256_loadu_pd(r), _mm256_loadu_pd(r + 3), load3(r + 6), rest_shape_inverse[l].data(),
                       G[l].data());
  }
}

PLIANT_AVX2_ONLY void element_forces_avx2(const Quat* q, const Mat3* F, const Mat3* rest_shape_inverse,
                                          const double* volume, double mu, double lambda, size_t count, double* energy,
                                          Mat3* H) {
  const __m256d two_mu = _mm256_set1_pd(2.0 * mu);
  for (size_t l = 0; l < count; ++l) {
    // evaluate_tet_batch's scalar expressions (Eigen's SSE2 code: no __AVX__ here, no contraction)
    const Mat3 R = q[l].toRotationMatrix();
    const double trace = R.cwiseProduct(F[l]).sum() - 3.0;
    const Mat3 FmR = F[l] - R;
    energy[l] = volume[l] * (mu * FmR.squaredNorm() + 0.5 * lambda * trace * trace);
    // (-V) ((2 mu) (F - R) + (lambda trace) R), column by column, then times Dm^-T
    const __m256d lambda_trace = _mm256_set1_pd(lambda * trace), minus_volume = _mm256_set1_pd(-volume[l]);
    const double* fmr = FmR.data();
    const double* r = R.data();
    __m256d a[3];
    for (int k = 0; k < 3; ++k) {
      const __m256d fk = k < 2 ? _mm256_loadu_pd(fmr + 3 * k) : load3(fmr + 6);
      const __m256d rk = k < 2 ? _mm256_loadu_pd(r + 3 * k) : load3(r + 6);
      a[k] = _mm256_mul_pd(minus_volume, _mm256_add_pd(_mm256_mul_pd(two_mu, fk), _mm256_mul_pd(lambda_trace, rk)));
    }
    product_transposed(a[0], a[1], a[2], rest_shape_inverse[l].data(), H[l].data());
  }
}

PLIANT_AVX2_ONLY void scatter_element_forces_avx2(const TetIndices* tets, const Mat3* H, size_t count, double* f) {
  for (size_t l = 0; l < count; ++l) {
    const TetIndices& tet = tets[l];
    const double* h = H[l].data();
    const __m256d h0 = _mm256_loadu_pd(h), h1 = _mm256_loadu_pd(h + 3), h2 = load3(h + 6);
    // In the scalar's order, one vertex after the other (a degenerate tet may repeat a vertex).
    double* f0 = f + 3 * static_cast<size_t>(tet[0]);
    store3(f0, _mm256_sub_pd(load3(f0), _mm256_add_pd(_mm256_add_pd(h0, h1), h2)));
    double* f1 = f + 3 * static_cast<size_t>(tet[1]);
    store3(f1, _mm256_add_pd(load3(f1), h0));
    double* f2 = f + 3 * static_cast<size_t>(tet[2]);
    store3(f2, _mm256_add_pd(load3(f2), h1));
    double* f3 = f + 3 * static_cast<size_t>(tet[3]);
    store3(f3, _mm256_add_pd(load3(f3), h2));
  }
}

#else

bool tet_gradient_kernels_available() { return false; }

void scatter_element_forces_avx2(const TetIndices*, const Mat3*, size_t, double*) {}

void deformation_gradients_avx2(const double*, const TetIndices*, const Mat3*, size_t, Mat3*) {}

void rotated_gradients_avx2(const Quat*, const Mat3*, size_t, Mat3*) {}

void element_forces_avx2(const Quat*, const Mat3*, const Mat3*, const double*, double, double, size_t, double*, Mat3*) {}

#endif

}  // namespace pliant
