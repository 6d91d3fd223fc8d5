// One entry point for reading a tetrahedral mesh from any supported file, chosen by extension:
// .node/.ele (or a base name with a .node partner) -> TetGen, .msh -> Gmsh 2.2/4.1, .vtk -> legacy
// VTK. And the matching writer for `pliant mesh convert`.
#pragma once

#include <string>

#include "sim/io/tet_mesh_file_data.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Reads a mesh file, dispatching on its extension; throws InputError (unsupported for an unknown
/// extension, io for a missing file, and the parser's kinds naming file:line).
TetMeshPtr read_tet_mesh(const std::string& path, TetMeshReadReport* report = nullptr);

/// Writes a mesh by extension: .vtu (VTK XML), .vtk (legacy), .node/.ele (TetGen), .msh (Gmsh 2.2).
void write_tet_mesh(const std::string& path, const TetMesh& mesh);

}  // namespace pliant
