// Splitting triangular prisms into three tetrahedra so that neighbouring prisms agree on the
// diagonals of their shared quadrilateral faces: every quad diagonal starts at the quad's vertex
// with the smallest global index (Dompierre, Labbe, Vallet, Camarero, "How to subdivide pyramids,
// prisms and hexahedra into tetrahedra", 1999). Used by the extruded and layered shapes.
#pragma once

#include <array>
#include <vector>

#include "sim/math_types.h"

namespace pliant {

/// Appends the three tets of the prism with bottom (v[0], v[1], v[2]) and top (v[3], v[4], v[5]),
/// v[i + 3] above v[i], each positively oriented for positions x.
void split_prism(const std::array<int, 6>& v, const std::vector<Vec3>& x, std::vector<TetIndices>& tets);

/// Swaps two vertices of `tet` if needed so that its signed volume at x is positive.
void orient_tet_positively(TetIndices& tet, const std::vector<Vec3>& x);

}  // namespace pliant
