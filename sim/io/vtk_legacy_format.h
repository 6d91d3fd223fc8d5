// Legacy VTK files (https://vtk.org/wp-content/uploads/2015/04/file-formats.pdf), ASCII
// UNSTRUCTURED_GRID: POINTS, CELLS (the classic "n size" layout and the 5.x OFFSETS/CONNECTIVITY
// layout) and CELL_TYPES. Cells of type 10 (VTK_TETRA) are kept, others skipped. An integer
// CELL_DATA scalar named "tag" (ours), "gmsh:physical" (meshio), "CellEntityIds" (gmsh) or
// "cell_scalars" (tetgen -k) becomes the tet tag.
#pragma once

#include <string>

#include "sim/io/tet_mesh_file_data.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Reads a legacy .vtk unstructured grid; throws InputError naming file:line.
TetMeshPtr read_vtk_legacy(const std::string& path, TetMeshReadReport* report = nullptr);

/// Parses legacy VTK text held in memory; `name` is used in messages.
TetMeshPtr read_vtk_legacy_text(const std::string& name, std::string text, TetMeshReadReport* report = nullptr);

/// Writes a legacy VTK 3.0 ASCII unstructured grid of tets (with a "tag" cell scalar if tagged).
void write_vtk_legacy(const std::string& path, const TetMesh& mesh);

}  // namespace pliant
