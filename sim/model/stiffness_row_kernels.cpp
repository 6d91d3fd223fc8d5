#include "sim/model/stiffness_row_kernels.h"

#include <algorithm>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PLIANT_STIFFNESS_ROW_KERNELS 1
// AVX2 without "fma": with FMA enabled GCC would contract a * b + c (its C++ default is
// -ffp-contract=fast) and the blocks would no longer be the scalar code's.
#define PLIANT_AVX2_ONLY __attribute__((target("avx2")))
#endif

namespace pliant {

#if defined(PLIANT_STIFFNESS_ROW_KERNELS)

bool stiffness_row_kernels_available() {
  static const bool available = __builtin_cpu_supports("avx2");
  return available;
}

namespace {

// Lane selections (_mm256_permute4x64_pd immediates, lane l takes source lane (imm >> 2l) & 3) that
// put the factors of block entries 0-3 ((row, column) = (0,0) (1,0) (2,0) (0,1)) and 4-7 ((1,1)
// (2,1) (0,2) (1,2)) into their lanes.
constexpr int kRowsOf0to3 = 0x24;     ///< (0, 1, 2, 0)
constexpr int kRowsOf4to7 = 0x49;     ///< (1, 2, 0, 1)
constexpr int kColumnsOf0to3 = 0x40;  ///< (0, 0, 0, 1)
constexpr int kColumnsOf4to7 = 0xA5;  ///< (1, 1, 2, 2)
// The diagonal block's entry (r, c) is (k a_min(r,c)) a_max(r,c) (symmetric form).
constexpr int kMinOf0to3 = 0x00;  ///< (0, 0, 0, 0)
constexpr int kMaxOf0to3 = 0x64;  ///< (0, 1, 2, 1)
constexpr int kMinOf4to7 = 0x45;  ///< (1, 1, 0, 1)
constexpr int kMaxOf4to7 = 0xA9;  ///< (1, 2, 2, 2)

/// x with d added to lane 0 only (the diagonal entries 0 and 4 of a block's two vectors).
PLIANT_AVX2_ONLY inline __m256d add_to_lane0(__m256d x, double d) {
  return _mm256_blend_pd(x, _mm256_add_pd(x, _mm256_set1_pd(d)), 0x1);
}

/// B[0..7] += (lo, hi), B[8] += e8.
PLIANT_AVX2_ONLY inline void add_to_block(double* B, __m256d lo, __m256d hi, double e8) {
  _mm256_storeu_pd(B, _mm256_add_pd(_mm256_loadu_pd(B), lo));
  _mm256_storeu_pd(B + 4, _mm256_add_pd(_mm256_loadu_pd(B + 4), hi));
  B[8] += e8;
}

/// One tet's rotated gradient r_j (lanes 0..2; lane 3 is another finite entry or zero, never used).
struct CornerGradients {
  __m256d r[4];
  double s[4][3];  ///< the same values as scalars
};

}  // namespace

PLIANT_AVX2_ONLY void sum_stiffness_row(const StiffnessRowSystem& sys, size_t first_block, size_t last_block,
                                        size_t first_corner, size_t last_corner) {
  std::fill(sys.blocks + 9 * first_block, sys.blocks + 9 * last_block, 0.0);
  for (size_t c = first_corner; c < last_corner; ++c) {
    const auto t = static_cast<size_t>(sys.corners[2 * c]);
    const auto a = static_cast<size_t>(sys.corners[2 * c + 1]);
    const double* g = sys.gradients + 9 * t;  // column-major: column j = r_{j+1}
    CornerGradients r;
    r.r[1] = _mm256_loadu_pd(g);
    r.r[2] = _mm256_loadu_pd(g + 3);
    r.r[3] = _mm256_maskload_pd(g + 6, _mm256_set_epi64x(0, -1, -1, -1));  // no read past the tet
    // r_0 = -(r_1 + r_2 + r_3), summed left to right as the scalar RotatedGradients.
    // (Negated by the sign bit, as the scalar's unary minus: 0 - x would turn -0 into +0.)
    r.r[0] = _mm256_xor_pd(_mm256_set1_pd(-0.0), _mm256_add_pd(_mm256_add_pd(r.r[1], r.r[2]), r.r[3]));
    for (int k = 0; k < 3; ++k) {
      r.s[1][k] = g[k];
      r.s[2][k] = g[3 + k];
      r.s[3][k] = g[6 + k];
      r.s[0][k] = -(g[k] + g[3 + k] + g[6 + k]);
    }
    const double Vmu = sys.volume[t] * sys.mu, Vlambda = sys.volume[t] * sys.lambda;
    const __m256d vmu = _mm256_set1_pd(Vmu);
    const __m256d ra = r.r[a];
    const double* as = r.s[a];
    const __m256d a_lo = _mm256_permute4x64_pd(ra, kColumnsOf0to3), a_hi = _mm256_permute4x64_pd(ra, kColumnsOf4to7);
    // w = V lambda r_a, in the rows of entries 0-3 and 4-7.
    const __m256d w_lo = _mm256_mul_pd(_mm256_set1_pd(Vlambda), _mm256_permute4x64_pd(ra, kRowsOf0to3));
    const __m256d w_hi = _mm256_mul_pd(_mm256_set1_pd(Vlambda), _mm256_permute4x64_pd(ra, kRowsOf4to7));
    const double w2 = Vlambda * as[2];
    const int* slots = sys.tet_blocks + 16 * t + 4 * a;
    for (size_t b = 0; b < 4; ++b) {
      if (slots[b] < 0) continue;  // stored transposed, in the other vertex's row
      double* B = sys.blocks + 9 * static_cast<size_t>(slots[b]);
      if (b == a) {
        // add_diagonal_stiffness_block: k = V mu + V lambda, d = V mu |r_a|^2, entry (r, c) =
        // (k a_min) a_max, plus d on the diagonal.
        const double k = Vmu + Vlambda;
        const double d = Vmu * (as[0] * as[0] + as[1] * as[1] + as[2] * as[2]);
        const __m256d kv = _mm256_set1_pd(k);
        const __m256d lo = _mm256_mul_pd(_mm256_mul_pd(kv, _mm256_permute4x64_pd(ra, kMinOf0to3)),
                                         _mm256_permute4x64_pd(ra, kMaxOf0to3));
        const __m256d hi = _mm256_mul_pd(_mm256_mul_pd(kv, _mm256_permute4x64_pd(ra, kMinOf4to7)),
                                         _mm256_permute4x64_pd(ra, kMaxOf4to7));
        add_to_block(B, add_to_lane0(lo, d), add_to_lane0(hi, d), (k * as[2]) * as[2] + d);
        continue;
      }
      // add_stiffness_block: u = V mu r_b, entry (r, c) = (u_r a_c + w_r b_c), plus
      // d = V mu (r_a . r_b) on the diagonal.
      const __m256d rb = r.r[b];
      const double* bs = r.s[b];
      const double d = Vmu * (as[0] * bs[0] + as[1] * bs[1] + as[2] * bs[2]);
      const __m256d u_lo = _mm256_mul_pd(vmu, _mm256_permute4x64_pd(rb, kRowsOf0to3));
      const __m256d u_hi = _mm256_mul_pd(vmu, _mm256_permute4x64_pd(rb, kRowsOf4to7));
      const __m256d lo = _mm256_add_pd(_mm256_mul_pd(u_lo, a_lo),
                                       _mm256_mul_pd(w_lo, _mm256_permute4x64_pd(rb, kColumnsOf0to3)));
      const __m256d hi = _mm256_add_pd(_mm256_mul_pd(u_hi, a_hi),
                                       _mm256_mul_pd(w_hi, _mm256_permute4x64_pd(rb, kColumnsOf4to7)));
      add_to_block(B, add_to_lane0(lo, d), add_to_lane0(hi, d), ((Vmu * bs[2]) * as[2] + w2 * bs[2]) + d);
    }
  }
}

#else

bool stiffness_row_kernels_available() { return false; }

void sum_stiffness_row(const StiffnessRowSystem&, size_t, size_t, size_t, size_t) {}

#endif

}  // namespace pliant
