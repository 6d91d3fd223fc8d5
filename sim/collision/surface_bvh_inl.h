// Template part of SurfaceBvh (segment queries are inlined into stage 2's edge loop).
#pragma once

#include "sim/collision/surface_bvh.h"
#include "sim/collision/triangle_queries.h"

namespace pliant {

inline const Vec3& SurfaceBvh::corner(int tri, int k) const {
  return x_[static_cast<size_t>(mesh_->surface_triangles()[static_cast<size_t>(tri)][static_cast<size_t>(k)])];
}

inline bool SurfaceBvh::excluded(int tri, int exclude_a, int exclude_b) const {
  if (exclude_a < 0 && exclude_b < 0) return false;
  for (int v : mesh_->surface_triangles()[static_cast<size_t>(tri)]) {
    if (v == exclude_a || v == exclude_b) return true;
  }
  return false;
}

template <class Visit>
void SurfaceBvh::for_each_segment_hit(const Vec3& a, const Vec3& b, int exclude_a, int exclude_b,
                                      Visit&& visit) const {
  if (nodes_.empty()) return;
  Aabb seg;
  seg.extend(a);
  seg.extend(b);
  const Vec3 dir = b - a;
  int stack[kMaxStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int n = stack[--top];
    const Node& node = nodes_[static_cast<size_t>(n)];
    if (!node.box.overlaps(seg)) continue;
    if (node.count == 0) {
      stack[top++] = n + 1;
      stack[top++] = node.first;
      continue;
    }
    for (int i = node.first; i < node.first + node.count; ++i) {
      const int tri = order_[static_cast<size_t>(i)];
      if (!boxes_[static_cast<size_t>(tri)].overlaps(seg) || excluded(tri, exclude_a, exclude_b)) continue;
      TriangleHit h;
      if (ray_triangle_intersection(a, dir, corner(tri, 0), corner(tri, 1), corner(tri, 2), 0.0, 1.0, h)) {
        SurfacePoint p;
        p.triangle = tri;
        p.barycentric = h.barycentric;
        p.point = h.barycentric[0] * corner(tri, 0) + h.barycentric[1] * corner(tri, 1) +
                  h.barycentric[2] * corner(tri, 2);
        p.t = h.t;
        visit(p);
      }
    }
  }
}

}  // namespace pliant
