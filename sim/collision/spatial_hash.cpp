#include "sim/collision/spatial_hash.h"

namespace pliant {

// Placeholder until issue 4 lands.
void SpatialHash::detect(std::span<const CollisionBody>, const CollisionFilter&, std::vector<VertexInTet>& out) {
  out.clear();
}

}  // namespace pliant
