// Camera against pinhole geometry: the target projects to the image centre, a point at half the
// vertical field of view above the axis to the top edge, world right to image right; frame_bounds
// puts the bounding sphere just inside the narrower field of view.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "render/camera.h"

namespace pliant {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

TEST(Camera, PinholeProjection) {
  Camera c;
  c.position = Vec3(0.0, -3.0, 0.0);
  c.target = Vec3::Zero();
  c.up = Vec3::UnitZ();
  c.fov_y_deg = 40.0;
  const int w = 200, h = 100;
  const Vec2 centre = c.project_to_pixel(c.target, w, h);
  EXPECT_NEAR(centre.x(), 100.0, 1e-9);
  EXPECT_NEAR(centre.y(), 50.0, 1e-9);
  const Vec2 top = c.project_to_pixel(Vec3(0.0, 0.0, 3.0 * std::tan(20.0 * kDeg)), w, h);
  EXPECT_NEAR(top.y(), 0.0, 1e-9);
  // Horizontal half-width at distance 3 is aspect * the vertical one.
  const Vec2 right = c.project_to_pixel(Vec3(2.0 * 3.0 * std::tan(20.0 * kDeg), 0.0, 0.0), w, h);
  EXPECT_NEAR(right.x(), 200.0, 1e-9);
  EXPECT_NEAR(c.depth_of(Vec3(5.0, 1.0, -2.0)), 4.0, 1e-12);
}

TEST(Camera, FrameBoundsFitsTheBoundingSphere) {
  Aabb box;
  box.extend(Vec3(1.0, 2.0, 3.0));
  box.extend(Vec3(1.4, 2.6, 3.2));
  for (const double aspect : {0.5, 1.0, 4.0 / 3.0, 2.5}) {
    const Camera c = frame_bounds(box, aspect);
    EXPECT_TRUE(c.target.isApprox(box.center()));
    const double radius = 0.5 * box.extent().norm();
    const double distance = (c.position - c.target).norm();
    const double half_y = 0.5 * c.fov_y_deg * kDeg;
    const double half_x = std::atan(aspect * std::tan(half_y));
    // The sphere's tangent cone from the eye has half-angle asin(r / d): inside the view, barely.
    const double cone = std::asin(radius / distance);
    EXPECT_LE(cone, std::min(half_x, half_y) + 1e-12) << "aspect " << aspect;
    EXPECT_GT(cone, 0.9 * std::min(half_x, half_y)) << "aspect " << aspect;
    EXPECT_NEAR((c.position - c.target).normalized().dot(kDefaultViewDirection.normalized()), 1.0, 1e-12);
  }
  // An empty box frames the unit cube at the origin.
  EXPECT_TRUE(frame_bounds(Aabb{}, 1.0).target.isApprox(Vec3::Zero()));
}

}  // namespace
}  // namespace pliant
