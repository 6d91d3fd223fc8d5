#include "sim/collision/quad_box_tree.h"

#include <bit>
#include <cassert>
#include <cmath>
#include <limits>

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

namespace {

// The query's bounds as the float test needs them, per axis, lanes 0-3 for "may meet" and 4-7 for
// "surely meets" (the same four children in both halves):
//   may:    child.min_f <= up(q.max)           and down(q.min) <= child.max_f
//   surely: child.min_f <= prev(down(q.max))   and next(up(q.min)) <= child.max_f
// with min_f = down(box.min), max_f = up(box.max). "May" holds whenever box.min <= q.max (the
// roundings are monotone). "Surely" implies it: box.min <= next(min_f) <= down(q.max) <= q.max
// (min_f is the largest float <= box.min), and symmetrically for the max side. A bound whose
// shrunk value would be infinite is NaN instead: that half never claims "surely" (re-tested).
struct FloatQuery {
  __m256 lo[3];
  __m256 hi[3];
};

PLIANT_AVX FloatQuery float_query(const Aabb& query) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  FloatQuery q;
  for (int a = 0; a < 3; ++a) {
    const float may_lo = QuadBoxTree::float_below(query.min[a]);
    const float may_hi = QuadBoxTree::float_above(query.max[a]);
    const float above_lo = QuadBoxTree::float_above(query.min[a]);
    const float below_hi = QuadBoxTree::float_below(query.max[a]);
    float sure_lo = above_lo < kInf ? QuadBoxTree::float_step_up(above_lo) : kNaN;
    float sure_hi = below_hi > -kInf ? QuadBoxTree::float_step_down(below_hi) : kNaN;
    if (std::isinf(sure_lo)) sure_lo = kNaN;
    if (std::isinf(sure_hi)) sure_hi = kNaN;
    q.lo[a] = _mm256_setr_ps(may_lo, may_lo, may_lo, may_lo, sure_lo, sure_lo, sure_lo, sure_lo);
    q.hi[a] = _mm256_setr_ps(may_hi, may_hi, may_hi, may_hi, sure_hi, sure_hi, sure_hi, sure_hi);
  }
  return q;
}

// Bit k: child k of a node meets `query` by the double closed comparisons (boxes_meet's, false for
// NaN). Decided on the float boxes; a child that may but not surely meet is re-tested on `exact`.
// Quiet comparisons (_CMP_LE_OQ: the same result as <=, false for NaN) because the "surely" half
// may hold the NaN marker, which must not raise FE_INVALID (tests trap it).
template <class FloatNode, class ExactNode>
PLIANT_AVX inline int children_mask(const FloatNode& node, const ExactNode& exact, const FloatQuery& q,
                                    const Aabb& query) {
  __m256 meets = _mm256_and_ps(
      _mm256_cmp_ps(_mm256_broadcast_ps(reinterpret_cast<const __m128*>(node.min[0])), q.hi[0], _CMP_LE_OQ),
      _mm256_cmp_ps(q.lo[0], _mm256_broadcast_ps(reinterpret_cast<const __m128*>(node.max[0])), _CMP_LE_OQ));
  for (int a = 1; a < 3; ++a) {
    meets = _mm256_and_ps(
        meets, _mm256_and_ps(
                   _mm256_cmp_ps(_mm256_broadcast_ps(reinterpret_cast<const __m128*>(node.min[a])), q.hi[a], _CMP_LE_OQ),
                   _mm256_cmp_ps(q.lo[a], _mm256_broadcast_ps(reinterpret_cast<const __m128*>(node.max[a])), _CMP_LE_OQ)));
  }
  const int both = _mm256_movemask_ps(meets);
  int mask = both & node.valid;
  // Rare (a face within a float ulp of the query's): predictable, and reads exact's lines only then.
  for (int unsure = mask & ~(both >> 4); unsure != 0; unsure &= unsure - 1) {
    const int k = std::countr_zero(static_cast<unsigned>(unsure));
    const bool exact_meets = exact.min[0][k] <= query.max[0] && query.min[0] <= exact.max[0][k] &&
                             exact.min[1][k] <= query.max[1] && query.min[1] <= exact.max[1][k] &&
                             exact.min[2][k] <= query.max[2] && query.min[2] <= exact.max[2][k];
    if (!exact_meets) mask &= ~(1 << k);
  }
  return mask;
}

}  // namespace

PLIANT_AVX int QuadBoxTree::leaves_meeting_avx(const Aabb& query, int* out) const {
  const FloatQuery q = float_query(query);
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
    const int mask = children_mask(node, exact_[static_cast<size_t>(e)], q, query);
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

PLIANT_AVX static int children_meeting_avx(const double (&min)[3][4], const double (&max)[3][4], const Aabb& query) {
  struct {
    alignas(16) float min[3][4];
    alignas(16) float max[3][4];
    int valid = 15;
  } node;
  for (int a = 0; a < 3; ++a) {
    for (int k = 0; k < 4; ++k) {
      node.min[a][k] = QuadBoxTree::float_below(min[a][k]);
      node.max[a][k] = QuadBoxTree::float_above(max[a][k]);
    }
  }
  struct {
    const double (&min)[3][4];
    const double (&max)[3][4];
  } exact{min, max};
  return children_mask(node, exact, float_query(query), query);
}

int QuadBoxTree::children_meeting(const double (&min)[3][4], const double (&max)[3][4], const Aabb& query) {
  assert(available());
  return children_meeting_avx(min, max, query);
}

#else

int QuadBoxTree::leaves_meeting_avx(const Aabb&, int*) const { return 0; }
int QuadBoxTree::children_meeting(const double (&)[3][4], const double (&)[3][4], const Aabb&) { return 0; }

#endif

}  // namespace pliant
