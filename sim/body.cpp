#include "sim/body.h"

#include <numeric>

namespace pliant {

double Body::total_mass() const { return std::accumulate(masses.begin(), masses.end(), 0.0); }

}  // namespace pliant
