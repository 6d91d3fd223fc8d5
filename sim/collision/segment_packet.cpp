#include "sim/collision/segment_packet.h"

#include <algorithm>
#include <cassert>
#include <limits>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PLIANT_SEGMENT_PACKETS 1
// AVX only, not FMA: a fused multiply-add would round differently from the scalar query.
#define PLIANT_AVX __attribute__((target("avx")))
#endif

namespace pliant {

void SegmentPacket::load(const Vec3& end, const Vec3* origins, int n) {
  assert(n >= 0 && n <= kCapacity);
  count = n;
  lanes = (n + kLanes - 1) / kLanes * kLanes;
  // The same values the scalar query computes per segment (dir, |dir|^2, the segment's box).
  for (int i = 0; i < n; ++i) {
    const Vec3& o = origins[i];
    const Vec3 d = end - o;
    for (int k = 0; k < 3; ++k) {
      origin[k][i] = o[k];
      dir[k][i] = d[k];
      box_min[k][i] = std::min(o[k], end[k]);
      box_max[k][i] = std::max(o[k], end[k]);
    }
    dir_squared[i] = d.squaredNorm();
  }
  // Padding: a zero segment (determinant 0, never accepted, no trap) whose empty box meets nothing.
  for (int i = n; i < lanes; ++i) {
    for (int k = 0; k < 3; ++k) {
      origin[k][i] = 0.0;
      dir[k][i] = 0.0;
      box_min[k][i] = std::numeric_limits<double>::infinity();
      box_max[k][i] = -std::numeric_limits<double>::infinity();
    }
    dir_squared[i] = 0.0;
  }
  for (int i = 0; i < lanes; ++i) {
    best_t[i] = 1.0;
    best_triangle[i] = -1.0;
    best_u[i] = 0.0;
    best_v[i] = 0.0;
  }
}

#if defined(PLIANT_SEGMENT_PACKETS)

bool segment_packets_available() {
  static const bool available = __builtin_cpu_supports("avx");
  return available;
}

namespace {

// (a0 b0 + a1 b1) + a2 b2: the order in which Eigen sums a Vector3d dot product.
PLIANT_AVX inline __m256d dot3(__m256d a0, __m256d a1, __m256d a2, __m256d b0, __m256d b1, __m256d b2) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(a0, b0), _mm256_mul_pd(a1, b1)), _mm256_mul_pd(a2, b2));
}

// a1 b2 - a2 b1 (one component of a cross product, as Eigen computes it).
PLIANT_AVX inline __m256d cross_component(__m256d a1, __m256d b2, __m256d a2, __m256d b1) {
  return _mm256_sub_pd(_mm256_mul_pd(a1, b2), _mm256_mul_pd(a2, b1));
}

// mask ? a : b per lane, by and/andnot/or: GCC 12 turns _mm256_blendv_pd on a comparison's mask
// into one branch per lane (measured: the kernel's mispredictions), the bitwise select stays
// branch free.
PLIANT_AVX inline __m256d select(__m256d mask, __m256d a, __m256d b) {
  return _mm256_or_pd(_mm256_and_pd(mask, a), _mm256_andnot_pd(mask, b));
}

template <int kGroups>
PLIANT_AVX void packet_leaf(SegmentPacket& s, const PreparedTriangle* triangles, const Aabb* boxes,
                            const int* triangle_index, int n) {
  constexpr double kSlack = 1e-12;  // ray_triangle_intersection's barycentric slack
  const __m256d one = _mm256_set1_pd(1.0);
  const __m256d zero = _mm256_setzero_pd();
  const __m256d low = _mm256_set1_pd(-kSlack);
  const __m256d high = _mm256_set1_pd(1.0 + kSlack);
  const __m256d parallel = _mm256_set1_pd(1e-28);
  for (int j = 0; j < n; ++j) {
    const PreparedTriangle& tri = triangles[j];
    const Aabb& box = boxes[j];
    const __m256d ax = _mm256_set1_pd(tri.a[0]), ay = _mm256_set1_pd(tri.a[1]), az = _mm256_set1_pd(tri.a[2]);
    const __m256d e1x = _mm256_set1_pd(tri.e1[0]), e1y = _mm256_set1_pd(tri.e1[1]), e1z = _mm256_set1_pd(tri.e1[2]);
    const __m256d e2x = _mm256_set1_pd(tri.e2[0]), e2y = _mm256_set1_pd(tri.e2[1]), e2z = _mm256_set1_pd(tri.e2[2]);
    const __m256d e1e2 = _mm256_set1_pd(tri.e1e2_squared);
    const __m256d min_x = _mm256_set1_pd(box.min[0]), min_y = _mm256_set1_pd(box.min[1]), min_z = _mm256_set1_pd(box.min[2]);
    const __m256d max_x = _mm256_set1_pd(box.max[0]), max_y = _mm256_set1_pd(box.max[1]), max_z = _mm256_set1_pd(box.max[2]);
    const __m256d index = _mm256_set1_pd(static_cast<double>(triangle_index[j]));
    for (int i = 0; i < kGroups * SegmentPacket::kLanes; i += SegmentPacket::kLanes) {
      // The triangle's box meets the segment's box (the scalar query's six closed comparisons).
      __m256d ok = _mm256_and_pd(_mm256_cmp_pd(min_x, _mm256_load_pd(&s.box_max[0][i]), _CMP_LE_OS),
                                 _mm256_cmp_pd(_mm256_load_pd(&s.box_min[0][i]), max_x, _CMP_LE_OS));
      ok = _mm256_and_pd(ok, _mm256_and_pd(_mm256_cmp_pd(min_y, _mm256_load_pd(&s.box_max[1][i]), _CMP_LE_OS),
                                           _mm256_cmp_pd(_mm256_load_pd(&s.box_min[1][i]), max_y, _CMP_LE_OS)));
      ok = _mm256_and_pd(ok, _mm256_and_pd(_mm256_cmp_pd(min_z, _mm256_load_pd(&s.box_max[2][i]), _CMP_LE_OS),
                                           _mm256_cmp_pd(_mm256_load_pd(&s.box_min[2][i]), max_z, _CMP_LE_OS)));
      if (_mm256_movemask_pd(ok) == 0) continue;  // no lane's box meets: skip Moller-Trumbore
      // Moller-Trumbore as ray_triangle_intersection (prepared), every test a mask.
      const __m256d dx = _mm256_load_pd(&s.dir[0][i]), dy = _mm256_load_pd(&s.dir[1][i]),
                    dz = _mm256_load_pd(&s.dir[2][i]);
      const __m256d px = cross_component(dy, e2z, dz, e2y);
      const __m256d py = cross_component(dz, e2x, dx, e2z);
      const __m256d pz = cross_component(dx, e2y, dy, e2x);
      const __m256d det = dot3(e1x, e1y, e1z, px, py, pz);
      const __m256d scale2 = _mm256_mul_pd(e1e2, _mm256_load_pd(&s.dir_squared[i]));
      const __m256d not_parallel =
          _mm256_cmp_pd(_mm256_mul_pd(det, det), _mm256_mul_pd(parallel, scale2), _CMP_GT_OS);
      ok = _mm256_and_pd(ok, not_parallel);
      const __m256d inv = _mm256_div_pd(one, select(not_parallel, det, one));
      const __m256d tx = _mm256_sub_pd(_mm256_load_pd(&s.origin[0][i]), ax);
      const __m256d ty = _mm256_sub_pd(_mm256_load_pd(&s.origin[1][i]), ay);
      const __m256d tz = _mm256_sub_pd(_mm256_load_pd(&s.origin[2][i]), az);
      const __m256d u = _mm256_mul_pd(dot3(tx, ty, tz, px, py, pz), inv);
      ok = _mm256_and_pd(ok, _mm256_and_pd(_mm256_cmp_pd(u, low, _CMP_NLT_US), _mm256_cmp_pd(u, high, _CMP_NGT_US)));
      const __m256d qx = cross_component(ty, e1z, tz, e1y);
      const __m256d qy = cross_component(tz, e1x, tx, e1z);
      const __m256d qz = cross_component(tx, e1y, ty, e1x);
      const __m256d v = _mm256_mul_pd(dot3(dx, dy, dz, qx, qy, qz), inv);
      ok = _mm256_and_pd(ok, _mm256_and_pd(_mm256_cmp_pd(v, low, _CMP_NLT_US),
                                           _mm256_cmp_pd(_mm256_add_pd(u, v), high, _CMP_NGT_US)));
      const __m256d t = _mm256_mul_pd(dot3(e2x, e2y, e2z, qx, qy, qz), inv);
      const __m256d best_t = _mm256_load_pd(&s.best_t[i]);
      ok = _mm256_and_pd(ok, _mm256_and_pd(_mm256_cmp_pd(t, zero, _CMP_NLT_US), _mm256_cmp_pd(t, best_t, _CMP_NGT_US)));
      // Keep it if there is no best yet, or it is nearer, or as near with a smaller index.
      const __m256d best_tri = _mm256_load_pd(&s.best_triangle[i]);
      const __m256d better = _mm256_or_pd(
          _mm256_or_pd(_mm256_cmp_pd(best_tri, zero, _CMP_LT_OS), _mm256_cmp_pd(t, best_t, _CMP_LT_OS)),
          _mm256_and_pd(_mm256_cmp_pd(t, best_t, _CMP_EQ_OQ), _mm256_cmp_pd(index, best_tri, _CMP_LT_OS)));
      const __m256d take = _mm256_and_pd(ok, better);
      _mm256_store_pd(&s.best_t[i], select(take, t, best_t));
      _mm256_store_pd(&s.best_triangle[i], select(take, index, best_tri));
      _mm256_store_pd(&s.best_u[i], select(take, u, _mm256_load_pd(&s.best_u[i])));
      _mm256_store_pd(&s.best_v[i], select(take, v, _mm256_load_pd(&s.best_v[i])));
    }
  }
}

}  // namespace

PLIANT_AVX void segment_packet_leaf(SegmentPacket& s, const PreparedTriangle* triangles, const Aabb* boxes,
                                    const int* triangle_index, int n) {
  switch (s.lanes / SegmentPacket::kLanes) {
    case 1: packet_leaf<1>(s, triangles, boxes, triangle_index, n); break;
    case 2: packet_leaf<2>(s, triangles, boxes, triangle_index, n); break;
    case 3: packet_leaf<3>(s, triangles, boxes, triangle_index, n); break;
    case 4: packet_leaf<4>(s, triangles, boxes, triangle_index, n); break;
    default: break;
  }
}

#else

bool segment_packets_available() { return false; }

void segment_packet_leaf(SegmentPacket&, const PreparedTriangle*, const Aabb*, const int*, int) {
  assert(false && "segment_packet_leaf needs AVX (check segment_packets_available())");
}

#endif

}  // namespace pliant
