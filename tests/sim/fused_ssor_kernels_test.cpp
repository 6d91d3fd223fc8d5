// The SSOR-PCG sweeps' AVX2/FMA kernels (sim/model/fused_ssor_kernels.h) against session 8's kernels,
// the default path's arithmetic that session 12 restructured (gather two blocks per turn with an
// unmasked third column, scatter two blocks per turn sharing the horizontal adds, the accumulator
// zeroed in the backward sweep instead of a memset, a fixed prefetch). Every sum must be the one
// session 8 formed, in its order, so the reference is session 8's code, kept here verbatim, and t,
// q, the accumulator and p . q must agree bit for bit. Systems: the upper-triangle block patterns of
// box meshes (the beam's 75 x 4 x 4 and a small one), fixed rows, entries over 12 decades with
// zeros and -0. Skipped on a CPU without AVX2/FMA.
#include <gtest/gtest.h>

#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "sim/mesh/box_mesh.h"
#include "sim/model/fused_ssor_kernels.h"

namespace pliant {
namespace {

#define REFERENCE_AVX2_FMA __attribute__((target("avx2,fma")))

// --- Session 8's kernels (fused_ssor_kernels.cpp at d036f38), the reference. ---

REFERENCE_AVX2_FMA __m256d reference_load3(const double* v) {
  return _mm256_maskload_pd(v, _mm256_set_epi64x(0, -1, -1, -1));
}

REFERENCE_AVX2_FMA void reference_store3(double* v, __m256d x) {
  _mm_storeu_pd(v, _mm256_castpd256_pd128(x));
  v[2] = _mm_cvtsd_f64(_mm256_extractf128_pd(x, 1));
}

REFERENCE_AVX2_FMA __m256d reference_mat_vec(const double* M, __m256d x) {
  const __m256d c = _mm256_mul_pd(_mm256_loadu_pd(M), _mm256_permute4x64_pd(x, 0x00));
  const __m256d d = _mm256_fmadd_pd(_mm256_loadu_pd(M + 3), _mm256_permute4x64_pd(x, 0x55), c);
  return _mm256_fmadd_pd(reference_load3(M + 6), _mm256_permute4x64_pd(x, 0xAA), d);
}

REFERENCE_AVX2_FMA __m256d reference_gather(const double* blocks, const int* cols, size_t first, size_t last,
                                            const double* t) {
  __m256d a0 = _mm256_setzero_pd(), a1 = _mm256_setzero_pd(), a2 = _mm256_setzero_pd();
  for (size_t b = first; b < last; ++b) {
    const double* B = blocks + 9 * b;
    const double* tj = t + 3 * static_cast<size_t>(cols[b]);
    a0 = _mm256_fmadd_pd(_mm256_loadu_pd(B), _mm256_broadcast_sd(tj), a0);
    a1 = _mm256_fmadd_pd(_mm256_loadu_pd(B + 3), _mm256_broadcast_sd(tj + 1), a1);
    a2 = _mm256_fmadd_pd(reference_load3(B + 6), _mm256_broadcast_sd(tj + 2), a2);
  }
  return _mm256_add_pd(_mm256_add_pd(a0, a1), a2);
}

REFERENCE_AVX2_FMA void reference_scatter(const double* blocks, const int* cols, size_t first, size_t last,
                                          __m256d y, double* acc) {
  for (size_t b = first; b < last; ++b) {
    const double* B = blocks + 9 * b;
    double* A = acc + 3 * static_cast<size_t>(cols[b]);
    const __m256d q0 = _mm256_mul_pd(_mm256_loadu_pd(B), y);
    const __m256d q1 = _mm256_mul_pd(_mm256_loadu_pd(B + 3), y);
    const __m256d q2 = _mm256_mul_pd(reference_load3(B + 6), y);
    const __m256d h01 = _mm256_hadd_pd(q0, q1);
    const __m256d h22 = _mm256_hadd_pd(q2, q2);
    const __m256d d = _mm256_add_pd(_mm256_permute2f128_pd(h01, h22, 0x20), _mm256_permute2f128_pd(h01, h22, 0x31));
    _mm_storeu_pd(A, _mm_add_pd(_mm_loadu_pd(A), _mm256_castpd256_pd128(d)));
    A[2] += _mm_cvtsd_f64(_mm256_extractf128_pd(d, 1));
  }
}

/// Session 8's fused_scatter_row.
REFERENCE_AVX2_FMA void reference_scatter_row(const double* blocks, const int* cols, size_t first, size_t last,
                                              double y0, double y1, double y2, double* acc) {
  reference_scatter(blocks, cols, first, last, _mm256_set_pd(0.0, y2, y1, y0), acc);
}

REFERENCE_AVX2_FMA double reference_sweeps(const FusedSsorSystem& sys, const double* p, double* t, double* q,
                                           double* acc) {
  const __m256d s = _mm256_set1_pd(sys.s);
  for (size_t i = sys.n; i-- > 0;) {
    if (sys.fixed[i] != 0) {
      t[3 * i] = p[3 * i], t[3 * i + 1] = p[3 * i + 1], t[3 * i + 2] = p[3 * i + 2];
      continue;
    }
    const __m256d a = reference_gather(sys.blocks, sys.cols, static_cast<size_t>(sys.offsets[i]) + 1,
                                       static_cast<size_t>(sys.offsets[i + 1]), t);
    reference_store3(t + 3 * i, reference_mat_vec(sys.D_inverse + 9 * i, _mm256_fnmadd_pd(s, a, reference_load3(p + 3 * i))));
  }
  std::fill(acc, acc + 3 * sys.n, 0.0);
  __m256d pq = _mm256_setzero_pd();
  for (size_t i = 0; i < sys.n; ++i) {
    const __m256d pi = reference_load3(p + 3 * i), ti = reference_load3(t + 3 * i);
    const __m256d u = _mm256_sub_pd(pi, reference_mat_vec(sys.D + 9 * i, ti));
    if (sys.fixed[i] != 0) {
      const __m256d qi = _mm256_add_pd(ti, u);
      reference_store3(q + 3 * i, qi);
      pq = _mm256_fmadd_pd(pi, qi, pq);
      continue;
    }
    const __m256d y = _mm256_blend_pd(
        reference_mat_vec(sys.D_inverse + 9 * i, _mm256_sub_pd(u, reference_load3(acc + 3 * i))), _mm256_setzero_pd(),
        0x8);
    const __m256d qi = _mm256_add_pd(ti, y);
    reference_store3(q + 3 * i, qi);
    pq = _mm256_fmadd_pd(pi, qi, pq);
    reference_scatter(sys.blocks, sys.cols, static_cast<size_t>(sys.offsets[i]) + 1,
                      static_cast<size_t>(sys.offsets[i + 1]), _mm256_mul_pd(s, y), acc);
  }
  const __m128d h = _mm_add_pd(_mm256_castpd256_pd128(pq), _mm256_extractf128_pd(pq, 1));
  return _mm_cvtsd_f64(_mm_add_sd(h, _mm_unpackhi_pd(h, h)));
}

// fused_cg_update as it was before session 15 (fused_ssor_kernels.cpp at af47300): the reference
// for the update of dv and r in flat lanes.
REFERENCE_AVX2_FMA double reference_cg_update(const FusedSsorSystem& sys, double a, const double* z, const double* q,
                                              double* dv, double* r, double* Dr) {
  const __m256d av = _mm256_set1_pd(a);
  __m256d rz = _mm256_setzero_pd();
  for (size_t i = 0; i < sys.n; ++i) {
    reference_store3(dv + 3 * i, _mm256_fmadd_pd(av, reference_load3(z + 3 * i), reference_load3(dv + 3 * i)));
    const __m256d ri = _mm256_fnmadd_pd(av, reference_load3(q + 3 * i), reference_load3(r + 3 * i));
    reference_store3(r + 3 * i, ri);
    const __m256d di = reference_mat_vec(sys.D + 9 * i, ri);
    reference_store3(Dr + 3 * i, di);
    rz = _mm256_fmadd_pd(ri, di, rz);
  }
  const __m128d h = _mm_add_pd(_mm256_castpd256_pd128(rz), _mm256_extractf128_pd(rz, 1));
  return _mm_cvtsd_f64(_mm_add_sd(h, _mm_unpackhi_pd(h, h)));
}

// --- The systems. ---

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// A box mesh's upper-triangle block pattern (row i: K'_ii, then its neighbours j > i ascending, as
// CorotationalFem stores K'), fixed rows at x = min with no upper blocks, random entries.
struct RandomSystem {
  std::vector<int> offsets{0}, cols;
  std::vector<double> blocks, D, D_inverse;
  std::vector<char> fixed;
  size_t n = 0;
  std::mt19937_64 rng;
  std::uniform_real_distribution<double> unit{-1.0, 1.0};
  std::uniform_int_distribution<int> decade{-6, 6};
  std::uniform_int_distribution<int> kind{0, 19};

  // Mostly O(1) entries, some over 12 decades, some +0 and -0.
  double entry() {
    const int k = kind(rng);
    if (k == 0) return 0.0;
    if (k == 1) return -0.0;
    if (k < 5) return unit(rng) * std::pow(10.0, decade(rng));
    return unit(rng);
  }

  // fixed_rows_keep_blocks: fixed rows keep their upper blocks, as CorotationalFem's pattern does
  // (the mesh's; the sweeps skip the row), so the forward sweep must not send through them.
  RandomSystem(int cells_x, int cells_yz, unsigned seed, bool fixed_rows_keep_blocks = false) : rng(seed) {
    const TetMeshPtr mesh = make_box_mesh({Vec3(1.0, 0.1, 0.1), cells_x, cells_yz, cells_yz});
    const std::vector<Vec3>& x = mesh->rest_positions();
    n = x.size();
    fixed.assign(n, 0);
    for (size_t i = 0; i < n; ++i) fixed[i] = x[i].x() < -0.5 + 1e-12 ? 1 : 0;
    for (size_t i = 0; i < n; ++i) {
      std::vector<int> row{static_cast<int>(i)};
      for (int j : mesh->vertex_neighbors(static_cast<int>(i))) {
        if (j > static_cast<int>(i) && (fixed[i] == 0 || fixed_rows_keep_blocks)) row.push_back(j);
      }
      std::sort(row.begin() + 1, row.end());
      cols.insert(cols.end(), row.begin(), row.end());
      offsets.push_back(static_cast<int>(cols.size()));
    }
    blocks.resize(9 * cols.size());
    for (double& b : blocks) b = entry();
    D.resize(9 * n);
    D_inverse.resize(9 * n);
    for (double& d : D) d = entry();
    for (double& d : D_inverse) d = 0.1 * unit(rng);  // keeps t bounded over the backward sweep
  }

  FusedSsorSystem system(double s) const {
    return {blocks.data(), cols.data(), offsets.data(), D.data(), D_inverse.data(), fixed.data(), s, n};
  }

  // The lower pattern (the solver's: lower_triangle_pattern) and its transposed blocks.
  LowerTrianglePattern lower;
  std::vector<double> lower_blocks;

  FusedSsorSystem gathered_system(double s) {
    lower = lower_triangle_pattern(offsets.data(), cols.data(), n);
    lower_blocks.assign(9 * lower.rows.size() + 4, std::nan(""));
    transpose_lower_blocks(blocks.data(), lower.upper_blocks.data(), lower.rows.data(), fixed.data(), lower.rows.size(),
                           lower_blocks.data());
    FusedSsorSystem fs = system(s);
    fs.lower_blocks = lower_blocks.data();
    fs.lower_rows = lower.rows.data();
    fs.lower_offsets = lower.offsets.data();
    return fs;
  }

  std::vector<double> vector() {
    std::vector<double> v(3 * n);
    for (double& e : v) e = entry();
    return v;
  }
};

// The fused sweeps and session 8's on the same system and direction, each accumulator starting
// from its own garbage (the kernels must overwrite all of it): t, q and p . q equal bit for bit, and
// the accumulator too where both kernels leave the same thing in it (not with the gathered sweep,
// whose accumulator holds s y).
void expect_sweeps_equal_reference(RandomSystem& sys, const FusedSsorSystem& fs, const std::vector<double>& p,
                                   bool compare_acc) {
  std::vector<double> t(3 * sys.n), q(3 * sys.n), acc = sys.vector();
  std::vector<double> t_ref(3 * sys.n), q_ref(3 * sys.n), acc_ref = sys.vector();
  const double pq = fused_eisenstat_sweeps(fs, p.data(), t.data(), q.data(), acc.data());
  const double pq_ref = reference_sweeps(fs, p.data(), t_ref.data(), q_ref.data(), acc_ref.data());
  EXPECT_TRUE(same_bits(t, t_ref));
  EXPECT_TRUE(same_bits(q, q_ref));
  if (compare_acc) {
    EXPECT_TRUE(same_bits(acc, acc_ref));
  }
  EXPECT_EQ(std::memcmp(&pq, &pq_ref, sizeof(double)), 0) << pq << " vs " << pq_ref;
}

// One iteration's sweeps on random systems and directions: t, q, the forward sweep's accumulator
// and p . q equal to session 8's bit for bit. The accumulator starts with garbage (the new kernel
// must zero all of it, as the memset did). FP traps are on (test_main): the restructured lanes raise
// nothing.
TEST(FusedSsorKernels, SweepsEqualSessionEightsKernelsBitForBit) {
  if (!fused_sweeps_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  struct Shape {
    int cells_x, cells_yz;
  };
  for (const Shape shape : {Shape{75, 4}, Shape{5, 2}, Shape{3, 1}}) {
    for (unsigned seed = 1; seed <= 6; ++seed) {
      RandomSystem sys(shape.cells_x, shape.cells_yz, seed);
      const double s = seed % 2 == 0 ? 1e-4 : 0.37;
      const FusedSsorSystem fs = sys.system(s);
      for (int k = 0; k < 3; ++k) {
        const std::vector<double> p = sys.vector();
        SCOPED_TRACE(testing::Message() << shape.cells_x << " seed " << seed << " k " << k);
        expect_sweeps_equal_reference(sys, fs, p, /*compare_acc=*/true);
      }
    }
  }
}

// Session 13: the forward sweep gathering from the transposed lower blocks instead of scattering.
// t, q and p . q equal to session 8's kernels bit for bit (the accumulator holds s y now, not
// compared), on patterns whose fixed rows keep their upper blocks (a fixed row must send nothing:
// its transposed blocks are zero, its s y too) and on the old ones; directions zero at fixed rows,
// as the solve's are, and not (the sweeps must still agree). The accumulator starts as garbage
// (the gathered sweep reads only what this sweep wrote). transpose_lower_blocks against the blocks
// entry by entry. FP traps are on (test_main).
TEST(FusedSsorKernels, GatheredForwardSweepEqualsSessionEightsScatterBitForBit) {
  if (!fused_sweeps_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  struct Shape {
    int cells_x, cells_yz;
    bool keep;
  };
  int checked = 0;
  for (const Shape shape : {Shape{75, 4, true}, Shape{5, 2, true}, Shape{3, 1, false}, Shape{5, 2, false}}) {
    for (unsigned seed = 1; seed <= 6; ++seed) {
      RandomSystem sys(shape.cells_x, shape.cells_yz, 100 + seed, shape.keep);
      const double s = seed % 2 == 0 ? 1e-4 : 0.37;
      const FusedSsorSystem fs = sys.gathered_system(s);
      for (size_t k = 0; k < sys.lower.rows.size(); ++k) {
        const double* L = &sys.lower_blocks[9 * k];
        const double* B = &sys.blocks[9 * static_cast<size_t>(sys.lower.upper_blocks[k])];
        const bool from_fixed = sys.fixed[static_cast<size_t>(sys.lower.rows[k])] != 0;
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) {
            const double expected = from_fixed ? 0.0 : B[c + 3 * r];  // L_rc = B_cr
            ASSERT_EQ(std::memcmp(&L[r + 3 * c], &expected, sizeof(double)), 0) << k << " " << r << " " << c;
          }
        }
      }
      for (int k = 0; k < 3; ++k) {
        std::vector<double> p = sys.vector();
        if (k != 2) {
          for (size_t i = 0; i < sys.n; ++i) {
            if (sys.fixed[i] != 0) p[3 * i] = p[3 * i + 1] = p[3 * i + 2] = 0.0;
          }
        }
        SCOPED_TRACE(testing::Message() << shape.cells_x << " seed " << seed << " k " << k);
        expect_sweeps_equal_reference(sys, fs, p, /*compare_acc=*/false);
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 72);
}

// The first transform's and the true residual's scatter (fused_scatter_row, the same scatter) row by
// row into one accumulator: equal to session 8's loop bit for bit.
TEST(FusedSsorKernels, ScatterRowEqualsSessionEightsLoopBitForBit) {
  if (!fused_sweeps_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  RandomSystem sys(75, 4, 99);
  std::vector<double> acc = sys.vector();
  std::vector<double> acc_ref = acc;
  const std::vector<double> y = sys.vector();
  for (size_t i = 0; i < sys.n; ++i) {
    const size_t first = static_cast<size_t>(sys.offsets[i]) + 1, last = static_cast<size_t>(sys.offsets[i + 1]);
    fused_scatter_row(sys.blocks.data(), sys.cols.data(), first, last, y[3 * i], y[3 * i + 1], y[3 * i + 2],
                      acc.data());
    reference_scatter_row(sys.blocks.data(), sys.cols.data(), first, last, y[3 * i], y[3 * i + 1], y[3 * i + 2],
                          acc_ref.data());
  }
  EXPECT_TRUE(same_bits(acc, acc_ref));
}


// Session 15: the sweeps indexing with the stored 3 j (LowerTrianglePattern::column_entries and
// row_entries, what the solver passes) against the same kernels forming 3 j per block visit (entries
// nullptr, the path they replace) and against session 8's kernels: t, q, the accumulator and p . q
// bit for bit, with the gathered forward sweep (which stores q and s y in whole lanes but the last
// row's: nothing written past 3 n) and with the scatter one, fixed rows keeping their blocks or not.
// The stored entries are checked against 3 j one by one.
TEST(FusedSsorKernels, StoredEntriesEqualEntriesFormedPerBlockBitForBit) {
  if (!fused_sweeps_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  struct Shape {
    int cells_x, cells_yz;
    bool keep;
  };
  int checked = 0;
  for (const Shape shape : {Shape{75, 4, true}, Shape{5, 2, false}, Shape{3, 1, true}}) {
    for (unsigned seed = 1; seed <= 4; ++seed) {
      RandomSystem sys(shape.cells_x, shape.cells_yz, 200 + seed, shape.keep);
      const double s = seed % 2 == 0 ? 1e-4 : 0.37;
      const FusedSsorSystem formed_gathered = sys.gathered_system(s);
      ASSERT_EQ(sys.lower.row_entries.size(), sys.lower.rows.size());
      ASSERT_EQ(sys.lower.column_entries.size(), sys.cols.size());
      for (size_t k = 0; k < sys.lower.rows.size(); ++k) ASSERT_EQ(sys.lower.row_entries[k], 3 * sys.lower.rows[k]);
      for (size_t b = 0; b < sys.cols.size(); ++b) ASSERT_EQ(sys.lower.column_entries[b], 3 * sys.cols[b]);
      FusedSsorSystem stored_gathered = formed_gathered;
      stored_gathered.col_entries = sys.lower.column_entries.data();
      stored_gathered.lower_row_entries = sys.lower.row_entries.data();
      FusedSsorSystem formed_scatter = sys.system(s), stored_scatter = sys.system(s);
      stored_scatter.col_entries = sys.lower.column_entries.data();
      const FusedSsorSystem pairs[2][2] = {{stored_gathered, formed_gathered}, {stored_scatter, formed_scatter}};
      for (const auto& pair : pairs) {
        const bool gathered = pair[0].lower_blocks != nullptr;
        const std::vector<double> p = sys.vector();
        SCOPED_TRACE(testing::Message() << shape.cells_x << " seed " << seed << " gathered " << gathered);
        // Four sentinel entries past each vector's end: the whole-lane stores must stop at 3 n.
        const double sentinel = 1234.5;
        std::vector<double> t(3 * sys.n + 4, sentinel), q(3 * sys.n + 4, sentinel), acc = sys.vector();
        acc.insert(acc.end(), 4, sentinel);
        std::vector<double> t_formed = t, q_formed = q, acc_formed = sys.vector();
        acc_formed.insert(acc_formed.end(), 4, sentinel);
        const double pq = fused_eisenstat_sweeps(pair[0], p.data(), t.data(), q.data(), acc.data());
        const double pq_formed =
            fused_eisenstat_sweeps(pair[1], p.data(), t_formed.data(), q_formed.data(), acc_formed.data());
        EXPECT_TRUE(same_bits(t, t_formed));
        EXPECT_TRUE(same_bits(q, q_formed));
        EXPECT_TRUE(same_bits(acc, acc_formed));
        for (const auto* v : {&t, &q, &acc}) {
          EXPECT_TRUE(std::all_of(v->end() - 4, v->end(), [&](double e) { return e == sentinel; }));
        }
        EXPECT_EQ(std::memcmp(&pq, &pq_formed, sizeof(double)), 0) << pq << " vs " << pq_formed;
        expect_sweeps_equal_reference(sys, pair[0], p, /*compare_acc=*/!gathered);
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 24);
}


// Session 15: fused_cg_update's dv += a z and r -= a q in flat 4-lane steps over the 3 n entries
// (a scalar tail when 3 n is not a multiple of 4) against the per-row masked loop it replaced: dv,
// r, D r and r . D r bit for bit, for row counts 1, 2, 3, 4, 5 (every tail length) and the box
// systems, with a of either sign and of 12 decades.
TEST(FusedSsorKernels, FlatCgUpdateEqualsRowByRowUpdateBitForBit) {
  if (!fused_sweeps_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  int checked = 0;
  for (const int cells : {75, 5, 3}) {
    RandomSystem sys(cells, cells == 75 ? 4 : 1, 300 + static_cast<unsigned>(cells));
    for (const size_t rows : {size_t{1}, size_t{2}, size_t{3}, size_t{4}, size_t{5}, sys.n}) {
      FusedSsorSystem fs = sys.system(0.37);
      fs.n = rows;
      for (const double a : {0.73, -1.9e-6, 4.1e5}) {
        SCOPED_TRACE(testing::Message() << cells << " rows " << rows << " a " << a);
        const std::vector<double> z = sys.vector(), q = sys.vector();
        std::vector<double> dv = sys.vector(), r = sys.vector(), Dr = sys.vector();
        std::vector<double> dv_ref = dv, r_ref = r, Dr_ref = Dr;
        const double rz = fused_cg_update(fs, a, z.data(), q.data(), dv.data(), r.data(), Dr.data());
        const double rz_ref =
            reference_cg_update(fs, a, z.data(), q.data(), dv_ref.data(), r_ref.data(), Dr_ref.data());
        EXPECT_TRUE(same_bits(dv, dv_ref));
        EXPECT_TRUE(same_bits(r, r_ref));
        EXPECT_TRUE(same_bits(Dr, Dr_ref));
        EXPECT_EQ(std::memcmp(&rz, &rz_ref, sizeof(double)), 0) << rz << " vs " << rz_ref;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 54);
}

// Session 16: the backward sweep's inner rows (p_i and D_i^-1's third column loaded whole, the
// prefetch from a running pointer), the forward sweep's whole third columns and fused_cg_update's
// whole-lane D r stores, on random upper patterns of 1 to
// 20 rows (so every boundary of the row loops: the last row, row 0, rows below and above the
// prefetch distance 8), rows with 0 to 4 upper blocks, random fixed rows keeping their blocks or
// not. Against session 8's kernels: t, q, p . q (and the accumulator with the scatter sweep) bit for
// bit; four sentinels before and after t, q, acc and D r untouched (no store before entry 0, the
// whole-lane stores not past 3 n). The whole loads must stay inside the exactly sized inputs: run it
// under valgrind's memcheck after changing them (docs/deformation-models.md, Session 16).
TEST(FusedSsorKernels, WholeLaneLoadsAndStoresEqualSessionEightsOnSmallPatternsBitForBit) {
  if (!fused_sweeps_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  int checked = 0;
  for (size_t n = 1; n <= 20; ++n) {
    for (unsigned seed = 1; seed <= 3; ++seed) {
      RandomSystem sys(1, 1, 400 + 10 * static_cast<unsigned>(n) + seed);  // its generator and entries
      std::uniform_int_distribution<int> upper(0, 4);
      sys.n = n;
      sys.offsets.assign(1, 0);
      sys.cols.clear();
      sys.fixed.assign(n, 0);
      for (size_t i = 0; i < n; ++i) {
        sys.fixed[i] = sys.kind(sys.rng) < 3 ? 1 : 0;
        std::vector<int> row{static_cast<int>(i)};
        if (sys.fixed[i] == 0 || seed != 2) {
          for (int k = upper(sys.rng); k > 0 && i + 1 < n; --k) {
            std::uniform_int_distribution<int> col(static_cast<int>(i) + 1, static_cast<int>(n) - 1);
            row.push_back(col(sys.rng));
          }
        }
        std::sort(row.begin() + 1, row.end());
        row.erase(std::unique(row.begin() + 1, row.end()), row.end());
        sys.cols.insert(sys.cols.end(), row.begin(), row.end());
        sys.offsets.push_back(static_cast<int>(sys.cols.size()));
      }
      // Exact sizes: the whole loads of the last row would read past them (memcheck).
      sys.blocks.resize(9 * sys.cols.size());
      for (double& b : sys.blocks) b = sys.entry();
      sys.D.resize(9 * n);
      sys.D_inverse.resize(9 * n);
      for (double& e : sys.D) e = sys.entry();
      for (double& e : sys.D_inverse) e = 0.1 * sys.unit(sys.rng);
      const double s = seed % 2 == 0 ? 1e-4 : 0.37;
      FusedSsorSystem gathered = sys.gathered_system(s);
      gathered.col_entries = sys.lower.column_entries.data();
      gathered.lower_row_entries = sys.lower.row_entries.data();
      FusedSsorSystem scatter = sys.system(s);
      scatter.col_entries = sys.lower.column_entries.data();
      for (const FusedSsorSystem* fs : {&gathered, &scatter}) {
        SCOPED_TRACE(testing::Message() << "n " << n << " seed " << seed << " gathered " << (fs == &gathered));
        const std::vector<double> p = sys.vector();
        const double sentinel = 1234.5;
        const auto padded = [&] {
          std::vector<double> v(3 * n + 8, sentinel);
          return v;
        };
        std::vector<double> t = padded(), q = padded(), acc = padded();
        std::vector<double> t_ref(3 * n), q_ref(3 * n), acc_ref = sys.vector();
        const double pq = fused_eisenstat_sweeps(*fs, p.data(), t.data() + 4, q.data() + 4, acc.data() + 4);
        const double pq_ref = reference_sweeps(*fs, p.data(), t_ref.data(), q_ref.data(), acc_ref.data());
        for (const auto* v : {&t, &q, &acc}) {
          EXPECT_TRUE(std::all_of(v->begin(), v->begin() + 4, [&](double e) { return e == sentinel; }));
          EXPECT_TRUE(std::all_of(v->end() - 4, v->end(), [&](double e) { return e == sentinel; }));
        }
        EXPECT_EQ(std::memcmp(t.data() + 4, t_ref.data(), 3 * n * sizeof(double)), 0);
        EXPECT_EQ(std::memcmp(q.data() + 4, q_ref.data(), 3 * n * sizeof(double)), 0);
        if (fs == &scatter) {
          EXPECT_EQ(std::memcmp(acc.data() + 4, acc_ref.data(), 3 * n * sizeof(double)), 0);
        }
        EXPECT_EQ(std::memcmp(&pq, &pq_ref, sizeof(double)), 0) << pq << " vs " << pq_ref;
        // The CG update after it, on the same system.
        const double a = seed == 3 ? -2.7e-3 : 0.61;
        std::vector<double> dv = sys.vector(), r = sys.vector(), Dr = padded();
        std::vector<double> dv_ref = dv, r_ref = r, Dr_ref(3 * n);
        const double rz = fused_cg_update(*fs, a, t.data() + 4, q.data() + 4, dv.data(), r.data(), Dr.data() + 4);
        const double rz_ref = reference_cg_update(*fs, a, t_ref.data(), q_ref.data(), dv_ref.data(), r_ref.data(),
                                                  Dr_ref.data());
        EXPECT_TRUE(same_bits(dv, dv_ref));
        EXPECT_TRUE(same_bits(r, r_ref));
        EXPECT_TRUE(std::all_of(Dr.begin(), Dr.begin() + 4, [&](double e) { return e == sentinel; }));
        EXPECT_TRUE(std::all_of(Dr.end() - 4, Dr.end(), [&](double e) { return e == sentinel; }));
        EXPECT_EQ(std::memcmp(Dr.data() + 4, Dr_ref.data(), 3 * n * sizeof(double)), 0);
        EXPECT_EQ(std::memcmp(&rz, &rz_ref, sizeof(double)), 0) << rz << " vs " << rz_ref;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 120);
}

}  // namespace
}  // namespace pliant
