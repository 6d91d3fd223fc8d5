// Tet meshes for instruments (issue 6, item 2), built here from the Kuhn box of sim/mesh/box_mesh.h
// by smooth maps, so no generator of slivers is needed:
//  - ball: an inner Kuhn cube (half-size 0.35 r) inside a shell of six blocks of hexahedra
//    between the cube's faces and the sphere, the outer layer placed by the cube-sphere map
//    x' = x sqrt(1 - y^2/2 - z^2/2 + y^2 z^2/3) (and cyclic). Each shell tet spans two radial
//    layers, so none has four vertices on the sphere (projecting a whole Kuhn cube does, and its
//    corner tets become slivers: radius ratio 0.07 at 4 cells, 0.013 at 8). Here the worst radius
//    ratio stays >= 0.18 at every resolution (tested).
//  - cylinder: the square cross-section is mapped onto the disk by the elliptical grid map
//    (x sqrt(1 - y^2/2), y sqrt(1 - x^2/2)).
//  - plate: a box placed by its min corner.
// Instruments are infinitely stiff, so their meshes only give contact geometry (surface and
// inside); they can be coarse. Meshes are in the instrument's local frame (metres).
#pragma once

#include <vector>

#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Vertices and tets not yet validated (to be merged before TetMesh::build).
struct RawTetMesh {
  std::vector<Vec3> positions;  ///< m
  std::vector<TetIndices> tets;
};

/// Ball of `radius` (m) centred at `center`, from a cube of `cells` cells per axis (>= 2).
RawTetMesh ball_tets(double radius, int cells, const Vec3& center = Vec3::Zero());
/// Solid cylinder along +z from z = z0 to z0 + length (m), `cells` cells across the diameter,
/// `length_cells` along the axis.
RawTetMesh cylinder_tets(double radius, double length, int cells, int length_cells, double z0 = 0.0);
/// Axis-aligned box [min, max] (m) with the given cell counts.
RawTetMesh box_tets(const Vec3& min, const Vec3& max, int nx, int ny, int nz);
/// Concatenates meshes (disjoint components; they may overlap in space).
RawTetMesh merge(const std::vector<RawTetMesh>& parts);
/// Validates and builds (TetMesh::build); `source` names it in errors.
TetMeshPtr build_instrument_mesh(RawTetMesh raw, const std::string& source);

/// Cells to use along a length so cells are about `cell_size` long: clamp(round(length/cell), 1, 64).
int cells_along(double length, double cell_size);

/// Radius ratio 3 r_in / r_out of a tet: 1 for the regular tet, -> 0 for slivers.
double tet_radius_ratio(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

}  // namespace pliant
