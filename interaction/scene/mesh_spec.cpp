#include "interaction/scene/mesh_spec.h"

#include <filesystem>
#include <string>

#include "sim/io/tet_mesh_reader.h"
#include "sim/mesh/box_mesh.h"
#include "sim/mesh/cylinder_mesh.h"
#include "sim/mesh/ellipsoid_mesh.h"
#include "sim/mesh/sphere_mesh.h"

namespace pliant {
namespace {

std::array<int, 3> read_cells(const JsonReader& j) {
  if (!j.is_array() || j.size() != 3) j.fail(InputErrorKind::wrong_type, "expected an array of 3 integers");
  std::array<int, 3> cells{};
  for (size_t i = 0; i < 3; ++i) {
    cells[i] = j.at(i).integer();
    if (cells[i] < 1 || cells[i] > 512) j.at(i).fail(InputErrorKind::bad_value, "expected an integer in [1, 512]");
  }
  // Each axis may be fine and the product not: 512^3 cells would be 805 million tets.
  constexpr long kMaxCells = 2'000'000;  // 12 million tets, about 3 GB with the model
  if (static_cast<long>(cells[0]) * cells[1] * cells[2] > kMaxCells) {
    j.fail(InputErrorKind::bad_value, "nx * ny * nz must not exceed " + std::to_string(kMaxCells) + " cells");
  }
  return cells;
}

// An integer member in [lo, hi], or `fallback` when absent.
int read_count(const JsonReader& j, const char* key, int fallback, int lo, int hi) {
  if (!j.has(key)) return fallback;
  const int n = j.at(key).integer();
  if (n < lo || n > hi) {
    j.at(key).fail(InputErrorKind::bad_value,
                   "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return n;
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
  const std::string shape = j.at("shape").choice({"box", "membrane", "sphere", "ellipsoid", "cylinder"});
  if (shape == "sphere") {
    // Fibonacci-surface ball (sim/mesh/sphere_mesh.h): vertices = shells * surface_vertices + 1.
    j.expect_keys({"shape", "radius", "surface_vertices", "shells"});
    SphereMeshSpec spec;
    spec.radius = j.at("radius").positive_number();
    spec.surface_vertices = read_count(j, "surface_vertices", spec.surface_vertices, 12, 100000);
    spec.shells = read_count(j, "shells", spec.shells, 1, 64);
    return make_sphere_mesh(spec);
  }
  if (shape == "ellipsoid") {
    j.expect_keys({"shape", "semi_axes", "surface_vertices", "shells"});
    EllipsoidMeshSpec spec;
    spec.semi_axes = j.at("semi_axes").vec3();
    if (!(spec.semi_axes.array() > 0.0).all()) {
      j.at("semi_axes").fail(InputErrorKind::bad_value, "semi-axes must be positive");
    }
    spec.surface_vertices = read_count(j, "surface_vertices", spec.surface_vertices, 12, 100000);
    spec.shells = read_count(j, "shells", spec.shells, 1, 64);
    return make_ellipsoid_mesh(spec);
  }
  if (shape == "cylinder") {
    // Solid cylinder along z (sim/mesh/cylinder_mesh.h).
    j.expect_keys({"shape", "radius", "length", "radial_cells", "axial_cells"});
    CylinderMeshSpec spec;
    spec.radius = j.at("radius").positive_number();
    spec.length = j.at("length").positive_number();
    spec.radial_cells = read_count(j, "radial_cells", spec.radial_cells, 1, 512);
    spec.axial_cells = read_count(j, "axial_cells", spec.axial_cells, 1, 512);
    return make_cylinder_mesh(spec);
  }
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
