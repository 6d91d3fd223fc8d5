#include "sim/model/tet_gradient_kernels.h"

#include "sim/model/exact_avx2.h"

#if defined(PLIANT_EXACT_AVX2_KERNELS)
#include "sim/model/matrix_entry_lanes.h"
#endif

namespace pliant {

#if defined(PLIANT_EXACT_AVX2_KERNELS)

bool tet_gradient_kernels_available() { return exact_avx2_kernels_available(); }

namespace {

using exact_lanes::load3;
using exact_lanes::product_column;
using exact_lanes::store3;

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

using matrix_lanes::load_entries;
using matrix_lanes::entry_sum9;
using matrix_lanes::store_entries;

/// R = q.toRotationMatrix() for four quaternions (Eigen 3.4's expressions, lane by lane), as nine
/// entry vectors (column-major: R(r, c) = R[r + 3 c]).
PLIANT_AVX2_ONLY inline void rotation_entries(const Quat& q0, const Quat& q1, const Quat& q2, const Quat& q3,
                                              __m256d R[9]) {
  // Quaternion coefficients are stored (x, y, z, w): the same 4x4 transpose as load_entries.
  const __m256d r0 = _mm256_loadu_pd(q0.coeffs().data()), r1 = _mm256_loadu_pd(q1.coeffs().data());
  const __m256d r2 = _mm256_loadu_pd(q2.coeffs().data()), r3 = _mm256_loadu_pd(q3.coeffs().data());
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
  const __m256d x = _mm256_permute2f128_pd(t0, t2, 0x20), y = _mm256_permute2f128_pd(t1, t3, 0x20);
  const __m256d z = _mm256_permute2f128_pd(t0, t2, 0x31), w = _mm256_permute2f128_pd(t1, t3, 0x31);
  const __m256d two = _mm256_set1_pd(2.0), one = _mm256_set1_pd(1.0);
  const __m256d tx = _mm256_mul_pd(two, x), ty = _mm256_mul_pd(two, y), tz = _mm256_mul_pd(two, z);
  const __m256d twx = _mm256_mul_pd(tx, w), twy = _mm256_mul_pd(ty, w), twz = _mm256_mul_pd(tz, w);
  const __m256d txx = _mm256_mul_pd(tx, x), txy = _mm256_mul_pd(ty, x), txz = _mm256_mul_pd(tz, x);
  const __m256d tyy = _mm256_mul_pd(ty, y), tyz = _mm256_mul_pd(tz, y), tzz = _mm256_mul_pd(tz, z);
  R[0] = _mm256_sub_pd(one, _mm256_add_pd(tyy, tzz));  // (0, 0)
  R[3] = _mm256_sub_pd(txy, twz);                      // (0, 1)
  R[6] = _mm256_add_pd(txz, twy);                      // (0, 2)
  R[1] = _mm256_add_pd(txy, twz);                      // (1, 0)
  R[4] = _mm256_sub_pd(one, _mm256_add_pd(txx, tzz));  // (1, 1)
  R[7] = _mm256_sub_pd(tyz, twx);                      // (1, 2)
  R[2] = _mm256_sub_pd(txz, twy);                      // (2, 0)
  R[5] = _mm256_add_pd(tyz, twx);                      // (2, 1)
  R[8] = _mm256_sub_pd(one, _mm256_add_pd(txx, tyy));  // (2, 2)
}

/// C = A B^T lane by lane in Eigen's order (product_column's): C(r, j) = sum_k A(r, k) B(j, k), rows
/// 0 and 1 (k0 + k1) + k2, row 2 k0 + (k1 + k2).
PLIANT_AVX2_ONLY inline void product_transposed_lanes(const __m256d a[9], const __m256d b[9], __m256d c[9]) {
  for (int j = 0; j < 3; ++j) {
    for (int r = 0; r < 3; ++r) {
      const __m256d p0 = _mm256_mul_pd(a[r], b[j]), p1 = _mm256_mul_pd(a[r + 3], b[j + 3]);
      const __m256d p2 = _mm256_mul_pd(a[r + 6], b[j + 6]);
      c[r + 3 * j] = r < 2 ? _mm256_add_pd(_mm256_add_pd(p0, p1), p2) : _mm256_add_pd(p0, _mm256_add_pd(p1, p2));
    }
  }
}

/// R Dm^-T for four tets, one per lane (rotated_gradients_avx2's product, R from the quaternion as
/// toRotationMatrix): the scalar rotated_gradient bit for bit (session 11).
PLIANT_AVX2_ONLY inline void rotated_gradient_lanes(const Quat& q0, const Quat& q1, const Quat& q2, const Quat& q3,
                                                    const Mat3& B0, const Mat3& B1, const Mat3& B2, const Mat3& B3,
                                                    Mat3& G0, Mat3& G1, Mat3& G2, Mat3& G3) {
  __m256d R[9], b[9], g[9];
  rotation_entries(q0, q1, q2, q3, R);
  load_entries(B0.data(), B1.data(), B2.data(), B3.data(), b);
  product_transposed_lanes(R, b, g);
  store_entries(g, G0.data(), G1.data(), G2.data(), G3.data());
}

/// element_forces_avx2 for four tets, one per lane: every lane performs the scalar expressions'
/// operations in their order (session 11).
PLIANT_AVX2_ONLY void element_forces_lanes(const Quat* q, const Mat3* F, const Mat3* rest_shape_inverse,
                                           const double* volume, double mu, double lambda, double* energy, Mat3* H) {
  __m256d R[9], f[9], e[9];
  rotation_entries(q[0], q[1], q[2], q[3], R);
  load_entries(F[0].data(), F[1].data(), F[2].data(), F[3].data(), f);
  // trace = R.cwiseProduct(F).sum() - 3
  for (int k = 0; k < 9; ++k) e[k] = _mm256_mul_pd(R[k], f[k]);
  const __m256d trace = _mm256_sub_pd(entry_sum9(e), _mm256_set1_pd(3.0));
  // F - R, its squared norm, the energy V (mu |F - R|^2 + ((0.5 lambda) trace) trace)
  __m256d fmr[9];
  for (int k = 0; k < 9; ++k) {
    fmr[k] = _mm256_sub_pd(f[k], R[k]);
    e[k] = _mm256_mul_pd(fmr[k], fmr[k]);
  }
  const __m256d v = _mm256_loadu_pd(volume);
  const __m256d half_lambda_trace = _mm256_mul_pd(_mm256_set1_pd(0.5 * lambda), trace);
  _mm256_storeu_pd(energy, _mm256_mul_pd(v, _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(mu), entry_sum9(e)),
                                                          _mm256_mul_pd(half_lambda_trace, trace))));
  // A = (-V) ((2 mu) (F - R) + (lambda trace) R)
  const __m256d two_mu = _mm256_set1_pd(2.0 * mu), lambda_trace = _mm256_mul_pd(_mm256_set1_pd(lambda), trace);
  const __m256d minus_volume = _mm256_xor_pd(_mm256_set1_pd(-0.0), v);
  __m256d a[9];
  for (int k = 0; k < 9; ++k) {
    a[k] = _mm256_mul_pd(minus_volume, _mm256_add_pd(_mm256_mul_pd(two_mu, fmr[k]), _mm256_mul_pd(lambda_trace, R[k])));
  }
  // H = A B^T, B = Dm^-1
  __m256d b[9];
  load_entries(rest_shape_inverse[0].data(), rest_shape_inverse[1].data(), rest_shape_inverse[2].data(),
               rest_shape_inverse[3].data(), b);
  __m256d h[9];
  product_transposed_lanes(a, b, h);
  store_entries(h, H[0].data(), H[1].data(), H[2].data(), H[3].data());
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

namespace {

/// One tet's R Dm^-T, a column per vector (R scalar: Eigen's expressions, 12 products and 9 sums).
PLIANT_AVX2_ONLY inline void rotated_gradient_columns(const Quat& q, const Mat3& rest_shape_inverse, Mat3& G) {
  const Mat3 R = q.toRotationMatrix();
  const double* r = R.data();
  product_transposed(_mm256_loadu_pd(r), _mm256_loadu_pd(r + 3), load3(r + 6), rest_shape_inverse.data(), G.data());
}

}  // namespace

PLIANT_AVX2_ONLY void rotated_gradients_avx2(const Quat* q, const Mat3* rest_shape_inverse, size_t count, Mat3* G) {
  size_t l = 0;
  for (; l + 4 <= count; l += 4) {  // four tets in lanes
    rotated_gradient_lanes(q[l], q[l + 1], q[l + 2], q[l + 3], rest_shape_inverse[l], rest_shape_inverse[l + 1],
                           rest_shape_inverse[l + 2], rest_shape_inverse[l + 3], G[l], G[l + 1], G[l + 2], G[l + 3]);
  }
  for (; l < count; ++l) rotated_gradient_columns(q[l], rest_shape_inverse[l], G[l]);
}

PLIANT_AVX2_ONLY void rotated_gradients_at_avx2(const Quat* q, const Mat3* rest_shape_inverse, const int* tets,
                                                size_t count, Mat3* G) {
  size_t l = 0;
  for (; l + 4 <= count; l += 4) {  // four tets in lanes
    const auto t0 = static_cast<size_t>(tets[l]), t1 = static_cast<size_t>(tets[l + 1]);
    const auto t2 = static_cast<size_t>(tets[l + 2]), t3 = static_cast<size_t>(tets[l + 3]);
    rotated_gradient_lanes(q[t0], q[t1], q[t2], q[t3], rest_shape_inverse[t0], rest_shape_inverse[t1],
                           rest_shape_inverse[t2], rest_shape_inverse[t3], G[t0], G[t1], G[t2], G[t3]);
  }
  for (; l < count; ++l) {
    const auto t = static_cast<size_t>(tets[l]);
    rotated_gradient_columns(q[t], rest_shape_inverse[t], G[t]);
  }
}

PLIANT_AVX2_ONLY void element_forces_avx2(const Quat* q, const Mat3* F, const Mat3* rest_shape_inverse,
                                          const double* volume, double mu, double lambda, size_t count, double* energy,
                                          Mat3* H) {
  size_t l = 0;
  for (; l + 4 <= count; l += 4) {  // four tets in lanes
    element_forces_lanes(q + l, F + l, rest_shape_inverse + l, volume + l, mu, lambda, energy + l, H + l);
  }
  const __m256d two_mu = _mm256_set1_pd(2.0 * mu);
  for (; l < count; ++l) {  // the rest one by one, a column per vector
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

void rotated_gradients_at_avx2(const Quat*, const Mat3*, const int*, size_t, Mat3*) {}

void element_forces_avx2(const Quat*, const Mat3*, const Mat3*, const double*, double, double, size_t, double*, Mat3*) {}

#endif

}  // namespace pliant
