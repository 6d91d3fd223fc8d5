// Gmsh .msh files, ASCII versions 2.2 and 4.1 (https://gmsh.info/doc/texinfo/gmsh.html#MSH-file-format).
// 4-node tetrahedra (element type 4) are kept, every other element type is skipped. A tet's tag is
// its first physical tag (2.2: the first element tag; 4.1: the first physical tag of its volume
// entity), 0 when it has none. Node tags may be sparse; they are mapped to 0-based indices. Unknown
// sections ($Comments, $PhysicalNames, $Periodic, ...) are skipped; binary files are unsupported.
#pragma once

#include <string>

#include "sim/io/tet_mesh_file_data.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Reads a .msh (2.2 or 4.1 ASCII) file; throws InputError naming file:line.
TetMeshPtr read_gmsh(const std::string& path, TetMeshReadReport* report = nullptr);

/// Parses .msh text held in memory; `name` is used in messages.
TetMeshPtr read_gmsh_text(const std::string& name, std::string text, TetMeshReadReport* report = nullptr);

/// Writes a .msh 2.2 ASCII file: nodes 1..n, tets as type 4 with tags (physical = elementary =
/// tet tag) when the mesh has tags, none otherwise.
void write_gmsh22(const std::string& path, const TetMesh& mesh);

}  // namespace pliant
