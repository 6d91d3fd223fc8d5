#include "sim/collision/tet_walk.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/collision/triangle_queries.h"

namespace pliant {

namespace {

// Face normals and the usable-volume test of one tet at positions x (the walk's per-visit arithmetic).
[[gnu::always_inline]] inline void face_planes(const TetMesh& mesh, std::span<const Vec3> x, int tet,
                                               TetFacePlanes::Tet& out) {
  const TetIndices& v = mesh.tets()[static_cast<size_t>(tet)];
  const Vec3* c[4];
  for (int k = 0; k < 4; ++k) c[k] = &x[static_cast<size_t>(v[static_cast<size_t>(k)])];
  for (int k = 0; k < 4; ++k) {
    const auto& f = TetMesh::kTetFaceCorners[k];
    const Vec3& xi = *c[f[0]];
    out.normal[static_cast<size_t>(k)] = (*c[f[1]] - xi).cross(*c[f[2]] - xi);  // outward (area x 2)
  }
  const double volume6 = out.normal[0].dot(*c[TetMesh::kTetFaceCorners[0][0]] - *c[0]);  // 6 x signed volume
  // Flat or inverted tet (|6V| below 1e-12 of its first edge lengths' cube): the side functions
  // do not bound it any more.
  const double l2 =
      std::max({(*c[1] - *c[0]).squaredNorm(), (*c[2] - *c[0]).squaredNorm(), (*c[3] - *c[0]).squaredNorm()});
  out.usable = volume6 > 0.0 && volume6 * volume6 > 1e-24 * l2 * l2 * l2;
}

}  // namespace

void TetFacePlanes::new_pose(int tet_count) {
  const auto n = static_cast<size_t>(tet_count);
  if (tets_.size() != n) {
    tets_.assign(n, Tet{});
    stamp_.assign(n, 0);
    pose_ = 0;
  }
  if (++pose_ == 0) {  // wrapped: no stamp may equal a later pose by accident
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    pose_ = 1;
  }
}

const TetFacePlanes::Tet& TetFacePlanes::tet(const TetMesh& mesh, std::span<const Vec3> x, int tet) {
  const auto i = static_cast<size_t>(tet);
  if (stamp_[i] != pose_) {
    face_planes(mesh, x, tet, tets_[i]);
    stamp_[i] = pose_;
  }
  return tets_[i];
}

namespace {

// The walk (design note in tet_walk.h); `planes_of(tet)` gives a tet's face normals at positions x.
template <class PlanesOf>
TetWalkResult walk(const TetMesh& mesh, std::span<const Vec3> x, int start, const Vec3& a, const Vec3& d,
                   double s_max, int max_steps, TetWalkExit& exit, PlanesOf&& planes_of) {
  const auto& tets = mesh.tets();
  const auto& neighbors = mesh.tet_face_neighbors();
  const auto& face_triangles = mesh.tet_face_triangles();
  int tet = start;
  int entry = -1;  // local face entered by (-1: the start tet)
  double s = 0.0;
  for (int step = 1; step <= max_steps; ++step) {
    const TetFacePlanes::Tet& t = planes_of(tet);
    if (!t.usable) return TetWalkResult::failed;
    const TetIndices& v = tets[static_cast<size_t>(tet)];
    int best_face = -1, best_surface = -1;
    double best_s = std::numeric_limits<double>::infinity(), best_surface_s = best_s;
    const auto& tet_face_triangles = face_triangles[static_cast<size_t>(tet)];
    for (int k = 0; k < 4; ++k) {
      if (k == entry) continue;
      const Vec3& n = t.normal[static_cast<size_t>(k)];
      const double nd = n.dot(d);
      if (!(nd > 0.0)) continue;
      const Vec3& xi = x[static_cast<size_t>(v[static_cast<size_t>(TetMesh::kTetFaceCorners[k][0])])];
      const double sk = -n.dot(a - xi) / nd;
      if (sk < best_s) {
        best_s = sk;
        best_face = k;
      }
      if (tet_face_triangles[static_cast<size_t>(k)] >= 0 && sk < best_surface_s) {
        best_surface_s = sk;
        best_surface = k;
      }
    }
    if (best_face < 0) return TetWalkResult::failed;
    // Session 20: where the line leaves through a surface vertex or edge, an interior face and a
    // surface face tie, and rounding can pick the interior one and send the walk on through the
    // body, out of its far side (PenetrationDepth.EnclosedPointUnderADentedVertexKeepsItsNearestPoint:
    // one such ray in its first 3,200). A surface face within a rounding margin of the best exit is
    // taken instead; the exit's hit is then Moller-Trumbore's around that triangle, or the walk
    // fails and the BVH answers.
    if (best_surface >= 0 && best_surface != best_face) {
      const Vec3& xi = x[static_cast<size_t>(v[static_cast<size_t>(TetMesh::kTetFaceCorners[best_face][0])])];
      const double margin = 1e-9 * (std::abs(best_s) + (a - xi).norm() / d.norm());
      if (best_surface_s <= best_s + margin) {
        best_face = best_surface;
        best_s = best_surface_s;
      }
    }
    s = std::max(s, best_s);
    if (s > s_max) return TetWalkResult::beyond_end;
    const int triangle = tet_face_triangles[static_cast<size_t>(best_face)];
    if (triangle >= 0) {
      exit.triangle = triangle;
      exit.tet = tet;
      exit.s = s;
      exit.steps = step;
      return TetWalkResult::exited;
    }
    const int next = neighbors[static_cast<size_t>(tet)][static_cast<size_t>(best_face)];
    entry = -1;
    for (int k = 0; k < 4; ++k) {
      if (neighbors[static_cast<size_t>(next)][static_cast<size_t>(k)] == tet) entry = k;
    }
    tet = next;
  }
  return TetWalkResult::failed;
}

}  // namespace

TetWalkResult walk_to_surface(const TetMesh& mesh, std::span<const Vec3> x, int start, const Vec3& a,
                              const Vec3& d, double s_max, int max_steps, TetWalkExit& exit,
                              TetFacePlanes* planes) {
  if (planes != nullptr) {
    return walk(mesh, x, start, a, d, s_max, max_steps, exit,
                [&](int tet) -> const TetFacePlanes::Tet& { return planes->tet(mesh, x, tet); });
  }
  TetFacePlanes::Tet local;
  return walk(mesh, x, start, a, d, s_max, max_steps, exit, [&](int tet) -> const TetFacePlanes::Tet& {
    face_planes(mesh, x, tet, local);
    return local;
  });
}

bool surface_hit_near(const TetMesh& mesh, std::span<const Vec3> x, int triangle, const Vec3& origin,
                      const Vec3& dir, double t_max, SurfacePoint& hit) {
  constexpr double kBorder = 1e-9;  // barycentric distance to the border that triggers the tie search
  const auto& tris = mesh.surface_triangles();
  auto corner = [&](int t, int k) -> const Vec3& {
    return x[static_cast<size_t>(tris[static_cast<size_t>(t)][static_cast<size_t>(k)])];
  };
  int best_tri = -1;
  TriangleHit best;
  TriangleHit h;
  if (ray_triangle_intersection(origin, dir, corner(triangle, 0), corner(triangle, 1), corner(triangle, 2), 0.0,
                                t_max, h) &&
      h.barycentric.minCoeff() > kBorder) {
    best_tri = triangle;
    best = h;
  } else {
    // Near a shared edge or corner: the BVH keeps the smallest (t, index) of all triangles there.
    for (int k = 0; k < 3; ++k) {
      for (int t : mesh.vertex_surface_triangles(tris[static_cast<size_t>(triangle)][static_cast<size_t>(k)])) {
        if (!ray_triangle_intersection(origin, dir, corner(t, 0), corner(t, 1), corner(t, 2), 0.0, t_max, h)) continue;
        if (best_tri < 0 || h.t < best.t || (h.t == best.t && t < best_tri)) {
          best_tri = t;
          best = h;
        }
      }
    }
    if (best_tri < 0) return false;
  }
  // As SurfaceBvh reports a hit (same expressions).
  hit.triangle = best_tri;
  hit.barycentric = best.barycentric;
  hit.point = best.barycentric[0] * corner(best_tri, 0) + best.barycentric[1] * corner(best_tri, 1) +
              best.barycentric[2] * corner(best_tri, 2);
  hit.t = best.t;
  hit.distance_squared = (hit.point - origin).squaredNorm();
  return true;
}

bool walk_edge_hit(const TetMesh& mesh, std::span<const Vec3> x, int tet_of_p, const Vec3& p, const Vec3& q,
                   int max_steps, SurfacePoint& hit, int* steps, TetFacePlanes* planes) {
  TetWalkExit exit;
  const TetWalkResult r = walk_to_surface(mesh, x, tet_of_p, p, q - p, 1.0, max_steps, exit, planes);
  if (steps != nullptr) *steps = exit.steps;
  if (r != TetWalkResult::exited) return false;
  return surface_hit_near(mesh, x, exit.triangle, q, p - q, 1.0, hit);
}

bool walk_ray_hit(const TetMesh& mesh, std::span<const Vec3> x, int tet_of_p, const Vec3& p, const Vec3& r,
                  int max_steps, SurfacePoint& hit, int* steps, TetFacePlanes* planes) {
  TetWalkExit exit;
  const TetWalkResult result = walk_to_surface(
      mesh, x, tet_of_p, p, r, std::numeric_limits<double>::infinity(), max_steps, exit, planes);
  if (steps != nullptr) *steps = exit.steps;
  if (result != TetWalkResult::exited) return false;
  return surface_hit_near(mesh, x, exit.triangle, p, r, std::numeric_limits<double>::max(), hit);
}

}  // namespace pliant
