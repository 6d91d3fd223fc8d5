#include "sim/model/stiffness_row_kernels.h"

#include <algorithm>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PLIANT_STIFFNESS_ROW_KERNELS 1
// AVX2 without "fma": with FMA enabled GCC would contract a * b + c (its C++ default is
// -ffp-contract=fast) and the blocks would no longer be the scalar code's.
#define PLIANT_AVX2_ONLY __attribute__((target("avx2")))
#include "sim/model/matrix_entry_lanes.h"
#endif

namespace pliant {

namespace {

// The corner pairs (a, b), a < b, of a tet, in tet_block_lists' order.
constexpr int kPairA[6] = {0, 0, 0, 1, 1, 2};
constexpr int kPairB[6] = {1, 2, 3, 2, 3, 3};

}  // namespace

void tet_block_lists(const int* tet_blocks, size_t tet_count, int* lists) {
  for (size_t t = 0; t < tet_count; ++t) {
    const int* slots = tet_blocks + 16 * t;
    int* list = lists + kTetBlockListSize * t;
    int bits = 0;
    for (int k = 0; k < 16; ++k) bits |= slots[k] >= 0 ? 1 << k : 0;
    bool one_per_pair = true;
    for (int a = 0; a < 4; ++a) {
      list[1 + a] = slots[5 * a];
      one_per_pair = one_per_pair && slots[5 * a] >= 0;
    }
    for (int p = 0; p < 6; ++p) {
      const int ab = slots[4 * kPairA[p] + kPairB[p]], ba = slots[4 * kPairB[p] + kPairA[p]];
      one_per_pair = one_per_pair && ((ab >= 0) != (ba >= 0));  // a repeated vertex stores both
      list[5 + p] = std::max(ab, ba);
    }
    list[0] = one_per_pair ? bits : -1;
  }
}

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

/// (d, -0, -0, -0): added to a block's vector it adds d to lane 0 (the diagonal entries 0 and 4)
/// and leaves the other lanes as they are, signed zeros included (x + -0 = x for every x; session 12,
/// one vector for both halves instead of a broadcast, two adds and two blends).
PLIANT_AVX2_ONLY inline __m256d lane0_only(double d) {
  return _mm256_blend_pd(_mm256_set1_pd(-0.0), _mm256_set1_pd(d), 0x1);
}

/// B[0..7] += (lo, hi), B[8] += e8.
PLIANT_AVX2_ONLY inline void add_to_block(double* B, __m256d lo, __m256d hi, double e8) {
  _mm256_storeu_pd(B, _mm256_add_pd(_mm256_loadu_pd(B), lo));
  _mm256_storeu_pd(B + 4, _mm256_add_pd(_mm256_loadu_pd(B + 4), hi));
  B[8] += e8;
}

/// One tet's rotated gradients r_0..r_3, lanes 0..2 of four 4-lane vectors stored side by side
/// (lane 3 is another finite entry or zero, never used). The corner's scalar factors are read back
/// from the same stored lanes (session 11): they are the same values, so the scalar copy that summed
/// r_0 a second time is gone.
struct CornerGradients {
  alignas(32) double s[4][4];  ///< s[j][k]: component k of r_j
};

/// Tet t's rotated gradients (column-major 3x3 at g: r_1..r_3) and r_0 = -(r_1 + r_2 + r_3), summed
/// left to right as the scalar RotatedGradients, into r.
PLIANT_AVX2_ONLY inline void load_corner_gradients(const double* g, CornerGradients& r) {
  const __m256d r1 = _mm256_loadu_pd(g), r2 = _mm256_loadu_pd(g + 3);
  const __m256d r3 = _mm256_maskload_pd(g + 6, _mm256_set_epi64x(0, -1, -1, -1));  // no read past the tet
  // (Negated by the sign bit, as the scalar's unary minus: 0 - x would turn -0 into +0.)
  _mm256_store_pd(r.s[0], _mm256_xor_pd(_mm256_set1_pd(-0.0), _mm256_add_pd(_mm256_add_pd(r1, r2), r3)));
  _mm256_store_pd(r.s[1], r1);
  _mm256_store_pd(r.s[2], r2);
  _mm256_store_pd(r.s[3], r3);
}

// Adds corner a's blocks (a, b), b = 0..3, of one tet to the blocks its slots name (-1: stored
// transposed in the other vertex's row). kFlagged: only the blocks block_dirty flags.
template <bool kFlagged>
PLIANT_AVX2_ONLY inline void add_corner_blocks(const CornerGradients& r, size_t a, const int* slots, double Vmu,
                                               double Vlambda, double* blocks, const char* block_dirty) {
  const __m256d vmu = _mm256_set1_pd(Vmu);
  const __m256d ra = _mm256_load_pd(r.s[a]);
  const double* as = r.s[a];
  const __m256d a_lo = _mm256_permute4x64_pd(ra, kColumnsOf0to3), a_hi = _mm256_permute4x64_pd(ra, kColumnsOf4to7);
  // w = V lambda r_a, in the rows of entries 0-3 and 4-7.
  const __m256d w_lo = _mm256_mul_pd(_mm256_set1_pd(Vlambda), _mm256_permute4x64_pd(ra, kRowsOf0to3));
  const __m256d w_hi = _mm256_mul_pd(_mm256_set1_pd(Vlambda), _mm256_permute4x64_pd(ra, kRowsOf4to7));
  const double w2 = Vlambda * as[2];
  // Unrolled (session 12): the four slots without a loop counter, ~4 instructions per slot.
#pragma GCC unroll 4
  for (size_t b = 0; b < 4; ++b) {
    if (slots[b] < 0) continue;  // stored transposed, in the other vertex's row
    if (kFlagged && block_dirty[slots[b]] == 0) continue;  // kept: its tets did not move
    double* B = blocks + 9 * static_cast<size_t>(slots[b]);
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
      const __m256d dv = lane0_only(d);
      add_to_block(B, _mm256_add_pd(lo, dv), _mm256_add_pd(hi, dv), (k * as[2]) * as[2] + d);
      continue;
    }
    // add_stiffness_block: u = V mu r_b, entry (r, c) = (u_r a_c + w_r b_c), plus
    // d = V mu (r_a . r_b) on the diagonal.
    const __m256d rb = _mm256_load_pd(r.s[b]);
    const double* bs = r.s[b];
    const double d = Vmu * (as[0] * bs[0] + as[1] * bs[1] + as[2] * bs[2]);
    const __m256d u_lo = _mm256_mul_pd(vmu, _mm256_permute4x64_pd(rb, kRowsOf0to3));
    const __m256d u_hi = _mm256_mul_pd(vmu, _mm256_permute4x64_pd(rb, kRowsOf4to7));
    const __m256d lo = _mm256_add_pd(_mm256_mul_pd(u_lo, a_lo),
                                     _mm256_mul_pd(w_lo, _mm256_permute4x64_pd(rb, kColumnsOf0to3)));
    const __m256d hi = _mm256_add_pd(_mm256_mul_pd(u_hi, a_hi),
                                     _mm256_mul_pd(w_hi, _mm256_permute4x64_pd(rb, kColumnsOf4to7)));
    const __m256d dv = lane0_only(d);
    add_to_block(B, _mm256_add_pd(lo, dv), _mm256_add_pd(hi, dv), ((Vmu * bs[2]) * as[2] + w2 * bs[2]) + d);
  }
}

// kFlagged: only the blocks block_dirty flags are zeroed and summed; otherwise the whole row, without
// the flag tests (session 13: a step in which every tet moved spent ~10 M instructions on them).
template <bool kFlagged>
PLIANT_AVX2_ONLY inline void sum_row(const StiffnessRowSystem& sys, size_t first_block, size_t last_block,
                                     size_t first_corner, size_t last_corner, const char* block_dirty) {
  // The members in locals: the block stores could alias sys for the compiler, which then reloaded
  // them per corner and per block.
  double* const blocks = sys.blocks;
  const double* const gradients = sys.gradients;
  const double* const volume = sys.volume;
  const int* const tet_blocks = sys.tet_blocks;
  const int* const corners = sys.corners;
  const double mu = sys.mu, lambda = sys.lambda;
  if constexpr (!kFlagged) {
    std::fill(blocks + 9 * first_block, blocks + 9 * last_block, 0.0);
  } else {
    for (size_t k = first_block; k < last_block; ++k) {
      if (block_dirty[k] != 0) std::fill(blocks + 9 * k, blocks + 9 * k + 9, 0.0);
    }
  }
  for (size_t c = first_corner; c < last_corner; ++c) {
    const auto t = static_cast<size_t>(corners[2 * c]);
    const auto a = static_cast<size_t>(corners[2 * c + 1]);
    const int* slots = tet_blocks + 16 * t + 4 * a;
    if (kFlagged && !corner_adds_to_dirty_block(slots, block_dirty)) continue;
    CornerGradients r;
    load_corner_gradients(gradients + 9 * t, r);
    add_corner_blocks<kFlagged>(r, a, slots, volume[t] * mu, volume[t] * lambda, blocks, block_dirty);
  }
}

}  // namespace

PLIANT_AVX2_ONLY void sum_stiffness_row(const StiffnessRowSystem& sys, size_t first_block, size_t last_block,
                                        size_t first_corner, size_t last_corner, const char* block_dirty) {
  if (block_dirty == nullptr) {
    sum_row<false>(sys, first_block, last_block, first_corner, last_corner, nullptr);
  } else {
    sum_row<true>(sys, first_block, last_block, first_corner, last_corner, block_dirty);
  }
}

namespace {

// Session 16: four tets per call, one per lane. A regular tet (four distinct vertices) adds to ten
// distinct blocks: its four diagonal ones and, for each of its six corner pairs (a, b), a < b, the
// one stored in the row of the lower vertex, R K_xy R^T with x that pair's row corner and y the
// other (add_corner_blocks' (a, b) when slot (a, b) is stored, its (b, a) otherwise). Each lane forms
// exactly add_corner_blocks' products and sums for its tet (the row corner chosen per lane by a
// blend, whose operands are the same values); only the additions of -0 to the off-diagonal entries
// are left out (x + -0 = x for every x). The ten blocks of the four tets go to a buffer first and are
// then added tet by tet, so every block still receives its terms in ascending tet order.
using matrix_lanes::load_entries;
using matrix_lanes::store_entries;

/// The ten blocks of the regular tets t..t+3 (tet_block_lists at lists) added to their slots, tet by
/// tet.
__attribute__((target("avx2"), flatten)) inline void add_four_tets_blocks(const double* gradients,
                                                                          const double* volume, const int* lists,
                                                                          double mu, double lambda, size_t t,
                                                                          double* blocks) {
  __m256d g[9];  // g[k] lane l: entry k of tet t + l's gradients (r_1 entries 0-2, r_2 3-5, r_3 6-8)
  load_entries(gradients + 9 * t, gradients + 9 * (t + 1), gradients + 9 * (t + 2), gradients + 9 * (t + 3),
               g);
  __m256d r[4][3];  // r[j][k]: component k of r_j
  for (int k = 0; k < 3; ++k) {
    r[1][k] = g[k];
    r[2][k] = g[3 + k];
    r[3][k] = g[6 + k];
    r[0][k] = _mm256_xor_pd(_mm256_set1_pd(-0.0), _mm256_add_pd(_mm256_add_pd(g[k], g[3 + k]), g[6 + k]));
  }
  const __m256d V = _mm256_loadu_pd(volume + t);
  const __m256d Vmu = _mm256_mul_pd(V, _mm256_set1_pd(mu)),
                Vlambda = _mm256_mul_pd(V, _mm256_set1_pd(lambda));
  alignas(32) double out[4][10 * 9];  // out[l][9 k ..]: tet t + l's block k (diagonal a = k, pair k - 4)
  __m256d e[9];
  const auto store = [&](int k) {
    store_entries(e, out[0] + 9 * k, out[1] + 9 * k, out[2] + 9 * k, out[3] + 9 * k);
  };
  const __m256d k_diag = _mm256_add_pd(Vmu, Vlambda);
#pragma GCC unroll 4
  for (int a = 0; a < 4; ++a) {
    // add_corner_blocks' diagonal block: entry (r, c) = (k a_min) a_max, plus d on the diagonal.
    const __m256d* x = r[a];
    const __m256d d =
        _mm256_mul_pd(Vmu, _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(x[0], x[0]), _mm256_mul_pd(x[1], x[1])),
                                         _mm256_mul_pd(x[2], x[2])));
    const __m256d k0 = _mm256_mul_pd(k_diag, x[0]), k1 = _mm256_mul_pd(k_diag, x[1]),
                  k2 = _mm256_mul_pd(k_diag, x[2]);
    e[0] = _mm256_add_pd(_mm256_mul_pd(k0, x[0]), d);
    e[1] = e[3] = _mm256_mul_pd(k0, x[1]);
    e[2] = e[6] = _mm256_mul_pd(k0, x[2]);
    e[4] = _mm256_add_pd(_mm256_mul_pd(k1, x[1]), d);
    e[5] = e[7] = _mm256_mul_pd(k1, x[2]);
    e[8] = _mm256_add_pd(_mm256_mul_pd(k2, x[2]), d);
    store(a);
  }
  const int* list[4] = {lists + kTetBlockListSize * t, lists + kTetBlockListSize * (t + 1),
                         lists + kTetBlockListSize * (t + 2), lists + kTetBlockListSize * (t + 3)};
  const __m256i bit_lanes = _mm256_set_epi64x(list[3][0], list[2][0], list[1][0], list[0][0]);
#pragma GCC unroll 6
  for (int p = 0; p < 6; ++p) {
    const int a = kPairA[p], b = kPairB[p];
    // Sign bit of each lane: slot (a, b) stored, so a is the row corner.
    const __m256d a_first =
        _mm256_castsi256_pd(_mm256_sll_epi64(bit_lanes, _mm_cvtsi32_si128(63 - (4 * a + b))));
    __m256d x[3], y[3], u[3], w[3];
    for (int k = 0; k < 3; ++k) {
      x[k] = _mm256_blendv_pd(r[b][k], r[a][k], a_first);
      y[k] = _mm256_blendv_pd(r[a][k], r[b][k], a_first);
      u[k] = _mm256_mul_pd(Vmu, y[k]);      // V mu r_y
      w[k] = _mm256_mul_pd(Vlambda, x[k]);  // V lambda r_x
    }
    // add_corner_blocks' off-diagonal block: entry (r, c) = u_r x_c + w_r y_c, plus d = V mu (x . y)
    // on the diagonal.
    const __m256d d =
        _mm256_mul_pd(Vmu, _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(x[0], y[0]), _mm256_mul_pd(x[1], y[1])),
                                         _mm256_mul_pd(x[2], y[2])));
    for (int c = 0; c < 3; ++c) {
      for (int row = 0; row < 3; ++row) {
        const __m256d entry = _mm256_add_pd(_mm256_mul_pd(u[row], x[c]), _mm256_mul_pd(w[row], y[c]));
        e[row + 3 * c] = row == c ? _mm256_add_pd(entry, d) : entry;
      }
    }
    store(4 + p);
  }
  for (size_t l = 0; l < 4; ++l) {
#pragma GCC unroll 10
    for (int k = 0; k < 10; ++k) {
      const double* o = out[l] + 9 * k;
      add_to_block(blocks + 9 * static_cast<size_t>(list[l][1 + k]), _mm256_loadu_pd(o), _mm256_loadu_pd(o + 4),
                   o[8]);
    }
  }
}

}  // namespace

// Tet order (session 14): a block's contributions are the tets holding both of its vertices; a row
// adds them in its corners' order, ascending tet, and so does this loop. Each tet's gradients are
// loaded and r_0 formed once instead of once per corner, and there is no corner list to walk.
// Session 16: regular tets four at a time in lanes (add_four_tets_blocks); a group with a
// degenerate tet, and the last tet_count % 4, one by one as before.
PLIANT_AVX2_ONLY void sum_stiffness_by_tet(const StiffnessRowSystem& sys, size_t block_count,
                                           size_t tet_count) {
  double* const blocks = sys.blocks;
  const double* const gradients = sys.gradients;
  const double* const volume = sys.volume;
  const int* const tet_blocks = sys.tet_blocks;
  const double mu = sys.mu, lambda = sys.lambda;
  // Zeroed in lanes. The zero goes through an empty asm (no instruction) so that GCC cannot turn the
  // loop into a memset call: glibc's rep stosb counts ~1 instruction per byte under callgrind, the
  // firm measure of this kernel (the time is the same: the same 32-byte stores).
  __m256d zero = _mm256_setzero_pd();
  asm("" : "+x"(zero));
  const size_t doubles = 9 * block_count;
  size_t k = 0;
  for (; k + 4 <= doubles; k += 4) _mm256_storeu_pd(blocks + k, zero);
  for (; k < doubles; ++k) blocks[k] = 0.0;
  const auto add_tet_blocks = [&](size_t t) {
    CornerGradients r;
    load_corner_gradients(gradients + 9 * t, r);
    const double Vmu = volume[t] * mu, Vlambda = volume[t] * lambda;
#pragma GCC unroll 4
    for (size_t a = 0; a < 4; ++a) {
      add_corner_blocks<false>(r, a, tet_blocks + 16 * t + 4 * a, Vmu, Vlambda, blocks, nullptr);
    }
  };
  const int* const lists = sys.tet_block_lists;
  size_t t = 0;
  for (; t + 4 <= tet_count; t += 4) {
    const int* list = lists + kTetBlockListSize * t;
    if ((list[0] | list[kTetBlockListSize] | list[2 * kTetBlockListSize] | list[3 * kTetBlockListSize]) >= 0) {
      add_four_tets_blocks(gradients, volume, lists, mu, lambda, t, blocks);  // four regular tets
      continue;
    }
    for (size_t l = 0; l < 4; ++l) add_tet_blocks(t + l);
  }
  for (; t < tet_count; ++t) add_tet_blocks(t);
}

namespace {

/// The packed xyz triple at v in lanes 0..2, lane 3 zero (no read past the triple).
PLIANT_AVX2_ONLY inline __m256d load3(const double* v) {
  return _mm256_maskload_pd(v, _mm256_set_epi64x(0, -1, -1, -1));
}

/// (c0 x0 + c1 x1) + c2 x2 lane-wise (a 3x3 block's columns times a triple, the scalar's order).
PLIANT_AVX2_ONLY inline __m256d block_times(__m256d c0, __m256d c1, __m256d c2, const double* x) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(c0, _mm256_broadcast_sd(x)), _mm256_mul_pd(c1, _mm256_broadcast_sd(x + 1))),
                       _mm256_mul_pd(c2, _mm256_broadcast_sd(x + 2)));
}

}  // namespace

PLIANT_AVX2_ONLY void stiffness_row_product(const double* blocks, const int* cols, size_t first_block,
                                            size_t last_block, size_t i, const double* p, double* y, double* result) {
  const double* pi = p + 3 * i;
  const __m256d pv = load3(pi);
  const __m256d minus_zero = _mm256_set1_pd(-0.0);
  // Block columns: lanes 0..2 (lane 3 is the next column's first entry, or zero for the third).
  const double* D = blocks + 9 * first_block;
  __m256d yi = _mm256_add_pd(load3(y + 3 * i),
                             block_times(_mm256_loadu_pd(D), _mm256_loadu_pd(D + 3), load3(D + 6), pi));
  for (size_t b = first_block + 1; b < last_block; ++b) {
    const double* B = blocks + 9 * b;
    const __m256d c0 = _mm256_loadu_pd(B), c1 = _mm256_loadu_pd(B + 3), c2 = load3(B + 6);
    double* yj = y + 3 * static_cast<size_t>(cols[b]);
    yi = _mm256_add_pd(yi, block_times(c0, c1, c2, p + 3 * static_cast<size_t>(cols[b])));
    // (B^T p_i)_k = (B_0k pi_0 + B_1k pi_1) + B_2k pi_2: lane products, lane 3 set to -0.0, pairs.
    const __m256d q0 = _mm256_blend_pd(_mm256_mul_pd(c0, pv), minus_zero, 0x8);
    const __m256d q1 = _mm256_blend_pd(_mm256_mul_pd(c1, pv), minus_zero, 0x8);
    const __m256d q2 = _mm256_blend_pd(_mm256_mul_pd(c2, pv), minus_zero, 0x8);
    const __m256d h01 = _mm256_hadd_pd(q0, q1);  // (q0_0+q0_1, q1_0+q1_1, q0_2, q1_2)
    const __m256d h22 = _mm256_hadd_pd(q2, q2);  // (q2_0+q2_1, ., q2_2, .)
    const __m256d d = _mm256_add_pd(_mm256_permute2f128_pd(h01, h22, 0x20), _mm256_permute2f128_pd(h01, h22, 0x31));
    _mm_storeu_pd(yj, _mm_add_pd(_mm_loadu_pd(yj), _mm256_castpd256_pd128(d)));
    yj[2] += _mm_cvtsd_f64(_mm256_extractf128_pd(d, 1));
  }
  _mm_storeu_pd(result, _mm256_castpd256_pd128(yi));
  result[2] = _mm_cvtsd_f64(_mm256_extractf128_pd(yi, 1));
}

namespace {

/// Stores lanes 0..2 of x at v.
PLIANT_AVX2_ONLY inline void store3(double* v, __m256d x) {
  _mm_storeu_pd(v, _mm256_castpd256_pd128(x));
  v[2] = _mm_cvtsd_f64(_mm256_extractf128_pd(x, 1));
}

}  // namespace

// Per lower entry the transposed copy's columns are rows of K'_ji, so L a_j = (c0 a_j0 + c1 a_j1) +
// c2 a_j2 is block_times again: entry k = (B_0k a_0 + B_1k a_1) + B_2k a_2, the row product's
// transposed term (its -0.0 fourth product added to that sum changes no bit). Lane 3 of every
// product is a finite entry of the next block (or the copies' padding) times an a_j entry, never
// stored. The third column of an upper block is loaded masked (the last block has no successor).
PLIANT_AVX2_ONLY void stiffness_product_pair_gathered(const StiffnessPairSystem& sys, const double* a,
                                                      const double* b, double* ya, double* yb) {
  const double* blocks = sys.blocks;
  const int* col_entries = sys.col_entries;
  const int* offsets = sys.offsets;
  const double* lower = sys.lower;
  const int* rows = sys.lower_row_entries;
  const int* lower_offsets = sys.lower_offsets;
  const char* skip = sys.skip;
  const size_t n = sys.n;
  for (size_t i = 0; i < n; ++i) {
    if (skip[i] != 0) {
      store3(ya + 3 * i, _mm256_setzero_pd());
      store3(yb + 3 * i, _mm256_setzero_pd());
      continue;
    }
    __m256d sa = _mm256_setzero_pd(), sb = _mm256_setzero_pd();
    const auto lower_last = static_cast<size_t>(lower_offsets[i + 1]);
    for (auto k = static_cast<size_t>(lower_offsets[i]); k < lower_last; ++k) {
      const double* L = lower + 9 * k;
      const __m256d c0 = _mm256_loadu_pd(L), c1 = _mm256_loadu_pd(L + 3), c2 = _mm256_loadu_pd(L + 6);
      const auto j = static_cast<size_t>(rows[k]);
      sa = _mm256_add_pd(sa, block_times(c0, c1, c2, a + j));
      sb = _mm256_add_pd(sb, block_times(c0, c1, c2, b + j));
    }
    const auto first = static_cast<size_t>(offsets[i]), last = static_cast<size_t>(offsets[i + 1]);
    const double* D = blocks + 9 * first;  // K'_ii
    {
      const __m256d c0 = _mm256_loadu_pd(D), c1 = _mm256_loadu_pd(D + 3), c2 = load3(D + 6);
      sa = _mm256_add_pd(sa, block_times(c0, c1, c2, a + 3 * i));
      sb = _mm256_add_pd(sb, block_times(c0, c1, c2, b + 3 * i));
    }
    for (size_t k = first + 1; k < last; ++k) {
      const double* B = blocks + 9 * k;
      const __m256d c0 = _mm256_loadu_pd(B), c1 = _mm256_loadu_pd(B + 3), c2 = load3(B + 6);
      const auto j = static_cast<size_t>(col_entries[k]);
      sa = _mm256_add_pd(sa, block_times(c0, c1, c2, a + j));
      sb = _mm256_add_pd(sb, block_times(c0, c1, c2, b + j));
    }
    store3(ya + 3 * i, sa);
    store3(yb + 3 * i, sb);
  }
}

#else

bool stiffness_row_kernels_available() { return false; }

void stiffness_row_product(const double*, const int*, size_t, size_t, size_t, const double*, double*, double*) {}

void stiffness_product_pair_gathered(const StiffnessPairSystem&, const double*, const double*, double*, double*) {}

void sum_stiffness_row(const StiffnessRowSystem&, size_t, size_t, size_t, size_t, const char*) {}

void sum_stiffness_by_tet(const StiffnessRowSystem&, size_t, size_t) {}

#endif

}  // namespace pliant
