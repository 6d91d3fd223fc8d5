#include "sim/contact/derived_held_fraction.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pliant {

double held_fraction_for_contact_mode(double omega_dt) {
  const double half = 0.5 * omega_dt;
  return 1.0 / (1.0 + half * half);
}

double bounce_stiffness_along(const Body& body, const Vec3& normal) {
  const double volume = body.mesh->total_rest_volume();
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (const Vec3& x : body.positions) {
    const double s = x.dot(normal);
    low = std::min(low, s);
    high = std::max(high, s);
  }
  const double extent = high - low;
  if (!(extent > 0.0) || !(volume > 0.0)) return 0.0;
  return body.material.young_modulus * volume / (extent * extent);
}

double contact_mode_omega(const Body& a, const Body& b, const Vec3& normal) {
  const double ka = bounce_stiffness_along(a, normal), kb = bounce_stiffness_along(b, normal);
  if (!(ka > 0.0) || !(kb > 0.0)) return 0.0;
  const double k = ka * kb / (ka + kb);
  auto anchored = [](const Body& body) { return std::any_of(body.fixed.begin(), body.fixed.end(), [](char f) { return f != 0; }); };
  const double ma = a.total_mass(), mb = b.total_mass();
  const bool fixed_a = anchored(a), fixed_b = anchored(b);
  // A body with fixed vertices has no translation: the free side moves against it alone.
  const double m = fixed_a == fixed_b ? ma * mb / (ma + mb) : (fixed_a ? mb : ma);
  if (!(m > 0.0)) return 0.0;
  return std::sqrt(k / m);
}

}  // namespace pliant
