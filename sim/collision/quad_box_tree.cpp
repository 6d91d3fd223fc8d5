#include "sim/collision/quad_box_tree.h"

#include <cassert>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PLIANT_QUAD_AVX 1
#define PLIANT_AVX __attribute__((target("avx")))
#endif

namespace pliant {
namespace {

bool avx_available() {
#if defined(PLIANT_QUAD_AVX)
  static const bool available = __builtin_cpu_supports("avx");
  return available;
#else
  return false;
#endif
}

}  // namespace

bool QuadBoxTree::available() { return avx_available(); }

int QuadBoxTree::leaves_meeting(const Aabb& query, int* out) const {
  assert(available());
  return nodes_.empty() ? 0 : leaves_meeting_avx(query, out);
}

#if defined(PLIANT_QUAD_AVX)

PLIANT_AVX int QuadBoxTree::leaves_meeting_avx(const Aabb& query, int* out) const {
  const __m256d qmin_x = _mm256_set1_pd(query.min[0]), qmin_y = _mm256_set1_pd(query.min[1]),
                qmin_z = _mm256_set1_pd(query.min[2]);
  const __m256d qmax_x = _mm256_set1_pd(query.max[0]), qmax_y = _mm256_set1_pd(query.max[1]),
                qmax_z = _mm256_set1_pd(query.max[2]);
  int stack[kMaxStack];
  int top = 0;
  int found = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int e = stack[--top];
    if (e < 0) {
      out[found++] = ~e;
      continue;
    }
    const Node& node = nodes_[static_cast<size_t>(e)];
    // The six closed comparisons of boxes_meet for four children at once (_CMP_LE_OS: false for
    // NaN, as the scalar <=).
    __m256d meets = _mm256_and_pd(_mm256_cmp_pd(_mm256_load_pd(node.min[0]), qmax_x, _CMP_LE_OS),
                                  _mm256_cmp_pd(qmin_x, _mm256_load_pd(node.max[0]), _CMP_LE_OS));
    meets = _mm256_and_pd(meets, _mm256_and_pd(_mm256_cmp_pd(_mm256_load_pd(node.min[1]), qmax_y, _CMP_LE_OS),
                                               _mm256_cmp_pd(qmin_y, _mm256_load_pd(node.max[1]), _CMP_LE_OS)));
    meets = _mm256_and_pd(meets, _mm256_and_pd(_mm256_cmp_pd(_mm256_load_pd(node.min[2]), qmax_z, _CMP_LE_OS),
                                               _mm256_cmp_pd(qmin_z, _mm256_load_pd(node.max[2]), _CMP_LE_OS)));
    const int mask = _mm256_movemask_pd(meets) & node.valid;
    // Every slot is written and the top advanced by its bit: no branch per child. Last to first,
    // so popped in the binary depth-first order.
    stack[top] = node.child[3];
    top += (mask >> 3) & 1;
    stack[top] = node.child[2];
    top += (mask >> 2) & 1;
    stack[top] = node.child[1];
    top += (mask >> 1) & 1;
    stack[top] = node.child[0];
    top += mask & 1;
  }
  return found;
}

#else

int QuadBoxTree::leaves_meeting_avx(const Aabb&, int*) const { return 0; }

#endif

}  // namespace pliant
