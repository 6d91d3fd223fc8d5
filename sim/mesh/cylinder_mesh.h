// Procedural solid cylinder along z. The cross-section is a disc of concentric rings (ring k holds
// 6k vertices, so triangles stay close to equilateral from centre to rim), zipped ring to ring by
// angle; the disc is extruded in axial layers and each prism split into three tets with
// consistent diagonals (prism_split.h).
#pragma once

#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Size and resolution of a procedural cylinder centred at the origin, axis along z.
struct CylinderMeshSpec {
  double radius = 0.5;   ///< radius (m)
  double length = 1.0;   ///< length along z (m)
  int radial_cells = 2;  ///< rings from the axis to the rim (>= 1); disc vertices = 1 + 3 n (n + 1)
  int axial_cells = 4;   ///< layers along z (>= 1)
};

/// Builds the cylinder mesh; throws InputError(bad_value) for bad parameters.
TetMeshPtr make_cylinder_mesh(const CylinderMeshSpec& spec);

}  // namespace pliant
