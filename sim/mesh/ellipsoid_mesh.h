// Procedural ellipsoid: the sphere mesh of sphere_mesh.h stretched along x, y and z. The affine map
// keeps every tet valid; quality falls with the ratio of the largest to the smallest semi-axis.
#pragma once

#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Semi-axes and resolution of a procedural ellipsoid centred at the origin.
struct EllipsoidMeshSpec {
  Vec3 semi_axes = Vec3::Ones();  ///< semi-axes along x, y, z (m)
  int surface_vertices = 73;      ///< vertices on the surface (>= 12)
  int shells = 1;                 ///< layers of surface vertices (>= 1), see SphereMeshSpec
};

/// Builds the ellipsoid mesh; throws InputError(bad_value) for bad parameters.
TetMeshPtr make_ellipsoid_mesh(const EllipsoidMeshSpec& spec);

}  // namespace pliant
