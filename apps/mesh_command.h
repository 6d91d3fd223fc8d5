// `pliant mesh info FILE` and `pliant mesh convert IN OUT`: inspect and convert tetrahedral mesh
// files. Bad input throws InputError (main.cpp maps it to exit code 2).
#pragma once

#include <ostream>
#include <string>

namespace pliant {

/// Prints counts, volume, bounding box, tags, element quality and what validation changed
/// (re-oriented tets, dropped vertices, skipped elements). Returns 0.
int run_mesh_info(const std::string& file, std::ostream& out);

/// Reads `in` (any supported format) and writes `out_path` in the format of its extension
/// (.vtu, .vtk, .node/.ele, .msh 2.2). Returns 0.
int run_mesh_convert(const std::string& in, const std::string& out_path, std::ostream& out);

}  // namespace pliant
