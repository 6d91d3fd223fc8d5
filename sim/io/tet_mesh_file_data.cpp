#include "sim/io/tet_mesh_file_data.h"

#include <cmath>

#include "sim/input_error.h"

namespace pliant {

TetMeshPtr build_tet_mesh_from_file(TetMeshFileData data, const std::string& source,
                                    TetMeshReadReport* report) {
  if (data.tets.empty()) {
    throw InputError(InputErrorKind::bad_value, source, "the file holds no 4-node tetrahedra");
  }
  const auto where = [&](size_t t) {
    return t < data.tet_lines.size() ? file_line(data.tet_file, data.tet_lines[t]) : data.tet_file;
  };
  const long n = static_cast<long>(data.positions.size());
  double sum_abs = 0.0;
  std::vector<double> volumes(data.tets.size());
  for (size_t t = 0; t < data.tets.size(); ++t) {
    const auto& tet = data.tets[t];
    for (int v : tet) {
      if (v < 0 || v >= n) {
        throw InputError(InputErrorKind::index_out_of_range, where(t),
                         "tetrahedron " + std::to_string(t) + " refers to vertex " + std::to_string(v) +
                             ", but there are " + std::to_string(n) + " vertices");
      }
    }
    for (int a = 0; a < 4; ++a) {
      for (int b = a + 1; b < 4; ++b) {
        if (tet[static_cast<size_t>(a)] == tet[static_cast<size_t>(b)]) {
          throw InputError(InputErrorKind::degenerate_element, where(t),
                           "tetrahedron " + std::to_string(t) + " repeats vertex " +
                               std::to_string(tet[static_cast<size_t>(a)]));
        }
      }
    }
    const auto& x = data.positions;
    volumes[t] = signed_tet_volume(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                   x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
    sum_abs += std::abs(volumes[t]);
  }
  // Same threshold as TetMesh::build, checked here so the message names the line.
  const double mean = sum_abs / static_cast<double>(data.tets.size());
  const double threshold = TetMeshOptions{}.min_relative_volume * mean;
  for (size_t t = 0; t < data.tets.size(); ++t) {
    if (!(std::abs(volumes[t]) > threshold)) {
      throw InputError(InputErrorKind::degenerate_element, where(t),
                       "tetrahedron " + std::to_string(t) + " has (near-)zero volume " +
                           std::to_string(volumes[t]) + " (mean tet volume " + std::to_string(mean) + ")");
    }
  }
  // Drop vertices that no tet uses: they would get zero mass.
  std::vector<int> new_index(data.positions.size(), -1);
  for (const auto& tet : data.tets) {
    for (int v : tet) new_index[static_cast<size_t>(v)] = 0;
  }
  int kept = 0;
  std::vector<Vec3> positions;
  positions.reserve(data.positions.size());
  for (size_t v = 0; v < data.positions.size(); ++v) {
    if (new_index[v] < 0) continue;
    new_index[v] = kept++;
    positions.push_back(data.positions[v]);
  }
  for (auto& tet : data.tets) {
    for (int& v : tet) v = new_index[static_cast<size_t>(v)];
  }
  if (report != nullptr) report->unused_vertices_removed = static_cast<int>(data.positions.size()) - kept;
  return TetMesh::build(std::move(positions), std::move(data.tets), source,
                        report != nullptr ? &report->build : nullptr, std::move(data.tet_tags));
}

}  // namespace pliant
