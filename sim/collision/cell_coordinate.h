// The integer cell of a coordinate on a uniform grid, shared by the spatial hash and the body-level
// broad phase (BoundsOverlap).
#pragma once

#include <algorithm>

namespace pliant {

/// floor(x * inv_cell), clamped to [-1e9, 1e9] so that absurd positions cannot overflow an int (they
/// land in an outermost cell), and NaN mapped to -1e9 (casting NaN to int is undefined). Always
/// inlined: GCC otherwise calls it from the spatial hash's pass 2 (six calls per tet, session 15).
[[gnu::always_inline]] inline int cell_coordinate(double x, double inv_cell) {
  // max(lo, min(v, hi)) is std::clamp for every number and maps NaN to lo (std::clamp returns NaN).
  // The bounds are integers, so clamping before the floor gives floor's clamped result.
  const double v = std::max(-1.0e9, std::min(x * inv_cell, 1.0e9));
  // floor as truncation, one down for a negative non-integer (exact for |v| <= 1e9): the portable
  // build has no SSE4.1 round, and std::floor's SSE2 sequence was 9% of detection (session 17).
  const int t = static_cast<int>(v);
  return t - (v < static_cast<double>(t) ? 1 : 0);
}

}  // namespace pliant
