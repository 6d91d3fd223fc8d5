// The "mesh" member of a scene body: a mesh file (relative to the scene file) or a procedural
// shape. Kept apart from the scene loader so new shapes are added in one place.
#pragma once

#include <string>

#include "interaction/json_reader.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Builds the mesh described by `j` (an object with "file" or "shape"). `base_dir` resolves
/// relative file paths. Errors name the JSON path (or the mesh file and line).
TetMeshPtr load_mesh_spec(const JsonReader& j, const std::string& base_dir);

}  // namespace pliant
