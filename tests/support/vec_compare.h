// Comparisons of per-vertex vector fields shared by the model tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <span>

#include "sim/math_types.h"

namespace pliant {

/// Largest |a_i - b_i| (same units as a and b).
inline double max_difference(std::span<const Vec3> a, std::span<const Vec3> b) {
  double d = 0.0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, (a[i] - b[i]).norm());
  return d;
}

/// Euclidean norm of the whole field, sqrt(sum |a_i|^2).
inline double field_norm(std::span<const Vec3> a) {
  double s = 0.0;
  for (const auto& v : a) s += v.squaredNorm();
  return std::sqrt(s);
}

/// Largest |a_i|.
inline double max_norm(std::span<const Vec3> a) {
  double d = 0.0;
  for (const auto& v : a) d = std::max(d, v.norm());
  return d;
}

}  // namespace pliant
