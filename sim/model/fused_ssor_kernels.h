// The SSOR sweeps' per-block kernels with fused multiply-adds in 256-bit lanes (AVX2 + FMA),
// chosen at run time (session 8, issue #3). Design note: the exact sweeps
// (corotational_fem.cpp, SsorSweeps) evaluate every 3x3 block product in scalar (or paired SSE2)
// arithmetic in one fixed order, ~35 instructions per block visit. Here a block's three columns
// are one 4-lane load each (the fourth lane is ignored or masked to zero):
//   gather  a += B t_j   (backward sweep): three FMAs into three accumulators, one per column;
//   scatter acc_j += B^T y (forward sweep): the column dot products c_k . y by two horizontal adds.
// The sums are the same but rounded differently (FMA keeps the product unrounded, the order of
// the terms differs), so the solve's iterates differ from the exact path's in the last bits and
// the CG residual test decides the rest: an approximation under the project's rule (tolerance,
// measured bound and test in docs/deformation-models.md "Session 8"; CorotationalFem's
// set_fused_sweeps(false) is the exact path bit for bit). Compiled for avx2/fma by function
// attribute, so the portable build keeps running on CPUs without them (fused_sweeps_available()).
#pragma once

#include <cstddef>

namespace pliant {

/// True when this CPU runs the AVX2 + FMA kernels below.
bool fused_sweeps_available();

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
};

/// One SSOR-PCG iteration's sweeps in Eisenstat's form (corotational_fem.cpp, solve_ssor), vectors
/// packed xyz per vertex: t = (D + L^T)^-1 p (backward), then q = t + (D + L)^-1 (p - D t)
/// (forward; acc is n entries of scratch); returns p . q. Only where fused_sweeps_available().
double fused_eisenstat_sweeps(const FusedSsorSystem& sys, const double* p, double* t, double* q, double* acc);

/// The CG update after the sweeps: dv += a z, r -= a q, Dr = D r; returns r . Dr. Only where
/// fused_sweeps_available().
double fused_cg_update(const FusedSsorSystem& sys, double a, const double* z, const double* q, double* dv, double* r,
                       double* Dr);

/// p = Dr + b p (the next direction). Only where fused_sweeps_available().
void fused_direction_update(size_t n, const double* Dr, double b, double* p);

// Session 11 (issue #3): the same iteration in three passes instead of four (plus a memset), the
// same operations on the same values in the same order, so the iterates are the ones of
// fused_eisenstat_sweeps + fused_cg_update + fused_direction_update bit for bit (those stay as
// the composition the tests compare against). What moved: the previous iteration's dv += a z and
// p = Dr + b p into the backward sweep (which reads p_i and overwrites z_i = t_i at row i anyway),
// the forward sweep's accumulator zeroed there too (no memset), q written over the accumulator
// (row i reads acc_i once, then only rows > i are sent to), and D_i^-1 read from the diagonal
// block's slot of row i (the caller swaps it in for the solve): the backward sweep streams the
// blocks and the inverses as one array, and the forward sweep one array fewer.

/// The previous iteration's vector updates that the next backward sweep applies as it passes:
/// dv += a z and p = Dr + b p (both only when `pending`).
struct FusedIterationCarry {
  bool pending = false;      ///< false in the first iteration of a solve
  double a = 0.0;            ///< the previous step length
  double b = 0.0;            ///< the previous direction factor
  const double* Dr = nullptr;  ///< D r~ of the previous iteration (n packed triples)
  double* dv = nullptr;        ///< the solution, advanced by a z
};

/// Backward sweep t = (D + L^T)^-1 p with D_i^-1 in the diagonal slot blocks + 9 offsets[i] (not
/// sys.D_inverse); before row i uses p_i and overwrites t_i: dv_i += a t_i, p_i = Dr_i + b p_i
/// (carry.pending), and acc_i = 0 for the forward sweep. Only where fused_sweeps_available().
void fused_backward_sweep(const FusedSsorSystem& sys, const FusedIterationCarry& carry, double* p, double* t,
                          double* acc);

/// Forward sweep q = t + (D + L)^-1 (p - D t), D_i^-1 from the diagonal slot as above, q written
/// over acc (zeroed by the backward sweep); returns p . q. Only where fused_sweeps_available().
double fused_forward_sweep(const FusedSsorSystem& sys, const double* p, const double* t, double* acc_q);

/// r -= a q, Dr = D r; returns r . Dr (fused_cg_update without its dv update). Only where
/// fused_sweeps_available().
double fused_residual_update(const FusedSsorSystem& sys, double a, const double* q, double* r, double* Dr);

/// dv += a z, the update a solve's last iteration leaves to the end. Only where
/// fused_sweeps_available().
void fused_solution_update(size_t n, double a, const double* z, double* dv);

}  // namespace pliant
