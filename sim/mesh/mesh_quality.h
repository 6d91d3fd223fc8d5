// Element quality of a tet mesh: dihedral angles (slivers have angles near 0 or 180 degrees),
// the spread of volumes, and the radius ratio 3 r_in / R_circ (1 for the regular tetrahedron, 0 for
// a degenerate one; Shewchuk, "What is a good linear finite element?", 2002, section 6).
#pragma once

#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Quality figures of one tetrahedron.
struct TetQuality {
  double min_dihedral_deg = 0.0;  ///< smallest of the six dihedral angles (degrees)
  double max_dihedral_deg = 0.0;  ///< largest of the six dihedral angles (degrees)
  double radius_ratio = 0.0;      ///< 3 * inradius / circumradius, in [0, 1]
};

/// Quality figures of a whole mesh.
struct MeshQuality {
  double min_dihedral_deg = 0.0;   ///< smallest dihedral angle over all tets (degrees)
  double max_dihedral_deg = 0.0;   ///< largest dihedral angle over all tets (degrees)
  double min_volume = 0.0;         ///< smallest rest tet volume (m^3)
  double max_volume = 0.0;         ///< largest rest tet volume (m^3)
  double volume_ratio = 0.0;       ///< min_volume / max_volume, in (0, 1]
  double min_radius_ratio = 0.0;   ///< worst radius ratio
  double mean_radius_ratio = 0.0;  ///< mean radius ratio
  int worst_tet = -1;              ///< tet with the smallest radius ratio
};

/// Quality of the tetrahedron (a, b, c, d) of either orientation.
TetQuality compute_tet_quality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Quality of every tet of `mesh` at its rest positions, summarized.
MeshQuality compute_mesh_quality(const TetMesh& mesh);

}  // namespace pliant
