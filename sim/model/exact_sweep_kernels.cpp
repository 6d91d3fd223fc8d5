#include "sim/model/exact_sweep_kernels.h"

#include "sim/model/exact_avx2.h"

namespace pliant {

#if defined(PLIANT_EXACT_AVX2_KERNELS)

bool exact_sweep_kernels_available() { return exact_avx2_kernels_available(); }

namespace {

using exact_lanes::load3;
using exact_lanes::store3;

/// sum_k L_k sy_{rows[k]} over row i's lower entries, k ascending, from +0: each term (L_0 y_0 +
/// L_1 y_1) + L_2 y_2 lane-wise (lane 3: a finite entry of the next copy or the padding times y, never
/// stored).
PLIANT_AVX2_ONLY inline __m256d gather_lower(const double* lower, const int* rows, size_t first, size_t last,
                                             const double* sy) {
  __m256d a = _mm256_setzero_pd();
  for (size_t k = first; k < last; ++k) {
    const double* L = lower + 9 * k;
    const double* y = sy + rows[k];
    const __m256d p0 = _mm256_mul_pd(_mm256_loadu_pd(L), _mm256_broadcast_sd(y));
    const __m256d p1 = _mm256_mul_pd(_mm256_loadu_pd(L + 3), _mm256_broadcast_sd(y + 1));
    const __m256d p2 = _mm256_mul_pd(_mm256_loadu_pd(L + 6), _mm256_broadcast_sd(y + 2));
    a = _mm256_add_pd(a, _mm256_add_pd(_mm256_add_pd(p0, p1), p2));
  }
  return a;
}

/// M x for the column-major 3x3 at M in Eigen's order (lane 3 not used).
PLIANT_AVX2_ONLY inline __m256d eigen_mat_vec(const double* M, __m256d x) {
  alignas(32) double v[4];
  _mm256_store_pd(v, x);
  return exact_lanes::product_column(_mm256_loadu_pd(M), _mm256_loadu_pd(M + 3), load3(M + 6), v[0], v[1], v[2]);
}

}  // namespace

PLIANT_AVX2_ONLY void exact_forward_sweep_gathered(const GatheredSweepSystem& sys, double* r, double* sy) {
  const __m256d s = _mm256_set1_pd(sys.s);
  for (size_t i = 0; i < sys.n; ++i) {
    if (sys.fixed[i] != 0) {  // y = r_i as it is, nothing sent
      store3(sy + 3 * i, _mm256_setzero_pd());
      continue;
    }
    const __m256d acc = gather_lower(sys.lower, sys.lower_row_entries, static_cast<size_t>(sys.lower_offsets[i]),
                                     static_cast<size_t>(sys.lower_offsets[i + 1]), sy);
    const __m256d y = eigen_mat_vec(sys.D_inverse + 9 * i, _mm256_sub_pd(load3(r + 3 * i), acc));
    store3(r + 3 * i, y);
    store3(sy + 3 * i, _mm256_mul_pd(s, y));
  }
}

PLIANT_AVX2_ONLY void exact_lower_product_rows_gathered(const GatheredSweepSystem& sys, const double* x, double* sx,
                                                        double* w) {
  const __m256d s = _mm256_set1_pd(sys.s);
  for (size_t i = 0; i < sys.n; ++i) {
    if (sys.fixed[i] != 0) {  // sends nothing
      store3(sx + 3 * i, _mm256_setzero_pd());
      continue;
    }
    const __m256d acc = gather_lower(sys.lower, sys.lower_row_entries, static_cast<size_t>(sys.lower_offsets[i]),
                                     static_cast<size_t>(sys.lower_offsets[i + 1]), sx);
    const __m256d xi = load3(x + 3 * i);
    store3(w + 3 * i, _mm256_add_pd(eigen_mat_vec(sys.D + 9 * i, xi), acc));
    store3(sx + 3 * i, _mm256_mul_pd(s, xi));
  }
}

#else

bool exact_sweep_kernels_available() { return false; }

void exact_forward_sweep_gathered(const GatheredSweepSystem&, double*, double*) {}

void exact_lower_product_rows_gathered(const GatheredSweepSystem&, const double*, double*, double*) {}

#endif

}  // namespace pliant
