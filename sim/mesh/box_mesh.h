// Procedural box: nx * ny * nz cells, each cut into six tetrahedra around its main diagonal
// (Kuhn/Freudenthal subdivision), so neighbouring cells share their face diagonals consistently.
#pragma once

#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Size and resolution of a procedural box, centred at the origin.
struct BoxMeshSpec {
  Vec3 size = Vec3::Ones();  ///< edge lengths (m)
  int nx = 1;                ///< cells along x
  int ny = 1;                ///< cells along y
  int nz = 1;                ///< cells along z
};

/// Builds the box mesh; throws InputError for non-positive sizes or cell counts.
TetMeshPtr make_box_mesh(const BoxMeshSpec& spec);

}  // namespace pliant
