#include "sim/model/query_stress_kernels.h"

#include "sim/model/exact_avx2.h"

namespace pliant {

#if defined(PLIANT_EXACT_AVX2_KERNELS)

bool query_stress_kernels_available() { return exact_avx2_kernels_available(); }

namespace {

/// Column k (0..2) of the column-major 3x3 at m in lanes 0..2: columns 0 and 1 by a full load
/// (lane 3 is the next column's first entry, unused), column 2 by a masked one (no read past m).
PLIANT_AVX2_ONLY inline __m256d matrix_column(const double* m, int k) {
  if (k < 2) return _mm256_loadu_pd(m + 3 * k);
  return _mm256_maskload_pd(m + 6, _mm256_set_epi64x(0, -1, -1, -1));
}

}  // namespace

namespace {

/// P = (2 mu) (F - R) + (lambda tr) R of one tet, tr = sum of R .* F - 3, into out (first_piola's
/// scalar expressions: Eigen's SSE2 code, no __AVX__ here, no contraction).
PLIANT_AVX2_ONLY inline void first_piola_stress(const Mat3& R, const Mat3& F, __m256d two_mu, double lambda,
                                                Mat3& out) {
  const double trace = R.cwiseProduct(F).sum() - 3.0;
  const __m256d lambda_trace = _mm256_set1_pd(lambda * trace);
  const double* f = F.data();
  const double* r = R.data();
  __m256d p[3];
  for (int k = 0; k < 3; ++k) {
    const __m256d rk = matrix_column(r, k);
    p[k] = _mm256_add_pd(_mm256_mul_pd(two_mu, _mm256_sub_pd(matrix_column(f, k), rk)), _mm256_mul_pd(lambda_trace, rk));
  }
  double* o = out.data();  // columns 0 and 1 stored whole (lane 3 overwritten next), then 2
  _mm256_storeu_pd(o, p[0]);
  _mm256_storeu_pd(o + 3, p[1]);
  _mm_storeu_pd(o + 6, _mm256_castpd256_pd128(p[2]));
  o[8] = _mm_cvtsd_f64(_mm256_extractf128_pd(p[2], 1));
}

}  // namespace

PLIANT_AVX2_ONLY void first_piola_stresses_avx2(const Quat* q, const Mat3* F, double mu, double lambda, size_t count,
                                                Mat3* R, Mat3* P) {
  const __m256d two_mu = _mm256_set1_pd(2.0 * mu);
  for (size_t l = 0; l < count; ++l) {
    R[l] = q[l].toRotationMatrix();
    first_piola_stress(R[l], F[l], two_mu, lambda, P[l]);
  }
}

PLIANT_AVX2_ONLY void first_piola_stresses_from_rotations_avx2(const Mat3* R, const Mat3* F, double mu, double lambda,
                                                               size_t count, Mat3* P) {
  const __m256d two_mu = _mm256_set1_pd(2.0 * mu);
  for (size_t l = 0; l < count; ++l) first_piola_stress(R[l], F[l], two_mu, lambda, P[l]);
}

PLIANT_AVX2_ONLY void corner_stress_sum_avx2(const int* corner_tets, size_t corner_stride, const Vec3* corner_gradients,
                                             size_t count, const int* tet_slots, const Mat3* slot_stresses,
                                             const double* volumes, double* f) {
  __m256d sum = _mm256_setzero_pd();
  for (size_t c = 0; c < count; ++c) {
    const auto t = static_cast<size_t>(corner_tets[c * corner_stride]);
    const double* P = slot_stresses[static_cast<size_t>(tet_slots[t])].data();
    const __m256d volume = _mm256_set1_pd(volumes[t]);
    const Vec3& g = corner_gradients[c];
    // (V P) g in Eigen's order: the columns of V P times g's components.
    sum = _mm256_sub_pd(sum, exact_lanes::product_column(_mm256_mul_pd(volume, matrix_column(P, 0)),
                                                         _mm256_mul_pd(volume, matrix_column(P, 1)),
                                                         _mm256_mul_pd(volume, matrix_column(P, 2)), g.x(), g.y(), g.z()));
  }
  exact_lanes::store3(f, sum);
}

#else

bool query_stress_kernels_available() { return false; }

void first_piola_stresses_avx2(const Quat*, const Mat3*, double, double, size_t, Mat3*, Mat3*) {}

void first_piola_stresses_from_rotations_avx2(const Mat3*, const Mat3*, double, double, size_t, Mat3*) {}

void corner_stress_sum_avx2(const int*, size_t, const Vec3*, size_t, const int*, const Mat3*, const double*, double*) {}

#endif

}  // namespace pliant
