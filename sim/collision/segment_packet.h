// A packet of segments that end at one point (a border point's fan of edges), tested against the
// triangles of a BVH leaf four segments at a time in 256-bit lanes (session 9, issue #4).
//
// Design note. The scalar fan query (SurfaceBvh::first_segment_hits) tests a triangle against
// each segment whose box it meets by Moller-Trumbore with early exits: per fan ~50 mispredicted
// branches, most of them the u/v rejections and the loop over a triangle's segment mask
// (docs/penetration-depth.md, sessions 5 and 8). Here one triangle is tested against four
// segments per AVX instruction with no early exit: the box test, the determinant test, the u, v
// and t range tests and the "nearer than the best so far" rule become lane masks, and each
// segment's best (t, triangle, u, v) is replaced by a blend. Exactness: every lane performs the
// scalar ray_triangle_intersection's operations on the same operands in the same order (the dot
// products as Eigen sums them, (x0 + x1) + x2; cross products a1 b2 - a2 b1; no FMA: the kernel
// is compiled for "avx" only), and every comparison is the scalar one, including its behaviour for
// NaN (!(u < -slack) rather than u >= -slack). Triangles are visited in the scalar loop's order
// and each segment keeps its best by the scalar rule (t <= best t, then smaller t or equal t and
// smaller index), so each segment's best goes through the same sequence of values as in the
// scalar query: results are bit for bit the same, ties included. A rejected lane's determinant is
// replaced by 1 before the division, so no lane traps (tests run with floating-point traps on).
// The kernel is chosen at run time (segment_packets_available()); without AVX the scalar query
// runs unchanged. Self-collision fans (excluded vertices) always take the scalar query.
#pragma once

#include "sim/collision/triangle_queries.h"
#include "sim/math_types.h"

namespace pliant {

/// Up to kCapacity segments origin_i -> end (t in [0, 1]) in structure-of-arrays order, padded to
/// a multiple of four lanes, with each segment's best hit so far.
struct SegmentPacket {
  static constexpr int kCapacity = 16;
  static constexpr int kLanes = 4;

  alignas(32) double origin[3][kCapacity];  ///< segment start (t = 0), m; padding lanes 0
  alignas(32) double dir[3][kCapacity];     ///< end - origin, m; padding lanes 0 (never accepted)
  alignas(32) double dir_squared[kCapacity];///< |dir|^2, m^2
  alignas(32) double box_min[3][kCapacity]; ///< segment's box; padding lanes +inf (meets nothing)
  alignas(32) double box_max[3][kCapacity]; ///< padding lanes -inf
  alignas(32) double best_t[kCapacity];     ///< parameter of the best hit so far (1 while none)
  alignas(32) double best_triangle[kCapacity];///< its triangle index (-1 while none), exact in a double
  alignas(32) double best_u[kCapacity];     ///< its Moller-Trumbore u
  alignas(32) double best_v[kCapacity];     ///< its Moller-Trumbore v
  int count = 0;                            ///< segments in use
  int lanes = 0;                            ///< count rounded up to a multiple of kLanes

  /// Loads segments origins[0..count) -> end (count <= kCapacity) and clears the best hits.
  void load(const Vec3& end, const Vec3* origins, int n);
};

/// True when this CPU runs segment_packet_leaf (AVX).
bool segment_packets_available();

/// Tests the packet against triangles [0, n) of a leaf in that order (prepared corners and edges,
/// boxes, and surface-triangle indices), keeping each segment's smallest (t, triangle) exactly as
/// SurfaceBvh::first_segment_hits' scalar loop keeps it. Only where segment_packets_available().
void segment_packet_leaf(SegmentPacket& packet, const PreparedTriangle* triangles, const Aabb* boxes,
                         const int* triangle_index, int n);

}  // namespace pliant
