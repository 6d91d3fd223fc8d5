// Colour map for per-vertex scalar fields: piecewise-linear viridis (perceptually uniform, readable
// in grey scale and by most colour-blind viewers), sampled from matplotlib's table at 0, 1/4, ...
#pragma once

#include "render/image.h"

namespace pliant {

/// Colour of a value t in [0, 1] (clamped; NaN maps to 0).
Rgba8 colour_map(double t);

/// Position of `value` in [lo, hi] as a fraction in [0, 1]; 0 when the range is empty.
double normalised(double value, double lo, double hi);

}  // namespace pliant
