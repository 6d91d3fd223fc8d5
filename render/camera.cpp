#include "render/camera.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace pliant {
namespace {

glm::dvec3 to_glm(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

std::array<float, 16> to_array(const glm::dmat4& m) {
  std::array<float, 16> out{};
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) out[static_cast<size_t>(4 * c + r)] = static_cast<float>(m[c][r]);
  }
  return out;
}

// A safe up vector: the given one unless it is (nearly) parallel to the viewing direction.
glm::dvec3 safe_up(const glm::dvec3& forward, const glm::dvec3& up) {
  const double len = glm::length(up);
  if (len > 0.0 && std::abs(glm::dot(glm::normalize(forward), up / len)) < 0.999) return up;
  const glm::dvec3 alt = std::abs(forward.y) < 0.9 * glm::length(forward) ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
  return alt;
}

glm::dmat4 view_matrix(const Camera& camera) {
  const glm::dvec3 eye = to_glm(camera.position);
  const glm::dvec3 target = to_glm(camera.target);
  return glm::lookAt(eye, target, safe_up(target - eye, to_glm(camera.up)));
}

double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }

}  // namespace

std::array<float, 16> Camera::view() const { return to_array(view_matrix(*this)); }

std::array<float, 16> Camera::view_projection(double aspect, double near_distance, double far_distance) const {
  const glm::dmat4 projection = glm::perspective(radians(fov_y_deg), aspect, near_distance, far_distance);
  return to_array(projection * view_matrix(*this));
}

Vec2 Camera::project_to_pixel(const Vec3& world_point, int width, int height) const {
  const double aspect = static_cast<double>(width) / static_cast<double>(height);
  // Any clip distances give the same x, y; these just keep the matrix well defined.
  const glm::dmat4 m = glm::perspective(radians(fov_y_deg), aspect, 1e-3, 1e3) * view_matrix(*this);
  const glm::dvec4 clip = m * glm::dvec4(to_glm(world_point), 1.0);
  const double ndc_x = clip.x / clip.w;
  const double ndc_y = clip.y / clip.w;
  return {0.5 * (ndc_x + 1.0) * width, 0.5 * (1.0 - ndc_y) * height};
}

double Camera::depth_of(const Vec3& world_point) const {
  const Vec3 forward = (target - position).normalized();
  return (world_point - position).dot(forward);
}

Camera frame_bounds(const Aabb& bounds, double aspect, const Vec3& view_direction, const Vec3& up,
                    double fov_y_deg) {
  Aabb box = bounds;
  if (box.empty()) {
    box.min = Vec3::Constant(-0.5);
    box.max = Vec3::Constant(0.5);
  }
  const double radius = std::max(0.5 * box.extent().norm(), 1e-6);
  const double half_fov_y = 0.5 * radians(fov_y_deg);
  const double half_fov_x = std::atan(aspect * std::tan(half_fov_y));
  const double half_fov = std::min(half_fov_y, half_fov_x);
  const double distance = 1.05 * radius / std::sin(half_fov);
  const Vec3 direction = view_direction.norm() > 0.0 ? view_direction.normalized() : kDefaultViewDirection.normalized();

  Camera camera;
  camera.target = box.center();
  camera.position = camera.target + distance * direction;
  camera.up = up;
  camera.fov_y_deg = fov_y_deg;
  return camera;
}

}  // namespace pliant
