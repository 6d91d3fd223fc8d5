#include "sim/model/rotation_batch_avx512.h"

#include <cstring>

#include "sim/model/rotation_extraction.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__AVX__)
#include <immintrin.h>
#define PLIANT_ROTATION_BATCH_AVX512 1
#define PLIANT_AVX512_ONLY __attribute__((target("avx512f,avx512dq")))
#endif

namespace pliant {

#if defined(PLIANT_ROTATION_BATCH_AVX512)

namespace rotation_batch_detail {
/// Eight lanes in one 512-bit register. The template's comparisons and selects go through these
/// functions, compiled for AVX-512 (and inlined only into the 8-lane kernel): GCC 12 optimises a
/// template's body in its own (SSE2) context before inlining it, and there turns an 8-lane comparison
/// into a vector of 0 / -1 lanes that the AVX-512 expansion then builds lane by lane, with branches,
/// and every select on it too. Here a comparison is one vcmppd into a mask register and one vpmovm2q,
/// a select one vpternlogq (a bitwise select of the 0 / -1 lanes: m ? a : b exactly).
typedef double Lanes8 __attribute__((vector_size(64)));
typedef long Index8 __attribute__((vector_size(64)));

/// out[i] lane j = in[j] lane i: an 8 x 8 transpose in three rounds of two-register shuffles
/// (pairs of entries, then quads, then halves), 24 shuffles.
PLIANT_AVX512_ONLY inline void transpose8(const Lanes8 (&in)[8], Lanes8 (&out)[8]) {
  const Index8 pair_even = {0, 8, 2, 10, 4, 12, 6, 14}, pair_odd = {1, 9, 3, 11, 5, 13, 7, 15};
  const Index8 quad_low = {0, 1, 8, 9, 4, 5, 12, 13}, quad_high = {2, 3, 10, 11, 6, 7, 14, 15};
  const Index8 half_low = {0, 1, 2, 3, 8, 9, 10, 11}, half_high = {4, 5, 6, 7, 12, 13, 14, 15};
  Lanes8 pairs[8], quads[8];
  for (int i = 0; i < 4; ++i) {
    pairs[2 * i] = __builtin_shuffle(in[2 * i], in[2 * i + 1], pair_even);     // columns 0, 2, 4, 6
    pairs[2 * i + 1] = __builtin_shuffle(in[2 * i], in[2 * i + 1], pair_odd);  // columns 1, 3, 5, 7
  }
  for (int g = 0; g < 8; g += 4) {  // rows 0-3 (g = 0) and 4-7 (g = 4) of in
    quads[g] = __builtin_shuffle(pairs[g], pairs[g + 2], quad_low);            // columns 0, 4
    quads[g + 1] = __builtin_shuffle(pairs[g + 1], pairs[g + 3], quad_low);    // columns 1, 5
    quads[g + 2] = __builtin_shuffle(pairs[g], pairs[g + 2], quad_high);       // columns 2, 6
    quads[g + 3] = __builtin_shuffle(pairs[g + 1], pairs[g + 3], quad_high);   // columns 3, 7
  }
  for (int j = 0; j < 4; ++j) {
    out[j] = __builtin_shuffle(quads[j], quads[j + 4], half_low);
    out[j + 4] = __builtin_shuffle(quads[j], quads[j + 4], half_high);
  }
}

/// The column-major entries of 8 packed 3x3 matrices, e[k] lane l = m[l].data()[k]: entries 0-7 by
/// one 64-byte load per matrix and transpose8, entry 8 by a gather.
PLIANT_AVX512_ONLY inline void load_entries8(const Mat3* m, Lanes8 (&e)[9]) {
  Lanes8 rows[8];
  for (int l = 0; l < 8; ++l) std::memcpy(&rows[l], m[l].data(), sizeof(Lanes8));
  Lanes8 (&first)[8] = *reinterpret_cast<Lanes8(*)[8]>(&e[0]);
  transpose8(rows, first);
  const __m512i matrix_offsets = _mm512_setr_epi64(0, 9, 18, 27, 36, 45, 54, 63);
  // (the masked form: GCC 12's unmasked gather reads an uninitialised source, -Wuninitialized)
  e[8] = reinterpret_cast<Lanes8>(_mm512_mask_i64gather_pd(_mm512_setzero_pd(), 0xff, matrix_offsets, m[0].data() + 8, 8));
}

/// The inverse of load_entries8: m[l].data()[k] = e[k] lane l.
PLIANT_AVX512_ONLY inline void store_entries8(const Lanes8 (&e)[9], Mat3* m) {
  Lanes8 rows[8];
  transpose8(*reinterpret_cast<const Lanes8(*)[8]>(&e[0]), rows);
  for (int l = 0; l < 8; ++l) std::memcpy(m[l].data(), &rows[l], sizeof(Lanes8));  // entries 0-7
  const __m512i matrix_offsets = _mm512_setr_epi64(0, 9, 18, 27, 36, 45, 54, 63);
  _mm512_i64scatter_pd(m[0].data() + 8, matrix_offsets, reinterpret_cast<__m512d>(e[8]), 8);
}

template <>
struct LaneTypes<8> {
  typedef Lanes8 Lanes;
  typedef Index8 Mask;
  PLIANT_AVX512_ONLY static Mask less(const Lanes& a, const Lanes& b) { return a < b; }
  PLIANT_AVX512_ONLY static Mask less_equal(const Lanes& a, const Lanes& b) { return a <= b; }
  PLIANT_AVX512_ONLY static Lanes select(const Mask& m, const Lanes& a, const Lanes& b) {
    return reinterpret_cast<Lanes>(_mm512_ternarylogic_epi64(
        reinterpret_cast<__m512i>(m), reinterpret_cast<__m512i>(a), reinterpret_cast<__m512i>(b), 0xca));
  }
  PLIANT_AVX512_ONLY static bool any(const Mask& m) {
    return _mm512_test_epi64_mask(reinterpret_cast<__m512i>(m), reinterpret_cast<__m512i>(m)) != 0;
  }
  /// Lane l of qx, qy, qz, qw = the coefficients (x, y, z, w) of q[l]: four 64-byte loads (two
  /// quaternions each) and two rounds of two-register permutes (the store's in reverse).
  PLIANT_AVX512_ONLY static void load_quaternions(const Quat* q, Lanes& qx, Lanes& qy, Lanes& qz, Lanes& qw) {
    const double* p = q[0].coeffs().data();  // q[l] at p + 4 l (packed, asserted below)
    const __m512d q01 = _mm512_loadu_pd(p), q23 = _mm512_loadu_pd(p + 8);
    const __m512d q45 = _mm512_loadu_pd(p + 16), q67 = _mm512_loadu_pd(p + 24);
    // (x0, y0, x1, y1, x2, y2, x3, y3) and (z0, w0, ...) for lanes 0-3, the same for 4-7
    const __m512i pairs_first = _mm512_setr_epi64(0, 1, 4, 5, 8, 9, 12, 13);
    const __m512i pairs_second = _mm512_setr_epi64(2, 3, 6, 7, 10, 11, 14, 15);
    const __m512d xy_low = _mm512_permutex2var_pd(q01, pairs_first, q23);
    const __m512d zw_low = _mm512_permutex2var_pd(q01, pairs_second, q23);
    const __m512d xy_high = _mm512_permutex2var_pd(q45, pairs_first, q67);
    const __m512d zw_high = _mm512_permutex2var_pd(q45, pairs_second, q67);
    const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
    const __m512i odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
    qx = reinterpret_cast<Lanes>(_mm512_permutex2var_pd(xy_low, even, xy_high));
    qy = reinterpret_cast<Lanes>(_mm512_permutex2var_pd(xy_low, odd, xy_high));
    qz = reinterpret_cast<Lanes>(_mm512_permutex2var_pd(zw_low, even, zw_high));
    qw = reinterpret_cast<Lanes>(_mm512_permutex2var_pd(zw_low, odd, zw_high));
  }
  /// q[l] = (qx, qy, qz, qw) lane l: two rounds of two-register permutes, (x, y) and (z, w) pairs of
  /// lanes 0-3 and 4-7, then lanes 2k and 2k + 1 whole, one 64-byte store per two quaternions.
  PLIANT_AVX512_ONLY static void store_quaternions(const Lanes& qx, const Lanes& qy, const Lanes& qz, const Lanes& qw,
                                                   Quat* q) {
    const __m512i pairs_low = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
    const __m512i pairs_high = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
    const __m512d x = reinterpret_cast<__m512d>(qx), y = reinterpret_cast<__m512d>(qy);
    const __m512d z = reinterpret_cast<__m512d>(qz), w = reinterpret_cast<__m512d>(qw);
    const __m512d xy_low = _mm512_permutex2var_pd(x, pairs_low, y), xy_high = _mm512_permutex2var_pd(x, pairs_high, y);
    const __m512d zw_low = _mm512_permutex2var_pd(z, pairs_low, w), zw_high = _mm512_permutex2var_pd(z, pairs_high, w);
    const __m512i even = _mm512_setr_epi64(0, 1, 8, 9, 2, 3, 10, 11), odd = _mm512_setr_epi64(4, 5, 12, 13, 6, 7, 14, 15);
    double* p = q[0].coeffs().data();  // q[l] at p + 4 l
    _mm512_storeu_pd(p, _mm512_permutex2var_pd(xy_low, even, zw_low));
    _mm512_storeu_pd(p + 8, _mm512_permutex2var_pd(xy_low, odd, zw_low));
    _mm512_storeu_pd(p + 16, _mm512_permutex2var_pd(xy_high, even, zw_high));
    _mm512_storeu_pd(p + 24, _mm512_permutex2var_pd(xy_high, odd, zw_high));
  }
  /// Lane l of Fl[i][j] = F[l](i, j) (load_entries8: the eight matrices packed).
  PLIANT_AVX512_ONLY static void load_matrices(const Mat3* F, Lanes (&Fl)[3][3]) {
    Lanes e[9];
    load_entries8(F, e);
    for (int k = 0; k < 9; ++k) Fl[k % 3][k / 3] = e[k];
  }
  /// s = sqrt(n) where n > 0, 1 elsewhere: one masked vsqrtpd (correctly rounded, as std::sqrt).
  PLIANT_AVX512_ONLY static void square_root_where_positive(const Lanes& n, Lanes& s) {
    const __m512d v = reinterpret_cast<__m512d>(n);
    const __mmask8 positive = _mm512_cmp_pd_mask(v, _mm512_setzero_pd(), _CMP_GT_OQ);
    s = reinterpret_cast<Lanes>(_mm512_mask_sqrt_pd(_mm512_set1_pd(1.0), positive, v));
  }
};
static_assert(sizeof(Quat) == 4 * sizeof(double) && sizeof(Mat3) == 9 * sizeof(double), "packed quaternions, matrices");
}  // namespace rotation_batch_detail

bool rotation_batch_avx512_available() {
  static const bool available = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq");
  return available;
}

// "flatten" inlines the template (and what it calls) here, so it is compiled for AVX-512 and the
// lanes are zmm registers; "avx512dq" moves lane masks between mask and vector registers in one
// instruction. No contraction: -ffp-contract=off on this file (rotation_batch_avx512.h).
PLIANT_AVX512_ONLY __attribute__((flatten)) void extract_rotations_batch_avx512(const Mat3* F, Quat* q,
                                                                                int max_iterations, double tolerance,
                                                                                int* iterations) {
  extract_rotations_lanes<kRotationBatchLanesAvx512>(F, q, max_iterations, tolerance, iterations);
}

namespace {

using rotation_batch_detail::Lanes8;

/// The sum of a column-major 3x3 matrix's nine entries per lane in Eigen's order for M.sum() in the
/// portable build (matrix_entry_lanes.h's entry_sum9): ((e0 + e2) + (e4 + e6)) + ((e1 + e3) + (e5 + e7)),
/// then + e8.
PLIANT_AVX512_ONLY inline void entry_sum9(const Lanes8 (&e)[9], Lanes8& sum) {
  sum = (((e[0] + e[2]) + (e[4] + e[6])) + ((e[1] + e[3]) + (e[5] + e[7]))) + e[8];
}

/// value in every lane (not 0 + value, which turns -0 into +0).
PLIANT_AVX512_ONLY inline Lanes8 broadcast(double value) { return reinterpret_cast<Lanes8>(_mm512_set1_pd(value)); }

/// F = Ds Dm^-1 of 8 tets in lanes, Fl[i][j] lane l = F(i, j) of tets[l] (8 packed index sets) with
/// Dm^-1 = rest_shape_inverse[l] (8 packed matrices): CorotationalFem::deformation_gradient's bits, as
/// deformation_gradients_avx2 computes it. b receives Dm^-1's entries, b[k][j] lane l = Dm^-1(k, j).
PLIANT_AVX512_ONLY inline void deformation_gradient_lanes(const double* x, const TetIndices* tets,
                                                          const Mat3* rest_shape_inverse, Lanes8 (&b)[3][3],
                                                          Lanes8 (&Fl)[3][3]) {
  using Ops = rotation_batch_detail::LaneTypes<8>;
  using Lanes = Lanes8;
  // The vertices' xyz by gathers: tets[l][k] for l = 0..7 out of the 32 packed indices, times 3.
  static_assert(sizeof(TetIndices) == 4 * sizeof(int), "packed tet indices");
  const __m512i indices_low = _mm512_loadu_si512(tets[0].data()), indices_high = _mm512_loadu_si512(tets[4].data());
  Lanes corner[4][3];  // corner[k][c]: coordinate c of the tet's vertex k
  for (int k = 0; k < 4; ++k) {
    const __m512i pick = _mm512_setr_epi32(k, 4 + k, 8 + k, 12 + k, 16 + k, 20 + k, 24 + k, 28 + k, 0, 0, 0, 0, 0, 0, 0,
                                           0);
    // (the zero-masked extract: GCC 12's cast to 256 bits reads an undefined value, -Wuninitialized)
    const __m256i vertex = _mm512_maskz_extracti64x4_epi64(0xf, _mm512_permutex2var_epi32(indices_low, pick, indices_high), 0);
    const __m256i offset = _mm256_add_epi32(vertex, _mm256_add_epi32(vertex, vertex));  // 3 v
    for (int c = 0; c < 3; ++c) {
      corner[k][c] = reinterpret_cast<Lanes>(_mm512_mask_i32gather_pd(_mm512_setzero_pd(), 0xff, offset, x + c, 8));
    }
  }
  // F = Ds Dm^-1 (CorotationalFem::deformation_gradient, as deformation_gradients_avx2 computes it):
  // Ds(i, k) = x_{k+1}(i) - x_0(i); F(i, j) = sum_k Ds(i, k) B(k, j) in Eigen's order, rows 0 and 1
  // (p0 + p1) + p2, row 2 p0 + (p1 + p2).
  Ops::load_matrices(rest_shape_inverse, b);
  Lanes ds[3][3];
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) ds[i][k] = corner[k + 1][i] - corner[0][i];
  }
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) {
      const Lanes p0 = ds[i][0] * b[0][j], p1 = ds[i][1] * b[1][j], p2 = ds[i][2] * b[2][j];
      Fl[i][j] = i < 2 ? (p0 + p1) + p2 : p0 + (p1 + p2);
    }
  }
}

}  // namespace

PLIANT_AVX512_ONLY __attribute__((flatten)) void evaluate_tets_avx512(const double* x, const TetIndices* tets,
                                                                       const Mat3* rest_shape_inverse,
                                                                       const double* volume, double mu, double lambda,
                                                                       int max_iterations, double tolerance,
                                                                       const Quat* warm_starts, Quat* q,
                                                                       double* energy, Mat3* H) {
  using Ops = rotation_batch_detail::LaneTypes<8>;
  using Lanes = Lanes8;
  Lanes b[3][3], Fl[3][3];  // b[k][j] = Dm^-1(k, j)
  deformation_gradient_lanes(x, tets, rest_shape_inverse, b, Fl);
  // The rotations (a lane taking the SVD start reads its F out of the lanes).
  const auto F_of_lane = [&](int l) {
    Mat3 F;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) F(i, j) = Fl[i][j][l];
    }
    return F;
  };
  Lanes qx, qy, qz, qw, count;
  rotation_batch_detail::iterate_rotation_lanes<8>(Fl, F_of_lane, warm_starts, q, max_iterations, tolerance, qx, qy, qz,
                                                   qw, count);
  rotation_batch_detail::normalise_quaternion_lanes<8>(qx, qy, qz, qw);
  Ops::store_quaternions(qx, qy, qz, qw, q);
  // element_forces_avx2's expressions per lane (tet_gradient_kernels.cpp, element_forces_lanes), the
  // column-major entry k = i + 3 j of R, F, F - R, A and H in one vector each.
  Lanes Rl[3][3];
  rotation_batch_detail::rotation_matrix_lanes<8>(qx, qy, qz, qw, Rl);
  Lanes r[9], f[9], e[9], fmr[9];
  for (int k = 0; k < 9; ++k) r[k] = Rl[k % 3][k / 3], f[k] = Fl[k % 3][k / 3];
  // trace = R.cwiseProduct(F).sum() - 3
  for (int k = 0; k < 9; ++k) e[k] = r[k] * f[k];
  Lanes trace;
  entry_sum9(e, trace);
  trace = trace - 3.0;
  // F - R, its squared norm, the energy V (mu |F - R|^2 + ((0.5 lambda) trace) trace)
  for (int k = 0; k < 9; ++k) {
    fmr[k] = f[k] - r[k];
    e[k] = fmr[k] * fmr[k];
  }
  Lanes v, squared_norm;
  std::memcpy(&v, volume, sizeof(Lanes));
  entry_sum9(e, squared_norm);
  const Lanes half_lambda_trace = broadcast(0.5 * lambda) * trace;
  const Lanes tet_energy = v * (broadcast(mu) * squared_norm + half_lambda_trace * trace);
  std::memcpy(energy, &tet_energy, sizeof(Lanes));
  // A = (-V) ((2 mu) (F - R) + (lambda trace) R), H = A B^T with B = Dm^-1: H(i, j) = sum_k A(i, k)
  // B(j, k), rows 0 and 1 (k0 + k1) + k2, row 2 k0 + (k1 + k2) (Eigen's order, product_transposed_lanes)
  const Lanes two_mu = broadcast(2.0 * mu), lambda_trace = broadcast(lambda) * trace;
  const Lanes minus_volume = -v;
  Lanes a[9], h[9];
  for (int k = 0; k < 9; ++k) a[k] = minus_volume * (two_mu * fmr[k] + lambda_trace * r[k]);
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) {
      const Lanes p0 = a[i] * b[j][0], p1 = a[i + 3] * b[j][1], p2 = a[i + 6] * b[j][2];
      h[i + 3 * j] = i < 2 ? (p0 + p1) + p2 : p0 + (p1 + p2);
    }
  }
  rotation_batch_detail::store_entries8(h, H);  // entries 0-7 transposed, one 64-byte store per tet
}

// exact_query_stresses_avx2's operations (query_stress_kernels.cpp) in 8 lanes: F as the evaluation
// pass computes it, the extraction's iteration, R, then P = (2 mu) (F - R) + (lambda tr) R.
PLIANT_AVX512_ONLY __attribute__((flatten)) void exact_query_stresses_avx512(
    const double* x, const TetIndices* mesh_tets, const Mat3* rest_shape_inverse, const int* tets, Quat* q, double mu,
    double lambda, int max_iterations, double tolerance, Mat3* const* F, Mat3* const* R, Mat3* P) {
  using Lanes = Lanes8;
  // The query's tets are scattered over the mesh: their index sets and Dm^-1 packed first.
  TetIndices batch_tets[8];
  Mat3 batch_rest_inverse[8];
  for (int l = 0; l < 8; ++l) {
    const auto t = static_cast<size_t>(tets[l]);
    batch_tets[l] = mesh_tets[t];
    batch_rest_inverse[l] = rest_shape_inverse[t];
  }
  Lanes b[3][3], Fl[3][3];
  deformation_gradient_lanes(x, batch_tets, batch_rest_inverse, b, Fl);
  Lanes f[9];
  for (int k = 0; k < 9; ++k) f[k] = Fl[k % 3][k / 3];
  Mat3 packed[8];
  rotation_batch_detail::store_entries8(f, packed);
  for (int l = 0; l < 8; ++l) *F[l] = packed[l];
  // The extraction's iteration on these lanes (a lane taking the SVD start reads its stored F).
  Lanes qx, qy, qz, qw, count;
  rotation_batch_detail::iterate_rotation_lanes<8>(Fl, [&](int l) -> const Mat3& { return *F[l]; }, q, q,
                                                   max_iterations, tolerance, qx, qy, qz, qw, count);
  rotation_batch_detail::normalise_quaternion_lanes<8>(qx, qy, qz, qw);
  Lanes Rl[3][3], r[9], e[9];
  rotation_batch_detail::rotation_matrix_lanes<8>(qx, qy, qz, qw, Rl);
  for (int k = 0; k < 9; ++k) r[k] = Rl[k % 3][k / 3];
  rotation_batch_detail::store_entries8(r, packed);
  for (int l = 0; l < 8; ++l) *R[l] = packed[l];
  // P = (2 mu) (F - R) + (lambda tr) R, tr = sum of R .* F - 3 (first_piola_stress's operations).
  for (int k = 0; k < 9; ++k) e[k] = r[k] * f[k];
  Lanes trace;
  entry_sum9(e, trace);
  trace = trace - 3.0;
  const Lanes two_mu = broadcast(2.0 * mu), lambda_trace = broadcast(lambda) * trace;
  Lanes p[9];
  for (int k = 0; k < 9; ++k) p[k] = two_mu * (f[k] - r[k]) + lambda_trace * r[k];
  rotation_batch_detail::store_entries8(p, P);
}

#else

bool rotation_batch_avx512_available() { return false; }

void extract_rotations_batch_avx512(const Mat3* F, Quat* q, int max_iterations, double tolerance, int* iterations) {
  for (int l = 0; l < kRotationBatchLanesAvx512; ++l) {
    const int it = extract_rotation(F[l], q[l], max_iterations, tolerance);
    if (iterations != nullptr) iterations[l] = it;
  }
}

void evaluate_tets_avx512(const double*, const TetIndices*, const Mat3*, const double*, double, double, int, double,
                          const Quat*, Quat*, double*, Mat3*) {}

void exact_query_stresses_avx512(const double*, const TetIndices*, const Mat3*, const int*, Quat*, double, double, int,
                                 double, Mat3* const*, Mat3* const*, Mat3*) {}

#endif

}  // namespace pliant
