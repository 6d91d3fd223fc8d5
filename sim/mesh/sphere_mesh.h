// Procedural ball without slivers. The surface is a Fibonacci-point triangulation of the sphere
// (any vertex count, surface triangles = 2 * surface_vertices - 4). Below it sit `shells` - 1
// scaled copies of that triangulation, each thinner in proportion to its radius so that the prisms
// between shells are about as tall as they are wide; the prisms are split into three tets with
// consistent diagonals and the innermost shell is joined to the centre vertex. Every tet therefore
// has a well-shaped spherical-Delaunay triangle as its base, which keeps dihedral angles far from
// 0 and 180 degrees (see docs/mesh-formats.md for the measured bounds).
#pragma once

#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Size and resolution of a procedural sphere centred at the origin.
struct SphereMeshSpec {
  double radius = 1.0;        ///< sphere radius (m)
  int surface_vertices = 73;  ///< vertices on the sphere (>= 12); 73 gives 142 surface triangles
  int shells = 1;             ///< layers of surface_vertices vertices (>= 1); vertices = shells * surface_vertices + 1
};

/// Builds the sphere mesh; throws InputError(bad_value) for bad parameters.
TetMeshPtr make_sphere_mesh(const SphereMeshSpec& spec);

/// Radius of shell k (0 = the surface) as a fraction of the sphere radius.
double sphere_shell_radius_fraction(int surface_vertices, int k);

}  // namespace pliant
