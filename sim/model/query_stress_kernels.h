// The local force queries' per-tet stress and per-vertex sums in 256-bit lanes (AVX2, no FMA),
// chosen at run time (session 11, issues #5 and #8). Design note: an exact query (the contact
// search's linearisation point and its final held-force evaluation, corotational_local_query.cpp)
// computes per touched tet P = (2 mu) (F - R) + (lambda tr) R, tr = tr(R^T F) - 3, and per asked
// vertex the sum over its corners of -V (P g_j) with the rest shape gradient g_j. In the portable
// build Eigen evaluates V (P g) as (V P) g (its rule for a scalar times a product) and the 3x3 by 3
// product lazily: rows 0 and 1 (a_0 + a_1) + a_2, row 2 a_0 + (a_1 + a_2), a_k = (V P)(i, k) g_k
// (checked on 2e5 random inputs). Here a column of P is one 4-lane vector (lanes 0..2) and every
// product and sum is the scalar code's, separately rounded (the functions are compiled for "avx2"
// alone: with FMA GCC would contract a * b + c), so the results are CorotationalFem's first_piola
// and sum_query_stresses bit for bit (tested: corotational_query_kernels_test). A -march=native build
// has Eigen's AVX packets and FMA in the scalar code: there the kernels report themselves
// unavailable. Kept apart from tet_gradient_kernels.* (the full pass's kernels) so the two change
// independently. Session 14: exact_query_stresses_avx2 runs a whole batch of the exact query in
// lanes (F from the positions, the extraction's iteration from rotation_extraction.h, R, P).
#pragma once

#include <cstddef>

#include "sim/math_types.h"

namespace pliant {

/// True when this CPU runs the kernels below and they are the scalar code's bit for bit (AVX2,
/// portable build).
bool query_stress_kernels_available();

/// For `count` tets: R[l] = q[l].toRotationMatrix() and P[l] = (2 mu) (F[l] - R[l]) + (lambda tr) R[l],
/// tr = sum of R .* F - 3 (CorotationalFem::first_piola bit for bit; mu, lambda in Pa).
void first_piola_stresses_avx2(const Quat* q, const Mat3* F, double mu, double lambda, size_t count, Mat3* R,
                               Mat3* P);

/// first_piola_stresses_avx2 with R[l] given (the rotation matrices of
/// extract_rotation_matrices_batch_avx2): P[l] may be F[l] (each tet's F is read whole first).
void first_piola_stresses_from_rotations_avx2(const Mat3* R, const Mat3* F, double mu, double lambda, size_t count,
                                              Mat3* P);

/// The exact query's stress of four tets (session 14): F_l = Ds Dm^-1 of tet tets[l] of mesh_tets
/// (positions x, packed xyz per vertex; rest_shape_inverse per mesh tet) into *F[l], the rotation
/// extract_rotation gives from F_l and the warm start q[l] (q[l] is scratch, rewritten where the SVD start is taken) into *R[l] as
/// toRotationMatrix(), and P[l] = (2 mu) (F_l - R_l) + (lambda tr) R_l: CorotationalFem's
/// deformation_gradient, extract_rotation and first_piola bit for bit, all in the lanes of one
/// batch (no F computed per tet and gathered again, no R stored and loaded again).
void exact_query_stresses_avx2(const double* x, const TetIndices* mesh_tets, const Mat3* rest_shape_inverse,
                               const int* tets, Quat* q, double mu, double lambda, int max_iterations,
                               double tolerance, Mat3* const* F, Mat3* const* R, Mat3* P);

/// f = -sum over `count` corners c, in order, of V_t (P_s g_c): t = corner_tets[c * corner_stride], s =
/// tet_slots[t], P_s = slot_stresses[s] (Pa), V_t = volumes[t] (m^3), g_c = corner_gradients[c] (1/m);
/// f (N, xyz) is CorotationalFem::sum_query_stresses's sum for one vertex bit for bit.
void corner_stress_sum_avx2(const int* corner_tets, size_t corner_stride, const Vec3* corner_gradients, size_t count,
                            const int* tet_slots, const Mat3* slot_stresses, const double* volumes, double* f);

}  // namespace pliant
