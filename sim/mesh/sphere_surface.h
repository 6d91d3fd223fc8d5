// A near-uniform triangulation of the unit sphere with any number of vertices: points on a
// Fibonacci (golden-angle) spiral, triangulated by their convex hull, which for points on a sphere
// is the spherical Delaunay triangulation (so triangles are as round as the points allow).
#pragma once

#include <vector>

#include "sim/math_types.h"

namespace pliant {

/// Unit-sphere points and outward (counter-clockwise from outside) triangles.
struct SphereTriangulation {
  std::vector<Vec3> points;          ///< on the unit sphere
  std::vector<TriIndices> triangles; ///< 2 * points - 4 of them
};

/// Triangulates `n` (>= 4) Fibonacci points on the unit sphere.
SphereTriangulation fibonacci_sphere_triangulation(int n);

}  // namespace pliant
