// Basic math types shared across sim: Eigen fixed-size vectors, double precision throughout.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

namespace pliant {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;

/// Vertex indices of one tetrahedron, positively oriented: det(x1-x0, x2-x0, x3-x0) > 0.
using TetIndices = std::array<int, 4>;
/// Vertex indices of one surface triangle, counter-clockwise seen from outside.
using TriIndices = std::array<int, 3>;

/// Axis-aligned bounding box. Empty when min > max.
struct Aabb {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());

  void extend(const Vec3& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  bool empty() const { return (min.array() > max.array()).any(); }
  Vec3 center() const { return 0.5 * (min + max); }
  Vec3 extent() const { return max - min; }
  bool overlaps(const Aabb& o) const {
    return (min.array() <= o.max.array()).all() && (o.min.array() <= max.array()).all();
  }
};

/// A rigid transform: x' = rotation * x + translation.
struct Pose {
  Vec3 translation = Vec3::Zero();
  Quat rotation = Quat::Identity();

  Vec3 apply(const Vec3& x) const { return rotation * x + translation; }
  static Pose identity() { return {}; }
};

/// Signed volume of a tetrahedron: det(b-a, c-a, d-a) / 6.
inline double signed_tet_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

}  // namespace pliant
