// What a mesh reader collects before a TetMesh is built: positions, tets with the file line each
// came from, tags. Building checks the tets again with their lines (so a zero-volume tet is
// reported as "file:line"), drops vertices no tet uses, and then calls TetMesh::build.
#pragma once

#include <string>
#include <vector>

#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Raw contents of a tetrahedral mesh file, vertex indices already 0-based.
struct TetMeshFileData {
  std::vector<Vec3> positions;    ///< vertex positions (file units, normally m)
  std::vector<TetIndices> tets;   ///< 0-based vertex indices, any orientation
  std::vector<long> tet_lines;    ///< line of each tet in `tet_file` (for messages)
  std::string tet_file;           ///< file the tets came from (the .ele for TetGen)
  std::vector<int> tet_tags;      ///< one tag per tet, or empty
};

/// What a reader found besides the mesh (shown by `pliant mesh info`).
struct TetMeshReadReport {
  std::string format;                ///< "tetgen", "gmsh 2.2", "gmsh 4.1", "vtk legacy"
  TetMeshBuildReport build;          ///< tets re-oriented by TetMesh::build
  int unused_vertices_removed = 0;   ///< vertices that no tetrahedron uses, dropped
  int skipped_elements = 0;          ///< non-tetrahedral elements skipped (faces, lines, points)
};

/// Checks tets (repeated vertices, indices, near-zero volume as TetMesh::build would) naming the
/// file line, removes unused vertices, and builds the mesh with `source` as its name.
TetMeshPtr build_tet_mesh_from_file(TetMeshFileData data, const std::string& source,
                                    TetMeshReadReport* report);

}  // namespace pliant
