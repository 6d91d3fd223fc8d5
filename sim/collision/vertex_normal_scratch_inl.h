// The hot lookup of VertexNormalScratch, inline for its users' translation units only (stage 2's
// solver and the scratch itself), so the widely included header stays free of it.
#pragma once

#include "sim/collision/vertex_normal_scratch.h"

namespace pliant {

inline const Vec3& VertexNormalScratch::normal(int v) {
  Entry& e = normals_[static_cast<std::uint32_t>(v) & (kNormalSlots - 1)];
  return e.tag == tag(v) ? e.value : compute_normal(v, e);
}

}  // namespace pliant
