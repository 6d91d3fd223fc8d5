// Camera: a pinhole looking from `position` at `target`, z up by default (gravity is -z in
// WorldSettings). Matrices are built with GLM inside camera.cpp; the header speaks Eigen like sim.
#pragma once

#include <array>

#include "sim/math_types.h"

namespace pliant {

/// A perspective camera in world coordinates (m).
struct Camera {
  Vec3 position = Vec3(1.0, -1.6, 1.0);  ///< eye (m)
  Vec3 target = Vec3::Zero();            ///< point looked at (m)
  Vec3 up = Vec3::UnitZ();               ///< approximate up direction (need not be unit)
  double fov_y_deg = 35.0;               ///< vertical field of view (degrees)

  /// Column-major OpenGL view-projection matrix for a viewport of this aspect (width / height)
  /// and the given clip distances (m).
  std::array<float, 16> view_projection(double aspect, double near_distance, double far_distance) const;
  /// Column-major view matrix (world to eye).
  std::array<float, 16> view() const;
  /// Pixel coordinates of a world point in a width x height image: x to the right, y down, pixel
  /// (i, j) covering [i, i+1) x [j, j+1). The point must be in front of the camera.
  Vec2 project_to_pixel(const Vec3& world_point, int width, int height) const;
  /// Distance along the viewing direction from the eye to a world point (m).
  double depth_of(const Vec3& world_point) const;
};

/// Default viewing direction for frame_bounds: from the front right, above (target to eye).
inline const Vec3 kDefaultViewDirection = Vec3(1.0, -1.6, 1.0);

/// A camera that frames the box: looks at its centre from `view_direction` (target to eye) at the
/// distance where the bounding sphere just fits the narrower field of view, plus a small margin.
/// An empty box frames the unit cube at the origin.
Camera frame_bounds(const Aabb& bounds, double aspect, const Vec3& view_direction = kDefaultViewDirection,
                    const Vec3& up = Vec3::UnitZ(), double fov_y_deg = 35.0);

}  // namespace pliant
