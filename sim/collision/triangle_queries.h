// Point and ray queries against one triangle: Moller-Trumbore ray intersection and the closest point
// (Ericson, Real-Time Collision Detection, 5.1.5). Used by the surface BVH of stage 2.
#pragma once

#include <algorithm>
#include <cmath>

#include "sim/math_types.h"

namespace pliant {

/// Where a ray or segment meets a triangle.
struct TriangleHit {
  double t = 0.0;                       ///< ray parameter: hit = origin + t * direction
  Vec3 barycentric = Vec3::Zero();      ///< weights of the triangle's corners a, b, c (sum 1, in [0,1])
};

/// A triangle prepared for many ray tests: corner a, edges e1 = b - a and e2 = c - a, and
/// |e1|^2 |e2|^2 (the same values ray_triangle_intersection computes from the corners).
struct PreparedTriangle {
  Vec3 a, e1, e2;
  double e1e2_squared = 0.0;

  /// From corners (a, b, c).
  static PreparedTriangle of(const Vec3& a, const Vec3& b, const Vec3& c) {
    PreparedTriangle p{a, b - a, c - a, 0.0};
    p.e1e2_squared = p.e1.squaredNorm() * p.e2.squaredNorm();
    return p;
  }
};

/// The corner weights (1 - u - v, u, v) of a Moller-Trumbore hit, clamped to [0, 1] and summing to
/// 1 (u, v may lie up to the test's slack outside the triangle).
inline Vec3 clamped_barycentric(double u, double v) {
  Vec3 w(1.0 - u - v, u, v);
  w = w.cwiseMax(0.0);
  w /= w.sum();
  return w;
}

/// ray_triangle_intersection on a prepared triangle; dir_squared = |dir|^2. Bit for bit the same
/// result (the same operations in the same order), without reloading the corners.
inline bool ray_triangle_intersection(const Vec3& origin, const Vec3& dir, double dir_squared,
                                      const PreparedTriangle& tri, double t_min, double t_max, TriangleHit& hit) {
  constexpr double kSlack = 1e-12;
  const Vec3& e1 = tri.e1;
  const Vec3& e2 = tri.e2;
  const Vec3 pvec = dir.cross(e2);
  const double det = e1.dot(pvec);
  // Parallel or degenerate: |det| <= 1e-14 |e1| |e2| |dir|, compared squared (no square roots).
  const double scale2 = tri.e1e2_squared * dir_squared;
  if (!(det * det > 1e-28 * scale2)) return false;
  const double inv = 1.0 / det;
  const Vec3 tvec = origin - tri.a;
  const double u = tvec.dot(pvec) * inv;
  if (u < -kSlack || u > 1.0 + kSlack) return false;
  const Vec3 qvec = tvec.cross(e1);
  const double v = dir.dot(qvec) * inv;
  if (v < -kSlack || u + v > 1.0 + kSlack) return false;
  const double t = e2.dot(qvec) * inv;
  if (t < t_min || t > t_max) return false;
  hit.t = t;
  hit.barycentric = clamped_barycentric(u, v);
  return true;
}

/// Moller-Trumbore: does origin + t dir (t in [t_min, t_max]) cross triangle (a, b, c)? Points on
/// the triangle's edges count (a relative slack of 1e-12 in the barycentric coordinates, then
/// clamped), so a ray through a shared edge is not lost between the two triangles.
inline bool ray_triangle_intersection(const Vec3& origin, const Vec3& dir, const Vec3& a, const Vec3& b,
                                      const Vec3& c, double t_min, double t_max, TriangleHit& hit) {
  return ray_triangle_intersection(origin, dir, dir.squaredNorm(), PreparedTriangle::of(a, b, c), t_min, t_max, hit);
}

/// Closest point of triangle (a, b, c) to p, as barycentric weights (Ericson 5.1.5).
inline Vec3 closest_point_on_triangle_barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {1.0, 0.0, 0.0};
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return {0.0, 1.0, 0.0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double den = d1 - d3;  // = |ab|^2 > 0 unless the edge is degenerate
    const double v = den > 0.0 ? d1 / den : 0.0;
    return {1.0 - v, v, 0.0};
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return {0.0, 0.0, 1.0};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double den = d2 - d6;
    const double w = den > 0.0 ? d2 / den : 0.0;
    return {1.0 - w, 0.0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double den = (d4 - d3) + (d5 - d6);
    const double w = den > 0.0 ? (d4 - d3) / den : 0.0;
    return {0.0, 1.0 - w, w};
  }
  const double sum = va + vb + vc;
  if (!(sum > 0.0)) return {1.0, 0.0, 0.0};  // degenerate triangle: its first corner
  const double v = vb / sum, w = vc / sum;
  return {1.0 - v - w, v, w};
}

}  // namespace pliant
