// The contact triangle of a colliding vertex (needed by the contact-surface method, not defined by
// Heidelberger 2004; algorithms.md section 2 [open]): the first surface triangle of the penetrated
// body hit by the ray x + t r, t >= 0; if r vanished or the ray misses, the nearest surface triangle.
#pragma once

#include <limits>
#include <optional>

#include "sim/collision/contact_types.h"
#include "sim/collision/surface_bvh.h"

namespace pliant {

/// A contact triangle and how it was found.
struct ContactTriangleHit {
  SurfacePoint point;                                      ///< triangle, barycentric weights, point
  ContactTriangleSource source = ContactTriangleSource::ray;
};

/// Contact triangle of the point x (m) moving along unit direction r on `surface` (triangles holding
/// vertex `exclude`, -1 for none, are skipped: self-collision). Empty only if no triangle is eligible.
/// `t_bound`: a ray parameter known to reach some eligible triangle (it only prunes the search; the
/// search is repeated unbounded if nothing is found below it, so the answer never depends on it).
inline std::optional<ContactTriangleHit> find_contact_triangle(
    const SurfaceBvh& surface, const Vec3& x, const Vec3& r, int exclude,
    double t_bound = std::numeric_limits<double>::max()) {
  ContactTriangleHit hit;
  if (r.squaredNorm() > 0.5 &&
      (surface.first_ray_hit(x, r, exclude, hit.point, t_bound) ||
       (t_bound < std::numeric_limits<double>::max() && surface.first_ray_hit(x, r, exclude, hit.point)))) {
    return hit;
  }
  if (!surface.nearest_point(x, exclude, hit.point)) return std::nullopt;
  hit.source = ContactTriangleSource::nearest_point_fallback;
  return hit;
}

}  // namespace pliant
