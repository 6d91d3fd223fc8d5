// Mesh quality against closed forms: the regular tetrahedron (all dihedral angles acos(1/3), radius
// ratio 1), the Kuhn tetrahedron of a cube cell (angles 45, 45, 60, 90, 90, 90 degrees, radius ratio
// sqrt(3) / (1 + sqrt(2))), a sliver; and the normal-vector dihedral formula against a second method
// (angle between the two other vertices projected onto the plane normal to the edge).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/mesh/box_mesh.h"
#include "sim/mesh/mesh_quality.h"

namespace pliant {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

// All six dihedral angles (degrees) by projection onto the plane normal to each edge.
std::vector<double> dihedral_angles_by_projection(const std::array<Vec3, 4>& p) {
  std::vector<double> angles;
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) {
      int others[2], n = 0;
      for (int k = 0; k < 4; ++k) if (k != i && k != j) others[n++] = k;
      const Vec3 e = (p[static_cast<size_t>(j)] - p[static_cast<size_t>(i)]).normalized();
      Vec3 u = p[static_cast<size_t>(others[0])] - p[static_cast<size_t>(i)];
      Vec3 w = p[static_cast<size_t>(others[1])] - p[static_cast<size_t>(i)];
      u -= u.dot(e) * e;
      w -= w.dot(e) * e;
      angles.push_back(std::acos(std::clamp(u.dot(w) / (u.norm() * w.norm()), -1.0, 1.0)) * kDeg);
    }
  }
  std::sort(angles.begin(), angles.end());
  return angles;
}

TetQuality quality(const std::array<Vec3, 4>& p) { return compute_tet_quality(p[0], p[1], p[2], p[3]); }

TEST(MeshQuality, RegularTetrahedron) {
  const std::array<Vec3, 4> p = {Vec3(1, 1, 1), Vec3(1, -1, -1), Vec3(-1, 1, -1), Vec3(-1, -1, 1)};
  const double expected = std::acos(1.0 / 3.0) * kDeg;  // 70.5288 degrees
  const TetQuality q = quality(p);
  EXPECT_NEAR(q.min_dihedral_deg, expected, 1e-12);
  EXPECT_NEAR(q.max_dihedral_deg, expected, 1e-12);
  EXPECT_NEAR(q.radius_ratio, 1.0, 1e-14);
  for (double a : dihedral_angles_by_projection(p)) EXPECT_NEAR(a, expected, 1e-12);
  // Either orientation, any similarity transform: same figures.
  const Quat r(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  std::array<Vec3, 4> moved;
  for (size_t k = 0; k < 4; ++k) moved[k] = 0.01 * (r * p[k]) + Vec3(5, -2, 1);
  std::swap(moved[0], moved[1]);
  const TetQuality qm = quality(moved);
  EXPECT_NEAR(qm.min_dihedral_deg, expected, 1e-10);
  EXPECT_NEAR(qm.radius_ratio, 1.0, 1e-12);
}

TEST(MeshQuality, KuhnTetrahedronOfACubeCell) {
  const std::array<Vec3, 4> p = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(1, 1, 1)};
  const std::vector<double> expected = {45, 45, 60, 90, 90, 90};
  const auto by_projection = dihedral_angles_by_projection(p);
  for (size_t k = 0; k < 6; ++k) EXPECT_NEAR(by_projection[k], expected[k], 1e-12);
  const TetQuality q = quality(p);
  EXPECT_NEAR(q.min_dihedral_deg, 45.0, 1e-12);
  EXPECT_NEAR(q.max_dihedral_deg, 90.0, 1e-12);
  EXPECT_NEAR(q.radius_ratio, std::sqrt(3.0) / (1.0 + std::sqrt(2.0)), 1e-14);

  // The whole box mesh is made of such tets (stretched cells would differ; these are cubes).
  const auto box = make_box_mesh({Vec3(0.3, 0.2, 0.1), 3, 2, 1});
  const MeshQuality mq = compute_mesh_quality(*box);
  EXPECT_NEAR(mq.min_dihedral_deg, 45.0, 1e-10);
  EXPECT_NEAR(mq.max_dihedral_deg, 90.0, 1e-10);
  EXPECT_NEAR(mq.volume_ratio, 1.0, 1e-12);
  EXPECT_NEAR(mq.min_volume, 0.1 * 0.1 * 0.1 / 6.0, 1e-15);
  EXPECT_NEAR(mq.min_radius_ratio, std::sqrt(3.0) / (1.0 + std::sqrt(2.0)), 1e-12);
  EXPECT_NEAR(mq.mean_radius_ratio, mq.min_radius_ratio, 1e-12);
}

TEST(MeshQuality, NormalFormulaMatchesProjectionOnRandomTets) {
  std::srand(7);
  auto rnd = [] { return 2.0 * std::rand() / RAND_MAX - 1.0; };
  for (int trial = 0; trial < 200; ++trial) {
    const std::array<Vec3, 4> p = {Vec3(rnd(), rnd(), rnd()), Vec3(rnd(), rnd(), rnd()), Vec3(rnd(), rnd(), rnd()),
                                   Vec3(rnd(), rnd(), rnd())};
    if (std::abs(signed_tet_volume(p[0], p[1], p[2], p[3])) < 1e-3) continue;
    const auto angles = dihedral_angles_by_projection(p);
    const TetQuality q = quality(p);
    EXPECT_NEAR(q.min_dihedral_deg, angles.front(), 1e-8);
    EXPECT_NEAR(q.max_dihedral_deg, angles.back(), 1e-8);
    EXPECT_GT(q.radius_ratio, 0.0);
    EXPECT_LE(q.radius_ratio, 1.0);
  }
}

TEST(MeshQuality, SliverIsFlaggedByAllMeasures) {
  // Four points near a square, alternately lifted by +-eps: a sliver as eps -> 0.
  for (double eps : {0.1, 0.01, 0.001}) {
    const std::array<Vec3, 4> p = {Vec3(1, 0, eps), Vec3(-1, 0, eps), Vec3(0, 1, -eps), Vec3(0, -1, -eps)};
    const TetQuality q = quality(p);
    const auto angles = dihedral_angles_by_projection(p);
    EXPECT_NEAR(q.min_dihedral_deg, angles.front(), 1e-8);
    EXPECT_NEAR(q.max_dihedral_deg, angles.back(), 1e-8);
    EXPECT_LT(q.min_dihedral_deg, 400.0 * eps);  // angles O(eps) from 0 and 180 degrees
    EXPECT_GT(q.max_dihedral_deg, 180.0 - 400.0 * eps);
    EXPECT_LT(q.radius_ratio, 10.0 * eps);
  }
}

}  // namespace
}  // namespace pliant
