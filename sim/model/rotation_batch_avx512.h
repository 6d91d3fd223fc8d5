// The batched rotation extraction eight tets at a time in 512-bit registers, chosen at run time
// (session 17, issue #6). Design note: the same template as extract_rotations_batch_avx2
// (extract_rotations_lanes<L>, rotation_extraction.h; every lane the scalar extract_rotation's
// operations in its order) instantiated for 8 lanes in a function compiled for "avx512f". Unlike
// "avx2", "avx512f" brings fused multiply-adds with it, so this file is compiled with
// -ffp-contract=off (sim/CMakeLists.txt): every multiply and add stays separately rounded and each
// lane is the scalar's result bit for bit, as the 4-lane batch's. Only portable GCC x86-64 builds
// have it (a build with AVX everywhere contracts its scalar code, so there is nothing to match).
#pragma once

#include "sim/math_types.h"

namespace pliant {

/// Lanes of extract_rotations_batch_avx512.
inline constexpr int kRotationBatchLanesAvx512 = 8;

/// True when this build has the 8-lane kernel and this CPU runs it (AVX-512F and DQ).
bool rotation_batch_avx512_available();

/// extract_rotation for 8 tets at once (F[l], warm starts q[l]), bit for bit the scalar's result per
/// lane; iterations[l] (optional) receives each lane's count. Only where rotation_batch_avx512_available().
void extract_rotations_batch_avx512(const Mat3* F, Quat* q, int max_iterations, double tolerance,
                                    int* iterations = nullptr);

/// CorotationalFem's evaluation pass for 8 tets (tets[l], positions x packed xyz per vertex) in
/// one kernel's lanes, bit for bit its scalar expressions (session 17): F = Ds Dm^-1, the rotation
/// q[l] from the warm start warm_starts[l] (q may be warm_starts), energy[l] = V (mu |F - R|^2 + lambda/2 trace^2) and H[l] =
/// (-V P) Dm^-T, R = q[l].toRotationMatrix(), trace = tr(R^T F) - 3 (the order of
/// deformation_gradients_avx2 and element_forces_avx2, tet_gradient_kernels.h); F, q and R are not
/// transposed out of the lanes and back in between. Only where rotation_batch_avx512_available().
void evaluate_tets_avx512(const double* x, const TetIndices* tets, const Mat3* rest_shape_inverse, const double* volume,
                          double mu, double lambda, int max_iterations, double tolerance, const Quat* warm_starts,
                          Quat* q, double* energy, Mat3* H);

/// The exact local query's stress of 8 tets in one kernel's lanes (session 18): exact_query_stresses_avx2
/// (query_stress_kernels.h) for 8 tets, bit for bit its results per lane: F_l = Ds Dm^-1 of mesh tet
/// tets[l] (positions x packed xyz) into *F[l], the rotation from F_l and the warm start q[l] (q is
/// scratch) into *R[l] as toRotationMatrix(), and P[l] = (2 mu) (F_l - R_l) + (lambda tr) R_l,
/// tr = sum of R .* F - 3 (P: 8 packed matrices). Only where rotation_batch_avx512_available().
void exact_query_stresses_avx512(const double* x, const TetIndices* mesh_tets, const Mat3* rest_shape_inverse,
                                 const int* tets, Quat* q, double mu, double lambda, int max_iterations,
                                 double tolerance, Mat3* const* F, Mat3* const* R, Mat3* P);

}  // namespace pliant
