// The SSOR sweeps' per-block kernels with fused multiply-adds in 256-bit lanes (AVX2 + FMA),
// chosen at run time (session 8, issue #3). Design note: the exact sweeps
// (corotational_fem.cpp, SsorSweeps) evaluate every 3x3 block product in scalar (or paired SSE2)
// arithmetic in one fixed order, ~35 instructions per block visit. Here a block's three columns
// are one 4-lane load each (the fourth lane is ignored or masked to zero):
//   gather  a += B t_j   (backward sweep): three FMAs into three accumulators, one per column;
//   scatter acc_j += B^T y (forward sweep): the column dot products c_k . y by two horizontal adds;
//   or (session 13, what the solver runs) the forward sweep gathers acc_i = sum_j L_ij s y_j from a
//   transposed copy of the blocks in lower-triangle rows: three products and adds, the same sums.
// The sums are the same but rounded differently (FMA keeps the product unrounded, the order of
// the terms differs), so the solve's iterates differ from the exact path's in the last bits and
// the CG residual test decides the rest: an approximation under the project's rule (tolerance,
// measured bound and test in docs/deformation-models.md "Session 8"; CorotationalFem's
// set_fused_sweeps(false) is the exact path bit for bit). Compiled for avx2/fma by function
// attribute, so the portable build keeps running on CPUs without them (fused_sweeps_available()).
#pragma once

#include <cstddef>
#include <vector>

namespace pliant {

/// True when this CPU runs the AVX2 + FMA kernels below.
bool fused_sweeps_available();

/// The lower triangle of a block-symmetric matrix stored as its upper triangle (row i: blocks
/// [offsets[i], offsets[i + 1]), the diagonal first, then the columns j > i): per row i, the stored
/// blocks (j, i), j < i, ascending j.
struct LowerTrianglePattern {
  std::vector<int> offsets;       ///< n + 1: row i's entries are [offsets[i], offsets[i + 1])
  std::vector<int> rows;          ///< per entry, its row j in the upper storage
  std::vector<int> upper_blocks;  ///< per entry, its block index in the upper storage
  /// Session 15: the packed-vector indices the sweeps read, stored so that the kernels form no 3 j
  /// per block visit: per entry 3 rows[k].
  std::vector<int> row_entries;
  std::vector<int> column_entries;  ///< per upper block b (the diagonal ones too): 3 cols[b]
};

/// Builds the pattern by a counting sort over the columns (any CPU).
LowerTrianglePattern lower_triangle_pattern(const int* offsets, const int* cols, size_t n);

/// acc_{cols[b]} += B_b^T y for blocks b in [first, last) (acc packed xyz per vertex). Only on a
/// CPU where fused_sweeps_available().
void fused_scatter_row(const double* blocks, const int* cols, size_t first, size_t last, double y0, double y1,
                       double y2, double* acc);

/// The system of the SSOR sweeps (SsorSweeps in corotational_fem.cpp): A = D + L + L^T with the
/// upper blocks s K'_ij in CSR rows (row i: [offsets[i], offsets[i + 1]), the first K'_ii), 3x3
/// diagonal blocks D_i and their inverses (column-major), fixed rows decoupled (D_i = I).
struct FusedSsorSystem {
  const double* blocks;     ///< K' upper-triangle blocks, column-major 3x3
  const int* cols;          ///< block column (vertex) index
  const int* offsets;       ///< n + 1 row offsets
  const double* D;          ///< n diagonal blocks of A
  const double* D_inverse;  ///< their inverses
  const char* fixed;        ///< nonzero: a fixed (decoupled) row
  double s;                 ///< h (beta + h)
  size_t n;                 ///< rows (vertices)
  /// Optional (session 13): the transposed upper blocks by row of A's lower triangle, L_ik =
  /// K'_ji^T for the blocks (j, i), j < i, ascending j (transpose_lower_blocks); with them the
  /// forward sweep gathers row i's sum from the rows before it instead of scattering row j's into
  /// the rows after it, the same sums in the same order. nullptr: the scatter.
  const double* lower_blocks = nullptr;
  const int* lower_rows = nullptr;     ///< the row j of each lower block
  const int* lower_offsets = nullptr;  ///< n + 1 offsets: row i's lower blocks [lower_offsets[i], lower_offsets[i + 1])
  /// Optional (session 15): 3 cols[b] per block (LowerTrianglePattern::column_entries), which the
  /// backward sweep's gather indexes with. nullptr: 3 cols[b] formed per visit (the same values).
  const int* col_entries = nullptr;
  /// Optional (session 15): 3 lower_rows[k] per lower block (LowerTrianglePattern::row_entries), for
  /// the gathered forward sweep. nullptr: formed per visit.
  const int* lower_row_entries = nullptr;
};

/// out's block k = K'_ji^T for the upper block upper_blocks[k] = (j, i), j = lower_rows[k]
/// (column-major 3x3, so its column m is row m of K'_ji), or zero when row j is fixed (a fixed row
/// sends nothing in the forward sweep). out holds 9 count + 4 doubles: the last four are zeroed
/// padding, read (never used) by the third column's 4-lane load of the last block. Only where
/// fused_sweeps_available().
void transpose_lower_blocks(const double* blocks, const int* upper_blocks, const int* lower_rows, const char* fixed,
                            size_t count, double* out);

/// One SSOR-PCG iteration's sweeps in Eisenstat's form (corotational_fem.cpp, solve_ssor), vectors
/// packed xyz per vertex: t = (D + L^T)^-1 p (backward), then q = t + (D + L)^-1 (p - D t)
/// (forward; acc is n entries of scratch: with the lower blocks it holds s y_i of the rows solved);
/// returns p . q. Only where fused_sweeps_available().
double fused_eisenstat_sweeps(const FusedSsorSystem& sys, const double* p, double* t, double* q, double* acc);

/// The CG update after the sweeps: dv += a z, r -= a q, Dr = D r; returns r . Dr. Only where
/// fused_sweeps_available().
double fused_cg_update(const FusedSsorSystem& sys, double a, const double* z, const double* q, double* dv, double* r,
                       double* Dr);

/// p = Dr + b p (the next direction). Only where fused_sweeps_available().
void fused_direction_update(size_t n, const double* Dr, double b, double* p);

}  // namespace pliant
