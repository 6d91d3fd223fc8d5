#include "sim/collision/surface_bvh.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

namespace pliant {
namespace {

// Slab test of origin + t dir against box for t in [0, t_max]; entry parameter in t_enter.
// Direction components below 1e-30 count as zero (no division, so no overflow trap).
bool ray_box(const Vec3& origin, const Vec3& dir, const Aabb& box, double t_max, double& t_enter) {
  double t0 = 0.0;
  double t1 = t_max;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(dir[k]) < 1e-30) {
      if (origin[k] < box.min[k] || origin[k] > box.max[k]) return false;
      continue;
    }
    double ta = (box.min[k] - origin[k]) / dir[k];
    double tb = (box.max[k] - origin[k]) / dir[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  t_enter = t0;
  return true;
}

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
  boxes_.resize(static_cast<size_t>(n));
  for (int t = 0; t < n; ++t) {
    Aabb box;
    for (int k = 0; k < 3; ++k) box.extend(corner(t, k));
    boxes_[static_cast<size_t>(t)] = box;
    centroids_[static_cast<size_t>(t)] = (corner(t, 0) + corner(t, 1) + corner(t, 2)) / 3.0;
    order_[static_cast<size_t>(t)] = t;
  }
  if (n == 0) return;
  nodes_.reserve(static_cast<size_t>(2 * (n / kLeafSize + 1)));
  build_node(0, n, 0);
}

int SurfaceBvh::build_node(int begin, int end, int depth) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(Node{});
  Aabb box, centroid_box;
  for (int i = begin; i < end; ++i) {
    const int t = order_[static_cast<size_t>(i)];
    box.extend(boxes_[static_cast<size_t>(t)].min);
    box.extend(boxes_[static_cast<size_t>(t)].max);
    centroid_box.extend(centroids_[static_cast<size_t>(t)]);
  }
  nodes_[static_cast<size_t>(index)].box = box;
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

bool SurfaceBvh::first_ray_hit(const Vec3& origin, const Vec3& dir, int exclude, SurfacePoint& hit) const {
  if (nodes_.empty()) return false;
  double best_t = std::numeric_limits<double>::max();
  int best_tri = -1;
  Vec3 best_bary = Vec3::Zero();
  int stack[kMaxStack];
  int top = 0;
  double t_enter = 0.0;
  if (!ray_box(origin, dir, nodes_[0].box, best_t, t_enter)) return false;
  stack[top++] = 0;
  while (top > 0) {
    const int n = stack[--top];
    const Node& node = nodes_[static_cast<size_t>(n)];
    if (!ray_box(origin, dir, node.box, best_t, t_enter)) continue;
    if (node.count == 0) {
      // Visit the nearer child first (pushed last).
      const int l = n + 1, r = node.first;
      double tl = 0.0, tr = 0.0;
      const bool hl = ray_box(origin, dir, nodes_[static_cast<size_t>(l)].box, best_t, tl);
      const bool hr = ray_box(origin, dir, nodes_[static_cast<size_t>(r)].box, best_t, tr);
      if (hl && hr) {
        if (tl <= tr) {
          stack[top++] = r;
          stack[top++] = l;
        } else {
          stack[top++] = l;
          stack[top++] = r;
        }
      } else if (hl) {
        stack[top++] = l;
      } else if (hr) {
        stack[top++] = r;
      }
      continue;
    }
    for (int i = node.first; i < node.first + node.count; ++i) {
      const int tri = order_[static_cast<size_t>(i)];
      if (excluded(tri, exclude, -1)) continue;
      TriangleHit h;
      if (ray_triangle_intersection(origin, dir, corner(tri, 0), corner(tri, 1), corner(tri, 2), 0.0, best_t, h)) {
        if (h.t < best_t || (h.t == best_t && tri < best_tri)) {
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
    if (box_distance_squared(p, node.box) > best_d2) continue;
    if (node.count == 0) {
      const int l = n + 1, r = node.first;
      const double dl = box_distance_squared(p, nodes_[static_cast<size_t>(l)].box);
      const double dr = box_distance_squared(p, nodes_[static_cast<size_t>(r)].box);
      if (dl <= dr) {
        stack[top++] = r;
        stack[top++] = l;
      } else {
        stack[top++] = l;
        stack[top++] = r;
      }
      continue;
    }
    for (int i = node.first; i < node.first + node.count; ++i) {
      const int tri = order_[static_cast<size_t>(i)];
      if (excluded(tri, exclude, -1)) continue;
      if (box_distance_squared(p, boxes_[static_cast<size_t>(tri)]) > best_d2) continue;
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
