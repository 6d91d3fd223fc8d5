// Stage 1: optimized spatial hashing (Teschner et al. 2003; algorithms.md section 1).
#pragma once

#include <span>
#include <vector>

#include "sim/collision/contact_types.h"

namespace pliant {

class SpatialHash {
 public:
  /// Finds every vertex lying inside a tetrahedron of a body it may collide with (per `filter`),
  /// including the same body when self-collision is allowed (a tet's own vertices excluded).
  /// `out` is cleared first; results are ordered by (body, vertex) so the step is deterministic.
  void detect(std::span<const CollisionBody> bodies, const CollisionFilter& filter,
              std::vector<VertexInTet>& out);
};

}  // namespace pliant
