// Stage 2: consistent penetration depth (Heidelberger et al. 2004) and the contact triangle of
// every colliding vertex (algorithms.md section 2).
#pragma once

#include <span>
#include <vector>

#include "sim/collision/contact_types.h"

namespace pliant {

class PenetrationDepthSolver {
 public:
  /// Depth, direction and contact triangle for every colliding vertex in `colliding`.
  /// `out` is cleared first and gets one entry per colliding vertex (same order), except vertices
  /// for which no contact triangle exists at all (documented in docs/penetration-depth.md).
  void compute(std::span<const CollisionBody> bodies, std::span<const VertexInTet> colliding,
               std::vector<VertexContact>& out);
};

}  // namespace pliant
