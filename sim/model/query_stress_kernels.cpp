#include "sim/model/query_stress_kernels.h"

#include "sim/model/exact_avx2.h"
#include "sim/model/rotation_extraction.h"

#if defined(PLIANT_EXACT_AVX2_KERNELS)
#include "sim/model/matrix_entry_lanes.h"
#endif

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

// "flatten" inlines the extraction's lane templates here, so they are compiled for AVX2 (as in
// rotation_batch_avx2.cpp).
PLIANT_AVX2_ONLY __attribute__((flatten)) void exact_query_stresses_avx2(
    const double* x, const TetIndices* mesh_tets, const Mat3* rest_shape_inverse, const int* tets, Quat* q, double mu,
    double lambda, int max_iterations, double tolerance, Mat3* const* F, Mat3* const* R, Mat3* P) {
  using Lanes = rotation_batch_detail::LaneTypes<4>::Lanes;
  // Ds's columns d_k = x_{k+1} - x_0 per tet (lanes 0..2 xyz), then per k a 4x4 transpose: lane l
  // of ds[i + 3 k] is Ds(i, k) of tet l.
  __m256d d[4][3];
  const double* B[4];
  for (int l = 0; l < 4; ++l) {
    const auto t = static_cast<size_t>(tets[l]);
    const TetIndices& tet = mesh_tets[t];
    const __m256d x0 = exact_lanes::load3(x + 3 * static_cast<size_t>(tet[0]));
    for (int k = 0; k < 3; ++k) {
      d[l][k] = _mm256_sub_pd(exact_lanes::load3(x + 3 * static_cast<size_t>(tet[static_cast<size_t>(k) + 1])), x0);
    }
    B[l] = rest_shape_inverse[t].data();
  }
  __m256d ds[9];
  for (int k = 0; k < 3; ++k) {
    const __m256d t0 = _mm256_unpacklo_pd(d[0][k], d[1][k]), t1 = _mm256_unpackhi_pd(d[0][k], d[1][k]);
    const __m256d t2 = _mm256_unpacklo_pd(d[2][k], d[3][k]), t3 = _mm256_unpackhi_pd(d[2][k], d[3][k]);
    ds[3 * k] = _mm256_permute2f128_pd(t0, t2, 0x20);
    ds[3 * k + 1] = _mm256_permute2f128_pd(t1, t3, 0x20);
    ds[3 * k + 2] = _mm256_permute2f128_pd(t0, t2, 0x31);
  }
  __m256d b[9];  // b[k + 3 j] = Dm^-1(k, j) per lane
  matrix_lanes::load_entries(B[0], B[1], B[2], B[3], b);
  // F = Ds Dm^-1 in Eigen's order (exact_lanes::product_column): rows 0 and 1 (p0 + p1) + p2,
  // row 2 p0 + (p1 + p2).
  __m256d f[9];
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) {
      const __m256d p0 = _mm256_mul_pd(ds[i], b[3 * j]), p1 = _mm256_mul_pd(ds[i + 3], b[3 * j + 1]);
      const __m256d p2 = _mm256_mul_pd(ds[i + 6], b[3 * j + 2]);
      f[i + 3 * j] = i < 2 ? _mm256_add_pd(_mm256_add_pd(p0, p1), p2) : _mm256_add_pd(p0, _mm256_add_pd(p1, p2));
    }
  }
  matrix_lanes::store_entries(f, F[0]->data(), F[1]->data(), F[2]->data(), F[3]->data());
  // The extraction's iteration on these lanes (a lane taking the SVD start reads its stored F).
  Lanes Fl[3][3], qx, qy, qz, qw, count;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) Fl[i][j] = f[i + 3 * j];
  }
  rotation_batch_detail::iterate_rotation_lanes<4>(Fl, [&](int l) -> const Mat3& { return *F[l]; }, q, q, max_iterations,
                                                   tolerance, qx, qy, qz, qw, count);
  rotation_batch_detail::normalise_quaternion_lanes<4>(qx, qy, qz, qw);
  Lanes Rl[3][3];
  rotation_batch_detail::rotation_matrix_lanes<4>(qx, qy, qz, qw, Rl);
  __m256d r[9];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r[i + 3 * j] = Rl[i][j];
  }
  matrix_lanes::store_entries(r, R[0]->data(), R[1]->data(), R[2]->data(), R[3]->data());
  // P = (2 mu) (F - R) + (lambda tr) R, tr = sum of R .* F - 3 (first_piola_stress's operations).
  __m256d e[9];
  for (int k = 0; k < 9; ++k) e[k] = _mm256_mul_pd(r[k], f[k]);
  const __m256d trace = _mm256_sub_pd(matrix_lanes::entry_sum9(e), _mm256_set1_pd(3.0));
  const __m256d two_mu = _mm256_set1_pd(2.0 * mu), lambda_trace = _mm256_mul_pd(_mm256_set1_pd(lambda), trace);
  __m256d p[9];
  for (int k = 0; k < 9; ++k) {
    p[k] = _mm256_add_pd(_mm256_mul_pd(two_mu, _mm256_sub_pd(f[k], r[k])), _mm256_mul_pd(lambda_trace, r[k]));
  }
  matrix_lanes::store_entries(p, P[0].data(), P[1].data(), P[2].data(), P[3].data());
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

void exact_query_stresses_avx2(const double*, const TetIndices*, const Mat3*, const int*, Quat*, double, double, int,
                               double, Mat3* const*, Mat3* const*, Mat3*) {}

void corner_stress_sum_avx2(const int*, size_t, const Vec3*, size_t, const int*, const Mat3*, const double*, double*) {}

#endif

}  // namespace pliant
