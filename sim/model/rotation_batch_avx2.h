// The batched rotation extraction four tets at a time in 256-bit registers, chosen at run time
// (session 9, issues #3 and #6). Design note: extract_rotations_lanes<L> (rotation_extraction.h)
// runs L tets' Newton iterations in the lanes of one GCC vector, each lane exactly the scalar
// extract_rotation's operations in its order. The portable build has SSE2 only, so
// kRotationBatchLanes is 2 there (four lanes in two SSE2 registers spilled and were slower,
// session 6); PLIANT_NATIVE builds get 4 at compile time but also FMA everywhere. Here the same
// template is instantiated for 4 lanes inside a function compiled for "avx2" alone (no "fma": the
// compiler cannot contract, so every lane stays the scalar's bit for bit) and flattened, so the
// lanes live in ymm registers; CorotationalFem's evaluation pass calls it where the CPU has AVX2.
#pragma once

#include "sim/math_types.h"

namespace pliant {

/// Lanes of extract_rotations_batch_avx2.
inline constexpr int kRotationBatchLanesAvx2 = 4;

/// True when this CPU runs extract_rotations_batch_avx2.
bool rotation_batch_avx2_available();

/// extract_rotation for 4 tets at once (F[l], warm starts q[l]), bit for bit the scalar's result per
/// lane; iterations[l] (optional) receives each lane's count. Only where rotation_batch_avx2_available().
void extract_rotations_batch_avx2(const Mat3* F, Quat* q, int max_iterations, double tolerance,
                                  int* iterations = nullptr);

/// extract_rotations_batch_avx2 from the warm starts warm_starts[l] into q[l] (another array; session
/// 18): the results of copying them into q first, bit for bit. Only where rotation_batch_avx2_available().
void extract_rotations_batch_avx2_from(const Mat3* F, const Quat* warm_starts, Quat* q, int max_iterations,
                                       double tolerance);

/// extract_rotations_batch_avx2 that also writes R[l] = q[l].toRotationMatrix() (bit for bit), the
/// normalisation and R computed in the lanes (session 13: the local queries' stress reads R).
void extract_rotation_matrices_batch_avx2(const Mat3* F, Quat* q, Mat3* R, int max_iterations, double tolerance);

}  // namespace pliant
