#include "sim/model/rotation_batch_avx512.h"

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
template <>
struct LaneTypes<8> {
  typedef double Lanes __attribute__((vector_size(64)));
  typedef long Mask __attribute__((vector_size(64)));
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
  /// Lane l of Fl[i][j] = F[l](i, j): one gather per entry (the eight matrices packed, 9 doubles apart).
  PLIANT_AVX512_ONLY static void load_matrices(const Mat3* F, Lanes (&Fl)[3][3]) {
    const __m512i tets = _mm512_setr_epi64(0, 9, 18, 27, 36, 45, 54, 63);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        // (the masked form: GCC 12's unmasked gather reads an uninitialised source, -Wuninitialized)
        Fl[i][j] = reinterpret_cast<Lanes>(
            _mm512_mask_i64gather_pd(_mm512_setzero_pd(), 0xff, tets, F[0].data() + i + 3 * j, 8));
      }
    }
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

#else

bool rotation_batch_avx512_available() { return false; }

void extract_rotations_batch_avx512(const Mat3* F, Quat* q, int max_iterations, double tolerance, int* iterations) {
  for (int l = 0; l < kRotationBatchLanesAvx512; ++l) {
    const int it = extract_rotation(F[l], q[l], max_iterations, tolerance);
    if (iterations != nullptr) iterations[l] = it;
  }
}

#endif

}  // namespace pliant
