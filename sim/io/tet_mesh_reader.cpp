#include "sim/io/tet_mesh_reader.h"

#include <filesystem>

#include "sim/input_error.h"
#include "sim/io/gmsh_format.h"
#include "sim/io/tetgen_format.h"
#include "sim/io/vtk_legacy_format.h"
#include "sim/io/vtu_writer.h"

namespace pliant {

TetMeshPtr read_tet_mesh(const std::string& path, TetMeshReadReport* report) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".node" || ext == ".ele") return read_tetgen(path, report);
  if (ext == ".msh") return read_gmsh(path, report);
  if (ext == ".vtk") return read_vtk_legacy(path, report);
  if (!std::filesystem::exists(path) && std::filesystem::exists(path + ".node")) return read_tetgen(path, report);
  if (!std::filesystem::exists(path)) throw InputError(InputErrorKind::io, path, "no such file");
  throw InputError(InputErrorKind::unsupported, path,
                   "unknown mesh file extension '" + ext + "' (expected .node, .ele, .msh or .vtk)");
}

void write_tet_mesh(const std::string& path, const TetMesh& mesh) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".vtu") {
    write_tet_mesh_vtu(path, mesh, mesh.rest_positions());
  } else if (ext == ".vtk") {
    write_vtk_legacy(path, mesh);
  } else if (ext == ".node" || ext == ".ele") {
    write_tetgen(path, mesh);
  } else if (ext == ".msh") {
    write_gmsh22(path, mesh);
  } else {
    throw InputError(InputErrorKind::unsupported, path,
                     "unknown output extension '" + ext + "' (expected .vtu, .vtk, .node, .ele or .msh)");
  }
}

}  // namespace pliant
