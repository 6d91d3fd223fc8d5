// The corotational FEM's per-tet 3x3 products in 256-bit lanes (AVX2, no FMA), chosen at run time
// (session 10, issues #3 and #6). Design note: the evaluation pass computes per tet the deformation
// gradient F = Ds Dm^-1 and the element forces H = (-V P) Dm^-T (scattered to the tet's four
// vertices), and the K' assembly the rotated
// shape gradients R Dm^-T; in the portable build Eigen evaluates these 3x3 products as its lazy
// coefficient product: rows 0 and 1 of a column in one SSE2 packet, summed over k left to right,
// (a_0k b_k0 + a_1k b_k1) + a_2k b_k2, and row 2 as a scalar reduction, a_0 b_0 + (a_1 b_1 + a_2 b_2)
// (measured entry by entry on random matrices; Eigen 3.4's product_evaluator and
// redux_novec_unroller). Here a column of the product is one 4-lane vector: three lane products,
// both sums, and a blend that takes row 2 from the second. Every product and sum is the scalar
// code's, separately rounded (the functions are compiled for "avx2" alone: with FMA enabled GCC
// would contract a * b + c), so the results are the scalar code's bit for bit (tested:
// tet_gradient_kernels_test). A -march=native build has Eigen's AVX packets and FMA in the scalar
// code, another order: there these kernels report themselves unavailable and the scalar code runs.
// Session 11: the element forces and the rotated gradients take four tets per call with one tet per
// lane (the tets' 3x3 matrices transposed into nine entry vectors): R from the quaternion, the trace,
// |F - R|^2, the energy and P then cost one vector operation per scalar one, each lane the scalar's
// expression in its order (Eigen's 9-term sums as ((p0 + p1) + (p2 + p3)), lane 0 + lane 1, + e8 over
// SSE2 packets p_j = (e_2j, e_2j+1)); the products keep the row order above.
#pragma once

#include "sim/math_types.h"

namespace pliant {

/// True when this CPU runs the kernels below and they are the scalar code's bit for bit (AVX2,
/// portable build).
bool tet_gradient_kernels_available();

/// F_l = Ds Dm_l^-1, Ds = (x_1 - x_0, x_2 - x_0, x_3 - x_0), for `count` tets (tets[l], inverse rest
/// shapes rest_shape_inverse[l]) and positions x (packed xyz per vertex): CorotationalFem's scalar
/// deformation_gradient bit for bit.
void deformation_gradients_avx2(const double* x, const TetIndices* tets, const Mat3* rest_shape_inverse, size_t count,
                                Mat3* F);

/// The rotated shape gradients G_l = R_l Dm_l^-T, R_l = q[l].toRotationMatrix(), for `count` tets:
/// CorotationalFem's scalar rotated_gradient bit for bit.
void rotated_gradients_avx2(const Quat* q, const Mat3* rest_shape_inverse, size_t count, Mat3* G);

/// The same for the tets t = tets[0 .. count - 1] of whole-mesh arrays: G[t] = R_t Dm_t^-T,
/// R_t = q[t].toRotationMatrix() (the K' reuse step's moved tets; distinct indices).
void rotated_gradients_at_avx2(const Quat* q, const Mat3* rest_shape_inverse, const int* tets, size_t count, Mat3* G);

/// The evaluation pass's per-tet expressions for `count` tets (CorotationalFem::evaluate_tet_batch bit
/// for bit): R = q.toRotationMatrix(), trace = tr(R^T F) - 3, the energy V (mu |F - R|^2 + lambda/2
/// trace^2) into energy[l] and the element forces H = (-V P) Dm^-T into H[l], P = (2 mu) (F - R) +
/// (lambda trace) R (the corotated first Piola-Kirchhoff stress; its 3x3 product in lanes).
void element_forces_avx2(const Quat* q, const Mat3* F, const Mat3* rest_shape_inverse, const double* volume, double mu,
                         double lambda, size_t count, double* energy, Mat3* H);

/// For each of `count` tets in order: f_0 -= (h_0 + h_1) + h_2, then f_{k+1} += h_k, k = 0..2, for
/// the columns h_k of H[l] and the vertices tets[l] in f (packed xyz per vertex): CorotationalFem's
/// scalar scatter bit for bit.
void scatter_element_forces_avx2(const TetIndices* tets, const Mat3* H, size_t count, double* f);

}  // namespace pliant
