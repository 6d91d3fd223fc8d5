// Small inline parts of SurfaceBvh (corner access and the self-collision exclusion test).
#pragma once

#include "sim/collision/surface_bvh.h"

namespace pliant {

inline const Vec3& SurfaceBvh::corner(int tri, int k) const {
  return x_[static_cast<size_t>(mesh_->surface_triangles()[static_cast<size_t>(tri)][static_cast<size_t>(k)])];
}

inline bool SurfaceBvh::excluded(int tri, int exclude_a, int exclude_b) const {
  if (exclude_a < 0 && exclude_b < 0) return false;
  for (int v : mesh_->surface_triangles()[static_cast<size_t>(tri)]) {
    if (v == exclude_a || v == exclude_b) return true;
  }
  return false;
}

}  // namespace pliant
