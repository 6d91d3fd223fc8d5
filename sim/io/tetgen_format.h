// TetGen .node/.ele files (https://wias-berlin.de/software/tetgen/fformats.html): points numbered
// from 0 or 1 (the first point's number decides), optional attributes and boundary markers, '#'
// comments. The first tet attribute (a region attribute) becomes the tet tag.
#pragma once

#include <string>

#include "sim/io/tet_mesh_file_data.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// The .node and .ele paths of a TetGen mesh given either file or the base name.
struct TetGenPaths {
  std::string node;  ///< "<base>.node"
  std::string ele;   ///< "<base>.ele"
};

/// Finds the partner file: "a.node" -> {a.node, a.ele}, "a.ele" or "a" likewise.
TetGenPaths tetgen_paths(const std::string& path);

/// Reads a TetGen mesh (either file or the base name); throws InputError naming file:line.
TetMeshPtr read_tetgen(const std::string& path, TetMeshReadReport* report = nullptr);

/// Writes "<base>.node" and "<base>.ele" (0-based, tags as one attribute); `path` is either file
/// or the base name.
void write_tetgen(const std::string& path, const TetMesh& mesh);

}  // namespace pliant
