// Barycentric coordinates of a point in a tetrahedron: the narrow-phase test of the spatial hash
// (Teschner et al. 2003; algorithms.md section 1), shared with the brute-force oracle in the tests.
//
// Design note (issue #4). A point exactly on an internal face, edge or vertex of a body lies in the
// closed tets on both sides, but rounding in the coordinates can put it "just outside" every one of
// them (b_k ~ -1e-17 on the shared face), so a vertex deep inside an aligned body went undetected.
// `contains_in_body` therefore accepts b_k down to a rounding tolerance across faces shared with
// another tet (inside the body on either side); across a face on the body's surface the test stays
// strict (b_k >= 0), so a point outside the body is still rejected by the surface face it lies
// beyond. The tolerance is a distance beyond the face: 1e-12 x max(largest |coordinate| of the
// tet, its longest edge), about 1e4 times the rounding of positions and of the coordinates (whose
// error grows with the coordinates' magnitude, not only with the tet's size); b_k is converted to
// that distance with the face's height |det| / |row_k|.
#pragma once

#include <algorithm>
#include <cmath>

#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// A tetrahedron prepared for many point tests: x0 and the rows of A^-1 scaled by det(A), where
/// A = [x1-x0, x2-x0, x3-x0] (algorithms.md section 1).
struct TetBarycentricFrame {
  Vec3 x0 = Vec3::Zero();
  Vec3 row1 = Vec3::Zero();  ///< (x2-x0) x (x3-x0): b1 = row1.(p-x0) / det
  Vec3 row2 = Vec3::Zero();  ///< (x3-x0) x (x1-x0)
  Vec3 row3 = Vec3::Zero();  ///< (x1-x0) x (x2-x0)
  double det = 0.0;          ///< det(A) = 6 * signed volume (m^3); may be negative (inverted tet)
  /// (1e-12 x max(largest |coordinate|, longest edge from x0))^2 (m^2): the squared distance a point
  /// may lie beyond an internal face and still count as on it (see the note).
  double rounding_squared = 0.0;
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
    const double coordinates = std::max(f.box.min.cwiseAbs().maxCoeff(), f.box.max.cwiseAbs().maxCoeff());
    f.rounding_squared = 1e-24 * std::max(coordinates * coordinates, scale);
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

  /// Whether a negative coordinate b_k of a point (k = 0..3: the face opposite corner k) is within
  /// rounding of that face: its distance beyond the face, -b_k |det| / |row_k|, is at most
  /// 1e-12 x max(largest |coordinate| of the tet, longest edge from x0) (see the note). Compared
  /// squared, so rejecting a point costs no square root.
  bool within_rounding_of_face(int k, double b_k) const {
    const double beyond = b_k * det;  // -(distance beyond the face) x |row_k| (m^3)
    const double normal_squared = k == 0   ? (row1 + row2 + row3).squaredNorm()
                                  : k == 1 ? row1.squaredNorm()
                                  : k == 2 ? row2.squaredNorm()
                                           : row3.squaredNorm();
    return beyond * beyond <= rounding_squared * normal_squared;
  }

  /// Inside test for a tet of a body: `contains`, except that across a face shared with another tet
  /// (`internal_face(k)` true for the face opposite corner k) a coordinate may be negative within
  /// rounding (within_rounding_of_face). The coordinates are reported as computed (possibly that
  /// negative).
  template <class InternalFace>
  bool contains_in_body(const Vec3& p, InternalFace&& internal_face, Vec4* barycentric_out = nullptr) const {
    if (degenerate) return false;
    if ((p.array() < box.min.array()).any() || (p.array() > box.max.array()).any()) return false;
    const Vec4 b = barycentric(p);
    for (int k = 0; k < 4; ++k) {
      if (b[k] >= 0.0) continue;
      if (!within_rounding_of_face(k, b[k]) || !internal_face(k)) return false;
    }
    if (barycentric_out != nullptr) *barycentric_out = b;
    return true;
  }
};

/// Whether the face of `tet` opposite its corner k is shared with another tet (not a surface
/// triangle). Cheap for faces with an interior corner; else a look-up among a corner's surface
/// triangles.
inline bool is_internal_tet_face(const TetMesh& mesh, int tet, int k) {
  const TetIndices& t = mesh.tets()[static_cast<size_t>(tet)];
  int face[3];
  int n = 0;
  for (int i = 0; i < 4; ++i) {
    if (i != k) face[n++] = t[static_cast<size_t>(i)];
  }
  for (int v : face) {
    if (!mesh.is_surface_vertex(v)) return true;
  }
  for (int s : mesh.vertex_surface_triangles(face[0])) {
    const TriIndices& tri = mesh.surface_triangles()[static_cast<size_t>(s)];
    int shared = 0;
    for (int v : tri) shared += (v == face[0] || v == face[1] || v == face[2]) ? 1 : 0;
    if (shared == 3) return false;
  }
  return true;
}

}  // namespace pliant
