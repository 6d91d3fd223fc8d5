#include "sim/model/rotation_batch_avx2.h"

#include "sim/model/rotation_extraction.h"

namespace pliant {

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)

bool rotation_batch_avx2_available() {
  static const bool available = __builtin_cpu_supports("avx2");
  return available;
}

// "flatten" inlines the template (and what it calls) here, so it is compiled for AVX2; "avx2"
// without "fma" keeps every multiply and add separately rounded (GCC contracts a * b + c by
// default where FMA is enabled).
__attribute__((target("avx2"), flatten)) void extract_rotations_batch_avx2(const Mat3* F, Quat* q,
                                                                           int max_iterations, double tolerance,
                                                                           int* iterations) {
  extract_rotations_lanes<kRotationBatchLanesAvx2>(F, q, max_iterations, tolerance, iterations);
}

__attribute__((target("avx2"), flatten)) void extract_rotations_batch_avx2_from(const Mat3* F, const Quat* warm_starts,
                                                                                Quat* q, int max_iterations,
                                                                                double tolerance) {
  extract_rotations_lanes<kRotationBatchLanesAvx2>(F, q, max_iterations, tolerance, nullptr, nullptr, warm_starts);
}

__attribute__((target("avx2"), flatten)) void extract_rotation_matrices_batch_avx2(const Mat3* F, Quat* q, Mat3* R,
                                                                                  int max_iterations,
                                                                                  double tolerance) {
  extract_rotations_lanes<kRotationBatchLanesAvx2>(F, q, max_iterations, tolerance, nullptr, R);
}

#else

bool rotation_batch_avx2_available() { return false; }

void extract_rotations_batch_avx2(const Mat3* F, Quat* q, int max_iterations, double tolerance, int* iterations) {
  for (int l = 0; l < kRotationBatchLanesAvx2; ++l) {
    const int it = extract_rotation(F[l], q[l], max_iterations, tolerance);
    if (iterations != nullptr) iterations[l] = it;
  }
}

void extract_rotations_batch_avx2_from(const Mat3* F, const Quat* warm_starts, Quat* q, int max_iterations,
                                       double tolerance) {
  for (int l = 0; l < kRotationBatchLanesAvx2; ++l) {
    q[l] = warm_starts[l];
    extract_rotation(F[l], q[l], max_iterations, tolerance);
  }
}

void extract_rotation_matrices_batch_avx2(const Mat3* F, Quat* q, Mat3* R, int max_iterations, double tolerance) {
  for (int l = 0; l < kRotationBatchLanesAvx2; ++l) {
    extract_rotation(F[l], q[l], max_iterations, tolerance);
    R[l] = q[l].toRotationMatrix();
  }
}

#endif

}  // namespace pliant
