// The exact SSOR sweeps' forward products by gathering, in AVX2 lanes without FMA (session 18,
// issue #6). Design note: the SSOR-PCG's first forward sweep r~ = (D + L)^-1 r and its true-residual
// check |(D + L) x| run the exact sweeps (corotational_fem.cpp, SsorSweeps), which scatter
// s K'_ij^T y_i from row i into the accumulators of the rows j > i (fused_scatter_row). Where the
// fused sweeps' transposed lower blocks exist (fused_ssor_kernels.h, transpose_lower_blocks: row i's
// entries hold K'_ji^T, j < i ascending, zero where row j is fixed) row i can gather the same terms
// from the s y_j the rows before it stored instead: each (B_0k y_0 + B_1k y_1) + B_2k y_2 (products
// rounded on their own, no FMA: the function is compiled for "avx2" alone, see exact_avx2.h) added
// in the order the scatter added them, to a sum that starts at +0 (the scatter's fourth term, a
// zero, can change only the sign of a zero term, and such a sum plus +-0 is the sum). D_i^-1 (r_i -
// acc_i) and D_i x_i are formed in Eigen's order (exact_lanes::product_column). So every value is the
// scatter loop's, bit for bit (tested against SsorSweeps in corotational_exact_sweep_kernels_test).
#pragma once

#include <cstddef>

namespace pliant {

/// True when this CPU runs the kernels below (the exact AVX2 kernels are built in and it has AVX2).
bool exact_sweep_kernels_available();

/// What the gathered sweeps read: the transposed lower blocks by row, the diagonal blocks of
/// A = D + L + L^T and their inverses (column-major 3x3, 9 doubles per row), the fixed flags and s.
struct GatheredSweepSystem {
  const double* lower;           ///< per lower entry K'_ji^T (zero where row j is fixed), + 4 padding doubles
  const int* lower_row_entries;  ///< per lower entry 3 j
  const int* lower_offsets;      ///< n + 1 offsets of the lower entries by row
  const double* D;               ///< diagonal blocks of A
  const double* D_inverse;       ///< their inverses
  const char* fixed;             ///< nonzero: a fixed (decoupled) row
  double s;                      ///< h (beta + h): L_ij = s K'_ji^T
  size_t n;                      ///< rows
};

/// r <- (D + L)^-1 r, rows ascending (SsorSweeps::forward with r as right-hand side and result): a
/// fixed row keeps r_i; another row r_i = D_i^-1 (r_i - sum_j L_ij y_j). sy is scratch of n triples
/// (s y_i per row, zero at fixed rows). Vectors packed xyz. Only where exact_sweep_kernels_available().
void exact_forward_sweep_gathered(const GatheredSweepSystem& sys, double* r, double* sy);

/// The rows of (D + L) x (SsorSweeps::lower_product_norm_sq's vectors): w_i = D_i x_i + sum_j L_ij x_j
/// for every unfixed row (a fixed row's w_i is not written). sx is scratch of n triples. The caller
/// sums |w_i|^2 over the unfixed rows in Eigen (the same sum). Only where exact_sweep_kernels_available().
void exact_lower_product_rows_gathered(const GatheredSweepSystem& sys, const double* x, double* sx, double* w);

}  // namespace pliant
