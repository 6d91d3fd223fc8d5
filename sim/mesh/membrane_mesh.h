// Procedural thin membrane: a box mesh (Kuhn cells) that is wide in x and y and only a few cells
// thick in z, centred at the origin.
#pragma once

#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Size and resolution of a procedural membrane (normal along z).
struct MembraneMeshSpec {
  double width = 1.0;      ///< extent along x (m)
  double depth = 1.0;      ///< extent along y (m)
  double thickness = 0.02; ///< extent along z (m)
  int nx = 10;             ///< cells along x (>= 1)
  int ny = 10;             ///< cells along y (>= 1)
  int layers = 1;          ///< cells through the thickness (>= 1)
};

/// Builds the membrane mesh; throws InputError(bad_value) for bad parameters.
TetMeshPtr make_membrane_mesh(const MembraneMeshSpec& spec);

}  // namespace pliant
