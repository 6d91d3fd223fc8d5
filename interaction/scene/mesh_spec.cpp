#include "interaction/scene/mesh_spec.h"

#include <filesystem>

#include "sim/io/tet_mesh_reader.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

std::array<int, 3> read_cells(const JsonReader& j) {
  if (!j.is_array() || j.size() != 3) j.fail(InputErrorKind::wrong_type, "expected an array of 3 integers");
  std::array<int, 3> cells{};
  for (size_t i = 0; i < 3; ++i) {
    cells[i] = j.at(i).integer();
    if (cells[i] < 1 || cells[i] > 512) j.at(i).fail(InputErrorKind::bad_value, "expected an integer in [1, 512]");
  }
  return cells;
}

}  // namespace

TetMeshPtr load_mesh_spec(const JsonReader& j, const std::string& base_dir) {
  if (!j.is_object()) j.fail(InputErrorKind::wrong_type, "expected an object with \"file\" or \"shape\"");
  if (j.has("file")) {
    j.expect_keys({"file"});
    std::filesystem::path file = j.at("file").string();
    if (file.is_relative()) file = std::filesystem::path(base_dir) / file;
    return read_tet_mesh(file.string());
  }
  const std::string shape = j.at("shape").choice({"box", "membrane"});
  if (shape == "box") {
    j.expect_keys({"shape", "size", "cells"});
    const Vec3 size = j.at("size").vec3();
    if (!(size.array() > 0.0).all()) j.at("size").fail(InputErrorKind::bad_value, "sizes must be positive");
    const auto cells = read_cells(j.at("cells"));
    return make_box_mesh({size, cells[0], cells[1], cells[2]});
  }
  // membrane: a thin box, one cell through its thickness unless told otherwise.
  j.expect_keys({"shape", "size", "cells"});
  const Vec3 size = j.at("size").vec3();
  if (!(size.array() > 0.0).all()) j.at("size").fail(InputErrorKind::bad_value, "sizes must be positive");
  std::array<int, 3> cells{8, 8, 1};
  if (j.has("cells")) cells = read_cells(j.at("cells"));
  return make_box_mesh({size, cells[0], cells[1], cells[2]});
}

}  // namespace pliant
