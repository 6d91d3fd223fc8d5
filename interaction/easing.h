// Easing curves for tool motion (issue 6, item 3): every scripted segment starts and ends at rest,
// so the velocity is continuous (C1) across keyframes and no velocity jump excites the tissue.
#pragma once

#include <algorithm>

namespace pliant {

/// Quintic "smootherstep" s(u) = 6u^5 - 15u^4 + 10u^3 on [0, 1] (clamped outside): s' = s'' = 0 at
/// both ends, so position, velocity and acceleration are continuous at keyframes.
inline double quintic_ease(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * u * (u * (6.0 * u - 15.0) + 10.0);
}

/// ds/du of quintic_ease: 30u^2 (u - 1)^2.
inline double quintic_ease_derivative(double u) {
  if (u <= 0.0 || u >= 1.0) return 0.0;
  return 30.0 * u * u * (u - 1.0) * (u - 1.0);
}

/// Cubic smoothstep 3u^2 - 2u^3 (clamped): used as a velocity ramp (C1 position, C1 velocity).
inline double smoothstep(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * (3.0 - 2.0 * u);
}

/// Integral of smoothstep from 0 to u (clamped to [0, 1]): u^3 - u^4/2.
inline double smoothstep_integral(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * u * (1.0 - 0.5 * u);
}

}  // namespace pliant
