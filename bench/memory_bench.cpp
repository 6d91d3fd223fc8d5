// What one core of this machine can stream (session 11, issue #3): a STREAM-like read of a buffer
// of a given size, the yardstick for the SSOR-PCG iteration's effective bandwidth
// (docs/deformation-models.md "Session 11"). The iteration reads ~1-3 MB per pass, between the
// 512 KB L2 of a core and the 32 MB L3, so the sizes bracket both.
//
// Read: the sum of every double of the buffer, four 4-lane AVX2 accumulators (AVX2 chosen at run
// time as the kernels are; SSE2 otherwise), so the adds are not the limit at any cache level.
// Directions, as the sweeps run: 0 ascending every pass; 1 descending every pass (the backward
// sweep's row order); 2 alternating (the forward and backward sweeps' zig-zag: the end of one pass
// is the start of the next, still in L2); 3 rows of 576 bytes (the beam's mean K' row: ~6.6 upper
// blocks of 72 bytes and the diagonal one) descending, each read ascending (the backward sweep's
// stream, which the hardware prefetcher follows less well).
// Run: build/bench/memory_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstddef>
#include <cstdlib>
#include <vector>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PLIANT_MEMORY_BENCH_AVX2 1
#endif

namespace {

/// Doubles per row of direction 3 (576 bytes: nine cache lines).
constexpr size_t kRowDoubles = 72;

#if defined(PLIANT_MEMORY_BENCH_AVX2)
/// Sum of x[first, last) (a multiple of 8 doubles) in four 4-lane accumulators, ascending.
__attribute__((target("avx2"))) inline __m256d sum_up(const double* x, size_t first, size_t last,
                                                      __m256d a0) {
  __m256d a1 = _mm256_setzero_pd(), a2 = a1, a3 = a1;
  size_t k = first;
  for (; k + 16 <= last; k += 16) {
    a0 = _mm256_add_pd(a0, _mm256_load_pd(x + k));
    a1 = _mm256_add_pd(a1, _mm256_load_pd(x + k + 4));
    a2 = _mm256_add_pd(a2, _mm256_load_pd(x + k + 8));
    a3 = _mm256_add_pd(a3, _mm256_load_pd(x + k + 12));
  }
  if (k < last) a0 = _mm256_add_pd(a0, _mm256_add_pd(_mm256_load_pd(x + k), _mm256_load_pd(x + k + 4)));
  return _mm256_add_pd(_mm256_add_pd(a0, a1), _mm256_add_pd(a2, a3));
}

__attribute__((target("avx2"))) double horizontal(__m256d a) {
  alignas(32) double lanes[4];
  _mm256_store_pd(lanes, a);
  return lanes[0] + lanes[1] + lanes[2] + lanes[3];
}

/// One pass over x[0, n) in the given direction (see the file's note).
__attribute__((target("avx2"))) double pass_avx2(const double* x, size_t n, int direction) {
  __m256d a0 = _mm256_setzero_pd(), a1 = a0, a2 = a0, a3 = a0;
  if (direction == 0) return horizontal(sum_up(x, 0, n, a0));
  if (direction == 1) {
    for (size_t k = n; k > 0; k -= 16) {
      a0 = _mm256_add_pd(a0, _mm256_load_pd(x + k - 4));
      a1 = _mm256_add_pd(a1, _mm256_load_pd(x + k - 8));
      a2 = _mm256_add_pd(a2, _mm256_load_pd(x + k - 12));
      a3 = _mm256_add_pd(a3, _mm256_load_pd(x + k - 16));
    }
    return horizontal(_mm256_add_pd(_mm256_add_pd(a0, a1), _mm256_add_pd(a2, a3)));
  }
  for (size_t r = n / kRowDoubles; r-- > 0;) a0 = sum_up(x, r * kRowDoubles, (r + 1) * kRowDoubles, a0);
  return horizontal(a0);
}
#endif

/// The same pass, portable.
double pass_plain(const double* x, size_t n, int direction) {
  double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0;
  if (direction == 0) {
    for (size_t k = 0; k < n; k += 4) a0 += x[k], a1 += x[k + 1], a2 += x[k + 2], a3 += x[k + 3];
  } else if (direction == 1) {
    for (size_t k = n; k > 0; k -= 4) a0 += x[k - 1], a1 += x[k - 2], a2 += x[k - 3], a3 += x[k - 4];
  } else {
    for (size_t r = n / kRowDoubles; r-- > 0;) {
      for (size_t k = r * kRowDoubles; k < (r + 1) * kRowDoubles; k += 4) {
        a0 += x[k], a1 += x[k + 1], a2 += x[k + 2], a3 += x[k + 3];
      }
    }
  }
  return (a0 + a1) + (a2 + a3);
}

/// One pass over x[0, n): 0 ascending, 1 descending, otherwise rows descending, each ascending.
double pass(const double* x, size_t n, int direction) {
#if defined(PLIANT_MEMORY_BENCH_AVX2)
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2) return pass_avx2(x, n, direction);
#endif
  return pass_plain(x, n, direction);
}

/// Doubles the buffer's length is a multiple of: whole rows of direction 3 and whole 16-double
/// steps of the passes.
constexpr size_t kQuantum = 144;

/// A 64-byte aligned buffer of `bytes` (rounded up to kQuantum doubles), filled with 1.0.
struct Buffer {
  explicit Buffer(size_t bytes) : n((bytes / sizeof(double) + kQuantum - 1) / kQuantum * kQuantum) {
    data = static_cast<double*>(std::aligned_alloc(64, n * sizeof(double)));
    for (size_t k = 0; k < n; ++k) data[k] = 1.0;
  }
  ~Buffer() { std::free(data); }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  size_t n;
  double* data = nullptr;
};

void BM_Read(benchmark::State& state) {
  const auto bytes = static_cast<size_t>(state.range(0)) * 1024;
  const auto direction = state.range(1);
  Buffer buffer(bytes);
  const size_t n = buffer.n;
  bool ascending = true;
  for (auto _ : state) {
    const int d = direction == 2 ? (ascending ? 0 : 1) : static_cast<int>(direction);
    benchmark::DoNotOptimize(pass(buffer.data, n, d));
    ascending = !ascending;
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(n * sizeof(double)));
  state.SetLabel(direction == 0   ? "ascending"
                 : direction == 1 ? "descending"
                 : direction == 2 ? "alternating"
                                  : "rows descending, each ascending");
}
BENCHMARK(BM_Read)
    ->ArgsProduct({{64, 256, 512, 1024, 2048, 4096, 32768}, {0, 1, 2, 3}})
    ->ArgNames({"kb", "direction"});

}  // namespace
