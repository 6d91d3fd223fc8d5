#include "sim/model/fused_ssor_kernels.h"

#include <algorithm>
#include <cmath>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PLIANT_FUSED_SWEEPS 1
#define PLIANT_AVX2_FMA __attribute__((target("avx2,fma")))
#endif

namespace pliant {

LowerTrianglePattern lower_triangle_pattern(const int* offsets, const int* cols, size_t n) {
  // Rows are visited ascending, so each column's list comes out ascending in the row.
  LowerTrianglePattern p;
  p.offsets.assign(n + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    for (auto k = static_cast<size_t>(offsets[i]) + 1; k < static_cast<size_t>(offsets[i + 1]); ++k) {
      p.offsets[static_cast<size_t>(cols[k]) + 1]++;
    }
  }
  for (size_t i = 0; i < n; ++i) p.offsets[i + 1] += p.offsets[i];
  p.rows.resize(static_cast<size_t>(p.offsets[n]));
  p.upper_blocks.resize(p.rows.size());
  std::vector<int> fill(p.offsets.begin(), p.offsets.end() - 1);
  for (size_t i = 0; i < n; ++i) {
    for (auto k = static_cast<size_t>(offsets[i]) + 1; k < static_cast<size_t>(offsets[i + 1]); ++k) {
      const auto slot = static_cast<size_t>(fill[static_cast<size_t>(cols[k])]++);
      p.rows[slot] = static_cast<int>(i);
      p.upper_blocks[slot] = static_cast<int>(k);
    }
  }
  p.row_entries.resize(p.rows.size());
  for (size_t k = 0; k < p.rows.size(); ++k) p.row_entries[k] = 3 * p.rows[k];
  const auto blocks = static_cast<size_t>(offsets[n]);
  p.column_entries.resize(blocks);
  for (size_t b = 0; b < blocks; ++b) p.column_entries[b] = 3 * cols[b];
  return p;
}

#if defined(PLIANT_FUSED_SWEEPS)

bool fused_sweeps_available() {
  static const bool available = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return available;
}

namespace {

/// Lanes 0..2 loaded, lane 3 zero: the third column of a block without reading past its end.
PLIANT_AVX2_FMA inline __m256d load_column3(const double* c) {
  return _mm256_maskload_pd(c, _mm256_set_epi64x(0, -1, -1, -1));
}

/// The packed xyz triple at v in lanes 0..2, lane 3 zero (no read past the triple).
PLIANT_AVX2_FMA inline __m256d load3(const double* v) { return load_column3(v); }

/// Stores lanes 0..2 at v.
PLIANT_AVX2_FMA inline void store3(double* v, __m256d x) {
  _mm_storeu_pd(v, _mm256_castpd256_pd128(x));
  v[2] = _mm_cvtsd_f64(_mm256_extractf128_pd(x, 1));
}

/// M x for a column-major 3x3 M; lane 3 of the result is not zero (callers store lanes 0..2 only
/// or multiply by a vector whose lane 3 is zero).
PLIANT_AVX2_FMA inline __m256d mat_vec(const double* M, __m256d x) {
  const __m256d c = _mm256_mul_pd(_mm256_loadu_pd(M), _mm256_permute4x64_pd(x, 0x00));
  const __m256d d = _mm256_fmadd_pd(_mm256_loadu_pd(M + 3), _mm256_permute4x64_pd(x, 0x55), c);
  return _mm256_fmadd_pd(load_column3(M + 6), _mm256_permute4x64_pd(x, 0xAA), d);
}

/// mat_vec with the third column loaded whole (session 16): its lane 3 is the entry after M's last,
/// which must exist (the next row's block: every row but the last). Lanes 0..2 are mat_vec's bit for
/// bit (the same products and FMAs); lane 3 differs, and callers that use it must not use this.
PLIANT_AVX2_FMA inline __m256d mat_vec_whole(const double* M, __m256d x) {
  const __m256d c = _mm256_mul_pd(_mm256_loadu_pd(M), _mm256_permute4x64_pd(x, 0x00));
  const __m256d d = _mm256_fmadd_pd(_mm256_loadu_pd(M + 3), _mm256_permute4x64_pd(x, 0x55), c);
  return _mm256_fmadd_pd(_mm256_loadu_pd(M + 6), _mm256_permute4x64_pd(x, 0xAA), d);
}

/// Sum of lanes 0..3.
PLIANT_AVX2_FMA inline double horizontal_sum(__m256d x) {
  const __m128d h = _mm_add_pd(_mm256_castpd256_pd128(x), _mm256_extractf128_pd(x, 1));
  return _mm_cvtsd_f64(_mm_add_sd(h, _mm_unpackhi_pd(h, h)));
}

/// Lanes 0..2 of x, lane 3 zero.
PLIANT_AVX2_FMA inline __m256d clear_lane3(__m256d x) { return _mm256_blend_pd(x, _mm256_setzero_pd(), 0x8); }

/// The end of the whole pairs in [first, last) (last >= first): a loop `b < pairs_end(...)`, b += 2,
/// tests one bound per turn (session 15: `b + 1 < last` made GCC keep a second counter).
inline size_t pairs_end(size_t first, size_t last) { return first + (last - first) / 2 * 2; }

/// acc += B t_j for one block: one FMA per block column into its own accumulator (a0, a1, a2). Each
/// column is a full 4-lane load; lane 3 is the next column's first entry, for the third column the
/// next block's: a finite product that is never stored. In bounds for every upper block, since the
/// block after it is another upper block or the next row's diagonal one (every row starts with K'_ii
/// and the last row has no upper blocks).
PLIANT_AVX2_FMA inline void gather_block(const double* B, const double* tj, __m256d& a0, __m256d& a1, __m256d& a2) {
  a0 = _mm256_fmadd_pd(_mm256_loadu_pd(B), _mm256_broadcast_sd(tj), a0);
  a1 = _mm256_fmadd_pd(_mm256_loadu_pd(B + 3), _mm256_broadcast_sd(tj + 1), a1);
  a2 = _mm256_fmadd_pd(_mm256_loadu_pd(B + 6), _mm256_broadcast_sd(tj + 2), a2);
}

/// sum_b B_b t_{cols[b]} over [first, last) (lane 3 not zero), the vertex's first entry in t being
/// kStride index[b]: index is cols with kStride 3, or the stored 3 cols (kStride 1, session 15: no
/// multiply per block). Three accumulators (one per block column) keep the FMA chains independent:
/// 4 cycles per block instead of 12. Each accumulator takes the blocks in ascending order, one FMA
/// each, as session 8's loop (the same bits); the loop runs two blocks per turn (session 12: fewer
/// loop instructions per block).
template <size_t kStride>
PLIANT_AVX2_FMA inline __m256d gather(const double* blocks, const int* index, size_t first, size_t last,
                                      const double* t) {
  __m256d a0 = _mm256_setzero_pd(), a1 = _mm256_setzero_pd(), a2 = _mm256_setzero_pd();
  size_t b = first;
  for (const size_t pairs = pairs_end(first, last); b < pairs; b += 2) {
    gather_block(blocks + 9 * b, t + kStride * static_cast<size_t>(index[b]), a0, a1, a2);
    gather_block(blocks + 9 * (b + 1), t + kStride * static_cast<size_t>(index[b + 1]), a0, a1, a2);
  }
  if (b < last) gather_block(blocks + 9 * b, t + kStride * static_cast<size_t>(index[b]), a0, a1, a2);
  return _mm256_add_pd(_mm256_add_pd(a0, a1), a2);
}

/// The lane products of a block's columns with y (the third column masked: its lane 3 is +0 x y_3).
struct ColumnProducts {
  __m256d q0, q1, q2;
};

/// c_k * y lane-wise for the three columns of the block at B.
PLIANT_AVX2_FMA inline ColumnProducts column_products(const double* B, __m256d y) {
  return {_mm256_mul_pd(_mm256_loadu_pd(B), y), _mm256_mul_pd(_mm256_loadu_pd(B + 3), y),
          _mm256_mul_pd(load_column3(B + 6), y)};
}

/// acc_{cols[b]} += B_b^T y over [first, last); y's lane 3 must be zero. (B^T y)_k =
/// (q_k0 + q_k1) + (q_k2 + q_k3) with q_k = c_k * y: hadd forms the pairs, the 128-bit halves are
/// added. Two blocks per turn (session 12) share the hadds: (c0, c1) of each block and the two
/// blocks' c2 are paired, so 3 hadds and one add give both blocks' sums where one block alone took
/// 2 and 1; every sum is the one-block loop's (the same pairs in the same order, the same bits).
/// The two blocks of a turn are different columns of one row, so their accumulators do not alias.
PLIANT_AVX2_FMA inline void scatter(const double* blocks, const int* cols, size_t first, size_t last, __m256d y,
                                    double* acc) {
  size_t b = first;
  for (const size_t pairs = pairs_end(first, last); b < pairs; b += 2) {
    const ColumnProducts e = column_products(blocks + 9 * b, y), f = column_products(blocks + 9 * (b + 1), y);
    double* A = acc + 3 * static_cast<size_t>(cols[b]);
    double* C = acc + 3 * static_cast<size_t>(cols[b + 1]);
    const __m256d he = _mm256_hadd_pd(e.q0, e.q1);  // (e0 lo, e1 lo, e0 hi, e1 hi): pair sums
    const __m256d hf = _mm256_hadd_pd(f.q0, f.q1);
    const __m256d h2 = _mm256_hadd_pd(e.q2, f.q2);  // (e2 lo, f2 lo, e2 hi, f2 hi)
    // (A_0, A_1, C_0, C_1) and (A_2, C_2): lo + hi of each pair.
    const __m256d d01 = _mm256_add_pd(_mm256_permute2f128_pd(he, hf, 0x20), _mm256_permute2f128_pd(he, hf, 0x31));
    const __m128d d2 = _mm_add_pd(_mm256_castpd256_pd128(h2), _mm256_extractf128_pd(h2, 1));
    _mm_storeu_pd(A, _mm_add_pd(_mm_loadu_pd(A), _mm256_castpd256_pd128(d01)));
    A[2] += _mm_cvtsd_f64(d2);
    _mm_storeu_pd(C, _mm_add_pd(_mm_loadu_pd(C), _mm256_extractf128_pd(d01, 1)));
    C[2] += _mm_cvtsd_f64(_mm_unpackhi_pd(d2, d2));
  }
  if (b < last) {
    const ColumnProducts e = column_products(blocks + 9 * b, y);
    double* A = acc + 3 * static_cast<size_t>(cols[b]);
    const __m256d h01 = _mm256_hadd_pd(e.q0, e.q1);  // (q0_0+q0_1, q1_0+q1_1, q0_2+q0_3, q1_2+q1_3)
    const __m256d h22 = _mm256_hadd_pd(e.q2, e.q2);  // (q2_0+q2_1, ., q2_2+q2_3, .)
    const __m256d d = _mm256_add_pd(_mm256_permute2f128_pd(h01, h22, 0x20), _mm256_permute2f128_pd(h01, h22, 0x31));
    _mm_storeu_pd(A, _mm_add_pd(_mm_loadu_pd(A), _mm256_castpd256_pd128(d)));
    A[2] += _mm_cvtsd_f64(_mm256_extractf128_pd(d, 1));
  }
}

/// x as it is, hidden from the optimiser: this file is compiled with "fma" and GCC contracts a * b + c
/// into one FMA (-ffp-contract=fast), which would round differently; a product passed through here
/// is rounded on its own, as the scatter's (no instruction is emitted).
PLIANT_AVX2_FMA inline __m256d rounded(__m256d x) {
  asm("" : "+x"(x));
  return x;
}

/// L y for one transposed block L = K'_ji^T (column m = row m of K'_ji; the fourth lane of each
/// 4-lane load is the next entry, a finite product never used) and y = s y_j: entry k =
/// (L_k0 y_0 + L_k1 y_1) + L_k2 y_2 = (B_0k y_0 + B_1k y_1) + B_2k y_2, the scatter's sum for
/// (B^T y)_k: the same products paired in the same order (the scatter's fourth term q_k3 = B_3k * 0
/// is a zero, which can change only the sign of a zero sum, and acc + (+-0) is acc: acc starts at
/// +0 and a sum is -0 only when both addends are).
PLIANT_AVX2_FMA inline __m256d transposed_block_product(const double* L, const double* y) {
  const __m256d p0 = rounded(_mm256_mul_pd(_mm256_loadu_pd(L), _mm256_broadcast_sd(y)));
  const __m256d p1 = rounded(_mm256_mul_pd(_mm256_loadu_pd(L + 3), _mm256_broadcast_sd(y + 1)));
  const __m256d p2 = rounded(_mm256_mul_pd(_mm256_loadu_pd(L + 6), _mm256_broadcast_sd(y + 2)));
  return _mm256_add_pd(_mm256_add_pd(p0, p1), p2);
}

/// sum_k L_k sy_{rows[k]} over [first, last), k ascending (j ascending): acc_i as the scatter leaves
/// it, each block's product added in the order the rows before i sent theirs (lane 3 not zero).
/// Row j's first entry in sy is kStride index[k] (index: rows with kStride 3, or the stored 3 rows
/// with kStride 1, as gather). Two blocks per turn (fewer loop instructions per block; the adds stay
/// in order).
template <size_t kStride>
PLIANT_AVX2_FMA inline __m256d gather_lower(const double* lower, const int* index, size_t first, size_t last,
                                            const double* sy) {
  __m256d a = _mm256_setzero_pd();
  size_t k = first;
  for (const size_t pairs = pairs_end(first, last); k < pairs; k += 2) {
    a = _mm256_add_pd(a,
                      transposed_block_product(lower + 9 * k, sy + kStride * static_cast<size_t>(index[k])));
    a = _mm256_add_pd(
        a, transposed_block_product(lower + 9 * (k + 1), sy + kStride * static_cast<size_t>(index[k + 1])));
  }
  if (k < last)
    a = _mm256_add_pd(a,
                      transposed_block_product(lower + 9 * k, sy + kStride * static_cast<size_t>(index[k])));
  return a;
}

/// Prefetches the blocks of row k (session 7: the hardware prefetcher misses the backward sweep's
/// descending stream), a line every 128 bytes to the row's end. (Session 12 measured five fixed
/// lines without the loop: 17 instructions fewer per row but the backward sweep ~10% slower at the
/// beam's size, docs/deformation-models.md; kept as it was.)
PLIANT_AVX2_FMA inline void prefetch_row(const double* blocks, const int* offsets, size_t k) {
  const auto* line = reinterpret_cast<const char*>(blocks + 9 * static_cast<size_t>(offsets[k]));
  const auto* end = reinterpret_cast<const char*>(blocks + 9 * static_cast<size_t>(offsets[k + 1]));
  for (; line < end; line += 128) _mm_prefetch(line, _MM_HINT_T0);
}

/// Stores x's lanes 0..2 at v (kWholeLanes false), or all four (true: lane 3 lands on v[3], which
/// the caller overwrites later; one store instead of three).
template <bool kWholeLanes>
PLIANT_AVX2_FMA inline void store_row(double* v, __m256d x) {
  if constexpr (kWholeLanes) {
    _mm256_storeu_pd(v, x);
  } else {
    store3(v, x);
  }
}

/// The pointers the forward sweep reads, copied out of the system (the stores through q and sy
/// could alias it for the compiler, which then reloads them per row).
struct ForwardSweepData {
  const double* lower;
  const int* rows;
  const int* offsets;
  const double* D;
  const double* D_inverse;
  const char* fixed;
};

/// Row i of the gathered forward sweep: q_i and s y_i stored, p_i . q_i added to pq (returned).
/// kWholeLanes (every row but the last, session 15): q_i and s y_i are stored as four lanes, the
/// fourth landing on row i + 1's first entry, which row i + 1 stores before anything reads it (its
/// gather reads s y_j of rows j < i + 1 only). Such a row also has a next row, so D_i's and
/// D_i^-1's third columns are loaded whole (session 16, mat_vec_whole: one instruction fewer each);
/// lanes 0..2 are mat_vec's, and the lane 3 this leaves in u (now also a product with the next
/// row's first entry) is cleared before it reaches q on a fixed row (y's lane 3 is cleared anyway),
/// so q, s y and p . q do not depend on what the next row holds.
template <size_t kStride, bool kWholeLanes>
PLIANT_AVX2_FMA inline __m256d forward_row(const ForwardSweepData& d, size_t i, const double* p, const double* t,
                                           double* q, double* sy, __m256d s, __m256d pq) {
  const __m256d pi = load3(p + 3 * i), ti = load3(t + 3 * i);
  const __m256d u = _mm256_sub_pd(pi, kWholeLanes ? mat_vec_whole(d.D + 9 * i, ti) : mat_vec(d.D + 9 * i, ti));
  if (d.fixed[i] != 0) {  // y = u, nothing sent
    const __m256d qi = _mm256_add_pd(ti, kWholeLanes ? clear_lane3(u) : u);
    store_row<kWholeLanes>(q + 3 * i, qi);
    store_row<kWholeLanes>(sy + 3 * i, _mm256_setzero_pd());
    return _mm256_fmadd_pd(pi, qi, pq);
  }
  const __m256d a = gather_lower<kStride>(d.lower, d.rows, static_cast<size_t>(d.offsets[i]),
                                          static_cast<size_t>(d.offsets[i + 1]), sy);
  const __m256d x = _mm256_sub_pd(u, a);
  const __m256d y = clear_lane3(kWholeLanes ? mat_vec_whole(d.D_inverse + 9 * i, x) : mat_vec(d.D_inverse + 9 * i, x));
  const __m256d qi = _mm256_add_pd(ti, y);
  store_row<kWholeLanes>(q + 3 * i, qi);
  store_row<kWholeLanes>(sy + 3 * i, _mm256_mul_pd(s, y));
  return _mm256_fmadd_pd(pi, qi, pq);
}

/// The forward sweep with the lower blocks (session 13): row i gathers acc_i = sum_{j < i} L_ij s y_j
/// from the s y_j the rows before it stored in acc (a fixed row stores zeros, and its transposed
/// blocks are zero), instead of the rows before it scattering into acc_i. Every other value is the
/// scatter loop's expression; returns p . q. rows: lower_rows (kStride 3) or lower_row_entries (1).
template <size_t kStride>
PLIANT_AVX2_FMA double forward_sweep_gathered(const FusedSsorSystem& sys, const int* rows, const double* p,
                                              const double* t, double* q, double* sy) {
  const ForwardSweepData d{sys.lower_blocks, rows, sys.lower_offsets, sys.D, sys.D_inverse, sys.fixed};
  const size_t n = sys.n;
  const __m256d s = _mm256_set1_pd(sys.s);
  __m256d pq = _mm256_setzero_pd();
  if (n == 0) return 0.0;
  for (size_t i = 0; i + 1 < n; ++i) pq = forward_row<kStride, true>(d, i, p, t, q, sy, s, pq);
  pq = forward_row<kStride, false>(d, n - 1, p, t, q, sy, s, pq);
  return horizontal_sum(pq);
}

/// The pointers the backward sweep reads, copied out of the system (as ForwardSweepData).
struct BackwardSweepData {
  const double* blocks;
  const int* offsets;
  const double* D_inverse;
  const char* fixed;
};

/// Rows ahead of the backward sweep whose blocks it asks the cache for (session 7).
constexpr size_t kPrefetchRows = 8;

/// Row i of the backward sweep: t_i = D_i^-1 (p_i - s sum_{j > i} K'_ij t_j), or p_i on a fixed row;
/// zeroes acc_i when the forward sweep scatters into it (kZeroAcc). kInner (session 16; every row
/// but the last): p_i and D_i^-1's third column are loaded whole, one instruction fewer each (their lane 3
/// is row i + 1's first entry: it reaches only lane 3 of the result, which mat_vec never reads and
/// store3 drops). Lanes 0..2 are the masked path's bit for bit. (t_i stored as four lanes one entry
/// down, a lane permute and one store instead of three instructions, was 3% slower in time: the
/// permute sits on the sweep's serial chain, t_i -> row i - 1's gather; docs/deformation-models.md.)
template <size_t kStride, bool kZeroAcc, bool kInner>
PLIANT_AVX2_FMA inline void backward_row(const BackwardSweepData& d, const int* cols, size_t i, const double* p,
                                         double* t, double* acc, __m256d s) {
  if (kZeroAcc) store3(acc + 3 * i, _mm256_setzero_pd());
  if (d.fixed[i] != 0) {
    t[3 * i] = p[3 * i], t[3 * i + 1] = p[3 * i + 1], t[3 * i + 2] = p[3 * i + 2];
    return;
  }
  const __m256d a = gather<kStride>(d.blocks, cols, static_cast<size_t>(d.offsets[i]) + 1,
                                    static_cast<size_t>(d.offsets[i + 1]), t);
  if constexpr (kInner) {
    store3(t + 3 * i, mat_vec_whole(d.D_inverse + 9 * i, _mm256_fnmadd_pd(s, a, _mm256_loadu_pd(p + 3 * i))));
  } else {
    store3(t + 3 * i, mat_vec(d.D_inverse + 9 * i, _mm256_fnmadd_pd(s, a, load3(p + 3 * i))));
  }
}

/// The backward sweep t = (D + L^T)^-1 p, rows descending, each row's blocks prefetched 8 rows
/// ahead. cols: sys.cols (kStride 3) or sys.col_entries (kStride 1). Session 16: the last row by the
/// masked path, the rows below it by the inner one; the rows from n - 2 down to 8
/// prefetch row i - 8's blocks from a running pointer (that row's lines end where row i - 7's begin,
/// the previous turn's start: the same lines as prefetch_row), the rows below 8 in a loop without
/// the test.
template <size_t kStride, bool kZeroAcc>
PLIANT_AVX2_FMA void backward_sweep(const FusedSsorSystem& sys, const int* cols, const double* p, double* t,
                                    double* acc) {
  const BackwardSweepData d{sys.blocks, sys.offsets, sys.D_inverse, sys.fixed};
  const size_t n = sys.n;
  const __m256d s = _mm256_set1_pd(sys.s);
  if (n == 0) return;
  const size_t last = n - 1;
  if (last >= kPrefetchRows) prefetch_row(d.blocks, d.offsets, last - kPrefetchRows);
  backward_row<kStride, kZeroAcc, false>(d, cols, last, p, t, acc, s);
  if (last == 0) return;
  size_t i = last - 1;
  if (i >= kPrefetchRows) {
    const auto line_of = [&](size_t k) {
      return reinterpret_cast<const char*>(d.blocks + 9 * static_cast<size_t>(d.offsets[k]));
    };
    const char* end = line_of(i - kPrefetchRows + 1);
    for (; i >= kPrefetchRows; --i) {
      const char* start = line_of(i - kPrefetchRows);
      for (const char* line = start; line < end; line += 128) _mm_prefetch(line, _MM_HINT_T0);
      end = start;
      backward_row<kStride, kZeroAcc, true>(d, cols, i, p, t, acc, s);
    }
  }
  for (size_t k = i + 1; k-- > 0;) backward_row<kStride, kZeroAcc, true>(d, cols, k, p, t, acc, s);
}

}  // namespace

// (B^T y)_k = c_k . y for the columns c_k: the products c_k * y lane-wise (y's lane 3 zero, so the
// loaded fourth entries drop out), then hadd pairs (c0, c1) and (c2, c2), and the 128-bit halves
// added: lanes 0..2 hold the three dot products.
PLIANT_AVX2_FMA void fused_scatter_row(const double* blocks, const int* cols, size_t first, size_t last, double y0,
                                       double y1, double y2, double* acc) {
  scatter(blocks, cols, first, last, _mm256_set_pd(0.0, y2, y1, y0), acc);
}

// Rows descending for t (backward_sweep); then rows ascending for q, gathering from the lower
// blocks (forward_sweep_gathered) or with the transposed blocks scattered (below). The forward sweep's
// accumulator is zeroed row by row in the backward sweep (session 12; before, a memset between the sweeps:
// the same +0.0 in every entry, and nothing reads acc before the forward sweep). The system's members are
// copied into locals: the stores through t, q and acc could alias sys for the compiler, which then reloaded
// them per row.
PLIANT_AVX2_FMA double fused_eisenstat_sweeps(const FusedSsorSystem& sys, const double* p, double* t, double* q,
                                              double* acc) {
  const bool gathered = sys.lower_blocks != nullptr;
  if (gathered) {
    if (sys.col_entries != nullptr) {
      backward_sweep<1, false>(sys, sys.col_entries, p, t, acc);
    } else {
      backward_sweep<3, false>(sys, sys.cols, p, t, acc);
    }
  } else if (sys.col_entries != nullptr) {
    backward_sweep<1, true>(sys, sys.col_entries, p, t, acc);
  } else {
    backward_sweep<3, true>(sys, sys.cols, p, t, acc);
  }
  if (gathered) {
    return sys.lower_row_entries != nullptr
               ? forward_sweep_gathered<1>(sys, sys.lower_row_entries, p, t, q, acc)
               : forward_sweep_gathered<3>(sys, sys.lower_rows, p, t, q, acc);
  }
  const int* cols = sys.cols;
  const int* offsets = sys.offsets;
  const double* blocks = sys.blocks;
  const double* D = sys.D;
  const double* D_inverse = sys.D_inverse;
  const char* fixed = sys.fixed;
  const size_t n = sys.n;
  const __m256d s = _mm256_set1_pd(sys.s);
  __m256d pq = _mm256_setzero_pd();
  for (size_t i = 0; i < n; ++i) {
    const __m256d pi = load3(p + 3 * i), ti = load3(t + 3 * i);
    const __m256d u = _mm256_sub_pd(pi, mat_vec(D + 9 * i, ti));
    if (fixed[i] != 0) {  // y = u, nothing sent
      const __m256d qi = _mm256_add_pd(ti, u);
      store3(q + 3 * i, qi);
      pq = _mm256_fmadd_pd(pi, qi, pq);
      continue;
    }
    const __m256d y = clear_lane3(mat_vec(D_inverse + 9 * i, _mm256_sub_pd(u, load3(acc + 3 * i))));
    const __m256d qi = _mm256_add_pd(ti, y);
    store3(q + 3 * i, qi);
    pq = _mm256_fmadd_pd(pi, qi, pq);
    scatter(blocks, cols, static_cast<size_t>(offsets[i]) + 1, static_cast<size_t>(offsets[i + 1]),
            _mm256_mul_pd(s, y), acc);
  }
  return horizontal_sum(pq);
}

PLIANT_AVX2_FMA double fused_cg_update(const FusedSsorSystem& sys, double a, const double* z, const double* q,
                                       double* dv, double* r, double* Dr) {
  // dv += a z and r -= a q entry by entry, four entries per instruction (session 15: before, a row's
  // three in masked lanes; each entry is the same FMA, so the same bits, in fewer loads and stores).
  const __m256d av = _mm256_set1_pd(a);
  const size_t m = 3 * sys.n, whole = m / 4 * 4;
  size_t k = 0;
  for (; k < whole; k += 4) {
    _mm256_storeu_pd(dv + k, _mm256_fmadd_pd(av, _mm256_loadu_pd(z + k), _mm256_loadu_pd(dv + k)));
    _mm256_storeu_pd(r + k, _mm256_fnmadd_pd(av, _mm256_loadu_pd(q + k), _mm256_loadu_pd(r + k)));
  }
  for (; k < m; ++k) {
    dv[k] = std::fma(a, z[k], dv[k]);
    r[k] = std::fma(-a, q[k], r[k]);
  }
  // D r and r . D r row by row (lane 3 of r_i zero, as the masked update left it). Every row but the
  // last stores D r_i as four lanes (session 16: one store instead of three), the fourth landing on
  // row i + 1's first entry, which row i + 1 stores next.
  __m256d rz = _mm256_setzero_pd();
  const size_t n = sys.n;
  const double* D = sys.D;
  for (size_t i = 0; i + 1 < n; ++i) {
    const __m256d ri = load3(r + 3 * i);
    const __m256d di = mat_vec(D + 9 * i, ri);
    _mm256_storeu_pd(Dr + 3 * i, di);
    rz = _mm256_fmadd_pd(ri, di, rz);
  }
  if (n > 0) {
    const __m256d ri = load3(r + 3 * (n - 1));
    const __m256d di = mat_vec(D + 9 * (n - 1), ri);
    store3(Dr + 3 * (n - 1), di);
    rz = _mm256_fmadd_pd(ri, di, rz);
  }
  return horizontal_sum(rz);
}

PLIANT_AVX2_FMA void fused_direction_update(size_t n, const double* Dr, double b, double* p) {
  const __m256d bv = _mm256_set1_pd(b);
  const size_t m = 3 * n, whole = m / 4 * 4;
  size_t k = 0;
  for (; k < whole; k += 4) {
    _mm256_storeu_pd(p + k, _mm256_fmadd_pd(bv, _mm256_loadu_pd(p + k), _mm256_loadu_pd(Dr + k)));
  }
  for (; k < m; ++k) p[k] = Dr[k] + b * p[k];
}

// Block by block: (B0 B1 B2 B3) and (B4 B5 B6 B7) in two registers; swapping lane 2 between them
// and exchanging lanes 1 and 3 of each gives (B0 B3 B6 B1) and (B4 B7 B2 B5), the transpose's first
// eight entries (entry 8 stays where it is). Copies only: every bit as it was.
PLIANT_AVX2_FMA void transpose_lower_blocks(const double* blocks, const int* upper_blocks, const int* lower_rows,
                                            const char* fixed, size_t count, double* out) {
  for (size_t k = 0; k < count; ++k, out += 9) {
    if (fixed[lower_rows[k]] != 0) {
      std::fill(out, out + 9, 0.0);
      continue;
    }
    const double* B = blocks + 9 * static_cast<size_t>(upper_blocks[k]);
    const __m256d lo = _mm256_loadu_pd(B), hi = _mm256_loadu_pd(B + 4);
    _mm256_storeu_pd(out, _mm256_permute4x64_pd(_mm256_blend_pd(lo, hi, 0x4), 0x6C));      // lanes (0, 3, 2, 1)
    _mm256_storeu_pd(out + 4, _mm256_permute4x64_pd(_mm256_blend_pd(hi, lo, 0x4), 0x6C));  // lanes (0, 3, 2, 1)
    out[8] = B[8];
  }
  std::fill(out, out + 4, 0.0);
}

#else

bool fused_sweeps_available() { return false; }

void fused_scatter_row(const double*, const int*, size_t, size_t, double, double, double, double*) {}

double fused_eisenstat_sweeps(const FusedSsorSystem&, const double*, double*, double*, double*) { return 0.0; }

double fused_cg_update(const FusedSsorSystem&, double, const double*, const double*, double*, double*, double*) {
  return 0.0;
}

void fused_direction_update(size_t, const double*, double, double*) {}

void transpose_lower_blocks(const double*, const int*, const int*, const char*, size_t, double*) {}

#endif

}  // namespace pliant
