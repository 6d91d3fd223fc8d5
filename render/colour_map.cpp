#include "render/colour_map.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace pliant {

Rgba8 colour_map(double t) {
  // viridis at t = 0, 0.25, 0.5, 0.75, 1 (matplotlib's _viridis_data).
  static constexpr std::array<std::array<double, 3>, 5> kStops = {{
      {68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}}};
  // NaN first: an ordered comparison with NaN raises FE_INVALID (trapped in tests).
  t = std::isnan(t) ? 0.0 : std::clamp(t, 0.0, 1.0);
  const double s = t * static_cast<double>(kStops.size() - 1);
  const auto i = std::min(static_cast<size_t>(s), kStops.size() - 2);
  const double f = s - static_cast<double>(i);
  std::array<std::uint8_t, 3> c{};
  for (size_t k = 0; k < 3; ++k) {
    c[k] = static_cast<std::uint8_t>(std::lround((1.0 - f) * kStops[i][k] + f * kStops[i + 1][k]));
  }
  return {c[0], c[1], c[2], 255};
}

double normalised(double value, double lo, double hi) {
  if (!(hi > lo)) return 0.0;
  return std::clamp((value - lo) / (hi - lo), 0.0, 1.0);
}

}  // namespace pliant
