#include "sim/collision/penetration_depth.h"

namespace pliant {

// Placeholder until issue 4 lands.
void PenetrationDepthSolver::compute(std::span<const CollisionBody>, std::span<const VertexInTet>,
                                     std::vector<VertexContact>& out) {
  out.clear();
}

}  // namespace pliant
