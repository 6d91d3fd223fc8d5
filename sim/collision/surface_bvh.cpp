#include "sim/collision/surface_bvh.h"

#include "sim/collision/segment_packet.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace pliant {
namespace {

// Aabb::overlaps (closed boxes), one comparison at a time so a box apart on the first axis costs
// one or two comparisons; the same predicate (also false for NaN), so the same boxes pass.
inline bool boxes_meet(const Aabb& a, const Aabb& b) {
  return a.min[0] <= b.max[0] && b.min[0] <= a.max[0] && a.min[1] <= b.max[1] && b.min[1] <= a.max[1] &&
         a.min[2] <= b.max[2] && b.min[2] <= a.max[2];
}

// A ray with its reciprocal direction precomputed for slab tests. Direction components below 1e-30
// count as zero (no division, so no overflow or divide-by-zero trap).
struct SlabRay {
  Vec3 origin;
  Vec3 inv = Vec3::Zero();
  bool parallel[3] = {false, false, false};
  bool any_parallel = false;

  SlabRay(const Vec3& o, const Vec3& d) : origin(o) {
    for (int k = 0; k < 3; ++k) {
      parallel[k] = std::abs(d[k]) < 1e-30;
      any_parallel = any_parallel || parallel[k];
      if (!parallel[k]) inv[k] = 1.0 / d[k];
    }
  }

  // Does origin + t dir meet box for some t in [0, t_max]? Entry parameter in t_enter. The entry
  // only grows and the exit only shrinks axis by axis, so testing them once at the end (branch
  // free, the common case of no parallel axis) decides exactly as testing after every axis.
  // The box is inflated by `slack` (m) on every side, computed as SurfaceBvh::query_box does
  // (box.min - slack, box.max + slack; exact for slack = 0) without building the inflated box.
  bool hits(const Aabb& box, double slack, double t_max, double& t_enter) const {
    double t0 = 0.0;
    double t1 = t_max;
    if (!any_parallel) {
      for (int k = 0; k < 3; ++k) {
        const double ta = ((box.min[k] - slack) - origin[k]) * inv[k];
        const double tb = ((box.max[k] + slack) - origin[k]) * inv[k];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
      }
      t_enter = t0;
      return t0 <= t1;
    }
    for (int k = 0; k < 3; ++k) {
      const double lo = box.min[k] - slack, hi = box.max[k] + slack;
      if (parallel[k]) {
        if (origin[k] < lo || origin[k] > hi) return false;
        continue;
      }
      double ta = (lo - origin[k]) * inv[k];
      double tb = (hi - origin[k]) * inv[k];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    t_enter = t0;
    return true;
  }
};

// Squared distance from p to box (0 inside).
double box_distance_squared(const Vec3& p, const Aabb& box) {
  const Vec3 d = (box.min - p).cwiseMax(p - box.max).cwiseMax(0.0);
  return d.squaredNorm();
}

}  // namespace

void SurfaceBvh::build(const TetMesh& mesh, std::span<const Vec3> x) {
  mesh_ = &mesh;
  x_ = x;
  const int n = mesh.surface_triangle_count();
  nodes_.clear();
  order_.resize(static_cast<size_t>(n));
  centroids_.resize(static_cast<size_t>(n));
  for (int t = 0; t < n; ++t) {
    centroids_[static_cast<size_t>(t)] = (corner(t, 0) + corner(t, 1) + corner(t, 2)) / 3.0;
    order_[static_cast<size_t>(t)] = t;
  }
  ++pose_epoch_;
  triangle_boxes_.resize(static_cast<size_t>(n));
  prepared_.resize(static_cast<size_t>(n));
  if (n == 0) {
    quad_.build(nodes_);
    remember_fitted_positions();
    slack_ = 0.0;
    return;
  }
  nodes_.reserve(static_cast<size_t>(2 * (n / kLeafSize + 1)));
  build_node(0, n, 0);
  leaf_epoch_.assign(nodes_.size(), 0);
  quad_.build(nodes_);
  fan_leaves_.resize(static_cast<size_t>(quad_.leaf_count()));
  full_refit();
}

void SurfaceBvh::remember_fitted_positions() {
  const std::vector<int>& surface = mesh_->surface_vertices();
  fitted_positions_.resize(surface.size());
  double scale = 0.0;
  for (size_t k = 0; k < surface.size(); ++k) {
    const Vec3& p = x_[static_cast<size_t>(surface[k])];
    fitted_positions_[k] = p;
    scale = std::max(scale, p.cwiseAbs().maxCoeff());
  }
  fitted_scale_ = scale;
}

void SurfaceBvh::fit_leaf(const Node& node) const {
  for (int j = node.first; j < node.first + node.count; ++j) {
    const int tri = order_[static_cast<size_t>(j)];
    const Vec3 &a = corner(tri, 0), &b = corner(tri, 1), &c = corner(tri, 2);
    Aabb& box = triangle_boxes_[static_cast<size_t>(j)];
    box.min = a.cwiseMin(b).cwiseMin(c);
    box.max = a.cwiseMax(b).cwiseMax(c);
    prepared_[static_cast<size_t>(j)] = PreparedTriangle::of(a, b, c);
  }
}

void SurfaceBvh::full_refit() {
  // Children come after their parent in depth-first order: a reverse sweep refits bottom-up.
  for (int i = static_cast<int>(nodes_.size()) - 1; i >= 0; --i) {
    Node& node = nodes_[static_cast<size_t>(i)];
    Aabb box;
    if (node.count > 0) {
      fit_leaf(node);
      leaf_epoch_[static_cast<size_t>(i)] = pose_epoch_;
      for (int j = node.first; j < node.first + node.count; ++j) {
        const Aabb& b = triangle_boxes_[static_cast<size_t>(j)];
        box.min = box.min.cwiseMin(b.min);
        box.max = box.max.cwiseMax(b.max);
      }
    } else {
      for (const int c : {i + 1, node.first}) {
        box.min = box.min.cwiseMin(nodes_[static_cast<size_t>(c)].box.min);
        box.max = box.max.cwiseMax(nodes_[static_cast<size_t>(c)].box.max);
      }
    }
    node.box = box;
  }
  quad_.refresh_boxes(nodes_);
  remember_fitted_positions();
  slack_ = 0.0;
}

SurfaceBvhUpdate SurfaceBvh::refit(std::span<const Vec3> x, double lazy_limit_edges, bool rebuild_when_full) {
  assert(mesh_ != nullptr);
  x_ = x;
  // Largest motion of a surface vertex since the boxes were fitted (max-norm); NaN counts as far.
  const std::vector<int>& surface = mesh_->surface_vertices();
  const double limit = lazy_limit_edges * mesh_->mean_edge_length();
  double delta = 0.0;
  bool beyond = false;
  for (size_t k = 0; k < surface.size(); ++k) {
    const double m = (x[static_cast<size_t>(surface[k])] - fitted_positions_[k]).cwiseAbs().maxCoeff();
    beyond = beyond || !(m <= limit);
    delta = std::max(delta, m);
  }
  if (!beyond && delta == 0.0) {
    // Unchanged only if no lazy step since the fit: the leaves may hold another pose's data.
    if (slack_ == 0.0) return SurfaceBvhUpdate::unchanged;
    ++pose_epoch_;  // back at the fitted positions: exact node boxes, leaves refitted on demand
    slack_ = 0.0;
    return SurfaceBvhUpdate::lazy;
  }
  ++pose_epoch_;
  if (!beyond && !nodes_.empty()) {
    // Every corner lies within delta of where the boxes were fitted. The margins cover the rounding
    // of delta itself and of box +- slack (coordinates up to fitted_scale_).
    slack_ = delta * (1.0 + 1e-12) + 1e-14 * fitted_scale_;
    return SurfaceBvhUpdate::lazy;
  }
  if (rebuild_when_full) {
    build(*mesh_, x);
    return SurfaceBvhUpdate::rebuild;
  }
  full_refit();
  return SurfaceBvhUpdate::refit;
}

Aabb SurfaceBvh::query_box(int n) const {
  const Aabb& box = nodes_[static_cast<size_t>(n)].box;
  if (slack_ == 0.0) return box;
  Aabb inflated;
  inflated.min = box.min.array() - slack_;
  inflated.max = box.max.array() + slack_;
  return inflated;
}

int SurfaceBvh::build_node(int begin, int end, int depth) {
  // Boxes are fitted afterwards (full_refit); the split needs only the centroids' bounds.
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(Node{});
  Aabb centroid_box;
  for (int i = begin; i < end; ++i) centroid_box.extend(centroids_[static_cast<size_t>(order_[static_cast<size_t>(i)])]);
  // The stack of a query holds at most two entries per level.
  if (end - begin <= kLeafSize || 2 * depth + 4 >= kMaxStack) {
    nodes_[static_cast<size_t>(index)].first = begin;
    nodes_[static_cast<size_t>(index)].count = end - begin;
    return index;
  }
  int axis = 0;
  centroid_box.extent().maxCoeff(&axis);
  const int mid = (begin + end) / 2;
  // Median split; ties by triangle index so the tree is a function of the positions only.
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end, [&](int a, int b) {
    const double ca = centroids_[static_cast<size_t>(a)][axis], cb = centroids_[static_cast<size_t>(b)][axis];
    return ca < cb || (ca == cb && a < b);
  });
  build_node(begin, mid, depth + 1);
  const int right = build_node(mid, end, depth + 1);
  nodes_[static_cast<size_t>(index)].first = right;
  nodes_[static_cast<size_t>(index)].count = 0;
  return index;
}

bool SurfaceBvh::first_ray_hit(const Vec3& origin, const Vec3& dir, int exclude_a, SurfacePoint& hit,
                               double t_max, int exclude_b) const {
  if (nodes_.empty()) return false;
  const SlabRay ray(origin, dir);
  const double dir_squared = dir.squaredNorm();
  double best_t = t_max;
  int best_tri = -1;
  Vec3 best_bary = Vec3::Zero();
  // Stack entries carry their entry parameter: a node is tested once, when its parent is popped.
  int stack[kMaxStack];
  double stack_t[kMaxStack];
  int top = 0;
  double t_enter = 0.0;
  if (!ray.hits(nodes_[0].box, slack_, best_t, t_enter)) return false;
  stack[top] = 0;
  stack_t[top++] = t_enter;
  while (top > 0) {
    --top;
    const int n = stack[top];
    if (stack_t[top] > best_t) continue;  // a nearer hit was found since it was pushed
    const Node& node = nodes_[static_cast<size_t>(n)];
    if (node.count == 0) {
      // Visit the nearer child first (pushed last).
      const int l = n + 1, r = node.first;
      double tl = 0.0, tr = 0.0;
      const bool hl = ray.hits(nodes_[static_cast<size_t>(l)].box, slack_, best_t, tl);
      const bool hr = ray.hits(nodes_[static_cast<size_t>(r)].box, slack_, best_t, tr);
      if (hl && hr) {
        const bool left_first = tl <= tr;
        stack[top] = left_first ? r : l;
        stack_t[top++] = left_first ? tr : tl;
        stack[top] = left_first ? l : r;
        stack_t[top++] = left_first ? tl : tr;
      } else if (hl) {
        stack[top] = l;
        stack_t[top++] = tl;
      } else if (hr) {
        stack[top] = r;
        stack_t[top++] = tr;
      }
      continue;
    }
    ensure_leaf(n);
    for (int i = node.first; i < node.first + node.count; ++i) {
      const int tri = order_[static_cast<size_t>(i)];
      if (excluded(tri, exclude_a, exclude_b)) continue;
      TriangleHit h;
      if (ray_triangle_intersection(origin, dir, dir_squared, prepared_[static_cast<size_t>(i)], 0.0, best_t, h)) {
        if (best_tri < 0 || h.t < best_t || (h.t == best_t && tri < best_tri)) {
          best_t = h.t;
          best_tri = tri;
          best_bary = h.barycentric;
        }
      }
    }
  }
  if (best_tri < 0) return false;
  hit.triangle = best_tri;
  hit.barycentric = best_bary;
  hit.point = best_bary[0] * corner(best_tri, 0) + best_bary[1] * corner(best_tri, 1) +
              best_bary[2] * corner(best_tri, 2);
  hit.t = best_t;
  hit.distance_squared = (hit.point - origin).squaredNorm();
  return true;
}

void SurfaceBvh::first_segment_hits(const Vec3& end, int exclude_end, std::span<const Vec3> origins,
                                    std::span<const int> exclude_origins, std::span<SurfacePoint> hits,
                                    std::span<char> found) const {
  const int total = static_cast<int>(origins.size());
  for (int begin = 0; begin < total; begin += kFanChunk) {
    const int m = std::min(kFanChunk, total - begin);
    Aabb fan;
    fan.extend(end);
    for (int i = 0; i < m; ++i) fan.extend(origins[static_cast<size_t>(begin + i)]);
    // Self-collision only: some segment skips the triangles holding its ends.
    bool any_exclude = exclude_end >= 0;
    for (int i = 0; i < m; ++i) any_exclude = any_exclude || exclude_origins[static_cast<size_t>(begin + i)] >= 0;
    // Node boxes are inflated by slack_ (lazy refit): inflate the fan's box instead.
    Aabb node_query = fan;
    if (slack_ > 0.0) {
      node_query.min.array() -= slack_;
      node_query.max.array() += slack_;
    }
    const auto chunk = static_cast<size_t>(begin);
    if (segment_packets_ && !any_exclude && segment_packets_available()) {
      fan_chunk_packet(end, node_query, origins.subspan(chunk, static_cast<size_t>(m)),
                       hits.subspan(chunk, static_cast<size_t>(m)), found.subspan(chunk, static_cast<size_t>(m)));
    } else {
      fan_chunk_scalar(end, exclude_end, fan, node_query, any_exclude, origins.subspan(chunk, static_cast<size_t>(m)),
                       exclude_origins.subspan(chunk, static_cast<size_t>(m)),
                       hits.subspan(chunk, static_cast<size_t>(m)), found.subspan(chunk, static_cast<size_t>(m)));
    }
  }
}

template <class Leaf>
void SurfaceBvh::visit_leaves_meeting(const Aabb& query, Leaf&& leaf) const {
  int stack[kMaxStack];
  int top = 0;
  if (!nodes_.empty()) stack[top++] = 0;
  while (top > 0) {
    const int n = stack[--top];
    const Node& node = nodes_[static_cast<size_t>(n)];
    if (!boxes_meet(node.box, query)) continue;
    if (node.count == 0) {
      stack[top++] = node.first;
      stack[top++] = n + 1;
      continue;
    }
    ensure_leaf(n);
    leaf(node);
  }
}

void SurfaceBvh::leaves_meeting(const Aabb& query, bool quad, std::vector<int>& out) const {
  out.clear();
  if (quad) {
    out.resize(static_cast<size_t>(quad_.leaf_count()));
    out.resize(static_cast<size_t>(quad_.leaves_meeting(query, out.data())));
    return;
  }
  visit_leaves_meeting(query, [&](const Node& node) { out.push_back(static_cast<int>(&node - nodes_.data())); });
}

void SurfaceBvh::fan_chunk_packet(const Vec3& end, const Aabb& node_query, std::span<const Vec3> origins,
                                  std::span<SurfacePoint> hits, std::span<char> found) const {
  const int m = static_cast<int>(origins.size());
  SegmentPacket packet;
  packet.load(end, origins.data(), m);
  // Every triangle of every leaf whose box meets the fan's box, in the scalar loop's order (the
  // 4-wide tree finds the binary traversal's leaves in its order); a triangle that meets no
  // segment's box is rejected by its lanes' box masks.
  const int leaves = quad_.leaves_meeting(node_query, fan_leaves_.data());
  for (int l = 0; l < leaves; ++l) {
    const int n = fan_leaves_[static_cast<size_t>(l)];
    ensure_leaf(n);
    const Node& node = nodes_[static_cast<size_t>(n)];
    const auto first = static_cast<size_t>(node.first);
    segment_packet_leaf(packet, &prepared_[first], &triangle_boxes_[first], &order_[first], node.count);
  }
  for (int i = 0; i < m; ++i) {
    const auto k = static_cast<size_t>(i);
    const int t = static_cast<int>(packet.best_triangle[i]);
    found[k] = t >= 0 ? 1 : 0;
    if (t < 0) continue;
    SurfacePoint& hit = hits[k];
    const Vec3 w = clamped_barycentric(packet.best_u[i], packet.best_v[i]);
    hit.triangle = t;
    hit.barycentric = w;
    hit.point = w[0] * corner(t, 0) + w[1] * corner(t, 1) + w[2] * corner(t, 2);
    hit.t = packet.best_t[i];
    hit.distance_squared = (hit.point - origins[k]).squaredNorm();
  }
}

void SurfaceBvh::fan_chunk_scalar(const Vec3& end, int exclude_end, const Aabb& fan, const Aabb& node_query,
                                  bool any_exclude, std::span<const Vec3> origins,
                                  std::span<const int> exclude_origins, std::span<SurfacePoint> hits,
                                  std::span<char> found) const {
  const int m = static_cast<int>(origins.size());
  // Segment boxes as separate coordinate arrays, so a triangle box is tested against all of them
  // without branches (the outcome is hard to predict).
  // Padded to an even count with empty boxes (min +inf, max -inf: they meet nothing), so the mask
  // is built two segments at a time.
  alignas(16) double seg_min[3][kFanChunk], seg_max[3][kFanChunk];
  Vec3 dir[kFanChunk];
  double best_t[kFanChunk], dir_squared[kFanChunk];
  int best_tri[kFanChunk];
  Vec3 best_bary[kFanChunk];
  for (int i = 0; i < m; ++i) {
    const Vec3& o = origins[static_cast<size_t>(i)];
    for (int k = 0; k < 3; ++k) {
      seg_min[k][i] = std::min(o[k], end[k]);
      seg_max[k][i] = std::max(o[k], end[k]);
    }
    dir[i] = end - o;
    dir_squared[i] = dir[i].squaredNorm();
    best_t[i] = 1.0;
    best_tri[i] = -1;
    best_bary[i] = Vec3::Zero();
  }
  const int padded = (m + 1) & ~1;
  for (int i = m; i < padded; ++i) {
    for (int k = 0; k < 3; ++k) {
      seg_min[k][i] = std::numeric_limits<double>::infinity();
      seg_max[k][i] = -std::numeric_limits<double>::infinity();
    }
  }
  // Every node and triangle whose box meets the fan's box; a triangle is tested against each
  // segment whose own box it meets. The smallest (t, triangle) per segment is kept, as the
  // nearest-first traversal of first_ray_hit keeps it, so the order of visits does not matter.
  visit_leaves_meeting(node_query, [&](const Node& node) {
    for (int j = node.first; j < node.first + node.count; ++j) {
      const Aabb& box = triangle_boxes_[static_cast<size_t>(j)];
      if (!boxes_meet(box, fan)) continue;
      // Bit i: the triangle's box meets segment i's box (the same six closed comparisons per
      // segment, two segments per SSE2 compare; padding segments never meet).
      unsigned mask = 0;
#if defined(__SSE2__)
      const __m128d min_x = _mm_set1_pd(box.min[0]), min_y = _mm_set1_pd(box.min[1]), min_z = _mm_set1_pd(box.min[2]);
      const __m128d max_x = _mm_set1_pd(box.max[0]), max_y = _mm_set1_pd(box.max[1]), max_z = _mm_set1_pd(box.max[2]);
      for (int i = 0; i < padded; i += 2) {
        __m128d meets = _mm_and_pd(_mm_cmple_pd(min_x, _mm_load_pd(&seg_max[0][i])),
                                   _mm_cmple_pd(_mm_load_pd(&seg_min[0][i]), max_x));
        meets = _mm_and_pd(meets, _mm_and_pd(_mm_cmple_pd(min_y, _mm_load_pd(&seg_max[1][i])),
                                             _mm_cmple_pd(_mm_load_pd(&seg_min[1][i]), max_y)));
        meets = _mm_and_pd(meets, _mm_and_pd(_mm_cmple_pd(min_z, _mm_load_pd(&seg_max[2][i])),
                                             _mm_cmple_pd(_mm_load_pd(&seg_min[2][i]), max_z)));
        mask |= static_cast<unsigned>(_mm_movemask_pd(meets)) << i;
      }
#else
      for (int i = 0; i < padded; ++i) {
        const bool meets = (box.min[0] <= seg_max[0][i]) & (seg_min[0][i] <= box.max[0]) &
                           (box.min[1] <= seg_max[1][i]) & (seg_min[1][i] <= box.max[1]) &
                           (box.min[2] <= seg_max[2][i]) & (seg_min[2][i] <= box.max[2]);
        mask |= static_cast<unsigned>(meets) << i;
      }
#endif
      const int tri = order_[static_cast<size_t>(j)];
      for (; mask != 0; mask &= mask - 1) {
        const int i = std::countr_zero(mask);
        if (any_exclude && excluded(tri, exclude_origins[static_cast<size_t>(i)], exclude_end)) continue;
        TriangleHit h;
        if (ray_triangle_intersection(origins[static_cast<size_t>(i)], dir[i], dir_squared[i],
                                      prepared_[static_cast<size_t>(j)], 0.0, best_t[i], h)) {
          if (best_tri[i] < 0 || h.t < best_t[i] || (h.t == best_t[i] && tri < best_tri[i])) {
            best_t[i] = h.t;
            best_tri[i] = tri;
            best_bary[i] = h.barycentric;
          }
        }
      }
    }
  });
  for (int i = 0; i < m; ++i) {
    const auto k = static_cast<size_t>(i);
    found[k] = best_tri[i] >= 0 ? 1 : 0;
    if (best_tri[i] < 0) continue;
    SurfacePoint& hit = hits[k];
    const int t = best_tri[i];
    hit.triangle = t;
    hit.barycentric = best_bary[i];
    hit.point = best_bary[i][0] * corner(t, 0) + best_bary[i][1] * corner(t, 1) + best_bary[i][2] * corner(t, 2);
    hit.t = best_t[i];
    hit.distance_squared = (hit.point - origins[k]).squaredNorm();
  }
}

bool SurfaceBvh::nearest_point(const Vec3& p, int exclude, SurfacePoint& nearest) const {
  if (nodes_.empty()) return false;
  double best_d2 = std::numeric_limits<double>::max();
  int best_tri = -1;
  Vec3 best_bary = Vec3::Zero();
  int stack[kMaxStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int n = stack[--top];
    const Node& node = nodes_[static_cast<size_t>(n)];
    if (box_distance_squared(p, query_box(n)) > best_d2) continue;
    if (node.count == 0) {
      const int l = n + 1, r = node.first;
      const double dl = box_distance_squared(p, query_box(l));
      const double dr = box_distance_squared(p, query_box(r));
      if (dl <= dr) {
        stack[top++] = r;
        stack[top++] = l;
      } else {
        stack[top++] = l;
        stack[top++] = r;
      }
      continue;
    }
    ensure_leaf(n);
    for (int i = node.first; i < node.first + node.count; ++i) {
      const int tri = order_[static_cast<size_t>(i)];
      if (excluded(tri, exclude, -1)) continue;
      if (box_distance_squared(p, triangle_boxes_[static_cast<size_t>(i)]) > best_d2) continue;
      const Vec3 w = closest_point_on_triangle_barycentric(p, corner(tri, 0), corner(tri, 1), corner(tri, 2));
      const Vec3 q = w[0] * corner(tri, 0) + w[1] * corner(tri, 1) + w[2] * corner(tri, 2);
      const double d2 = (q - p).squaredNorm();
      if (d2 < best_d2 || (d2 == best_d2 && tri < best_tri)) {
        best_d2 = d2;
        best_tri = tri;
        best_bary = w;
      }
    }
  }
  if (best_tri < 0) return false;
  nearest.triangle = best_tri;
  nearest.barycentric = best_bary;
  nearest.point = best_bary[0] * corner(best_tri, 0) + best_bary[1] * corner(best_tri, 1) +
                  best_bary[2] * corner(best_tri, 2);
  nearest.t = 0.0;
  nearest.distance_squared = best_d2;
  return true;
}

}  // namespace pliant
