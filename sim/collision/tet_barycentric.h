// Barycentric coordinates of a point in a tetrahedron: the narrow-phase test of the spatial hash
// (Teschner et al. 2003; algorithms.md section 1), shared with the brute-force oracle in the tests.
#pragma once

#include <algorithm>
#include <cmath>

#include "sim/math_types.h"

namespace pliant {

/// A tetrahedron prepared for many point tests: x0 and the rows of A^-1 scaled by det(A), where
/// A = [x1-x0, x2-x0, x3-x0] (algorithms.md section 1).
struct TetBarycentricFrame {
  Vec3 x0 = Vec3::Zero();
  Vec3 row1 = Vec3::Zero();  ///< (x2-x0) x (x3-x0): b1 = row1.(p-x0) / det
  Vec3 row2 = Vec3::Zero();  ///< (x3-x0) x (x1-x0)
  Vec3 row3 = Vec3::Zero();  ///< (x1-x0) x (x2-x0)
  double det = 0.0;          ///< det(A) = 6 * signed volume (m^3); may be negative (inverted tet)
  bool degenerate = true;    ///< |det| too small relative to the edge lengths: no point is inside
  Aabb box;                  ///< bounding box of the four corners

  /// Prepares the frame of tet (x0, x1, x2, x3).
  static TetBarycentricFrame of(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
    TetBarycentricFrame f;
    const Vec3 e1 = x1 - x0;
    const Vec3 e2 = x2 - x0;
    const Vec3 e3 = x3 - x0;
    f.x0 = x0;
    f.box.extend(x0);
    f.box.extend(x1);
    f.box.extend(x2);
    f.box.extend(x3);
    f.row1 = e2.cross(e3);
    f.row2 = e3.cross(e1);
    f.row3 = e1.cross(e2);
    f.det = e1.dot(f.row1);
    // Relative threshold: a sliver with |det| < 1e-14 * (max edge)^3 has no well-defined inside.
    const double scale = std::max({e1.squaredNorm(), e2.squaredNorm(), e3.squaredNorm()});
    f.degenerate = !(std::abs(f.det) > 1e-14 * scale * std::sqrt(scale));
    return f;
  }

  /// Barycentric coordinates (b0, b1, b2, b3) of p; undefined (zero) for a degenerate tet.
  Vec4 barycentric(const Vec3& p) const {
    if (degenerate) return Vec4::Zero();
    const Vec3 d = p - x0;
    const double inv = 1.0 / det;
    const double b1 = row1.dot(d) * inv;
    const double b2 = row2.dot(d) * inv;
    const double b3 = row3.dot(d) * inv;
    return {1.0 - b1 - b2 - b3, b1, b2, b3};
  }

  /// Inside test of algorithms.md section 1: p in the tet's AABB, then b1, b2, b3 >= 0 and
  /// b1 + b2 + b3 <= 1 (closed tet). The AABB part makes the predicate exact on the box faces,
  /// where rounding in the barycentric coordinates could otherwise accept a point just outside.
  bool contains(const Vec3& p, Vec4* barycentric_out = nullptr) const {
    if (degenerate) return false;
    if ((p.array() < box.min.array()).any() || (p.array() > box.max.array()).any()) return false;
    const Vec4 b = barycentric(p);
    if (b[0] >= 0.0 && b[1] >= 0.0 && b[2] >= 0.0 && b[3] >= 0.0) {
      if (barycentric_out != nullptr) *barycentric_out = b;
      return true;
    }
    return false;
  }
};

}  // namespace pliant
