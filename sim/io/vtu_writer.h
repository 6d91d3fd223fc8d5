// VTK XML unstructured grid (.vtu) and ParaView time series (.pvd) output. Files are written to a
// temporary name and renamed, so a reader never sees half a file. Errors throw InputError(io).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// VTK cell types we write.
enum class VtuCellType { vertex = 1, triangle = 5, tetra = 10 };

/// Cells of one type; connectivity holds 1, 3 or 4 point indices per cell.
struct VtuCells {
  VtuCellType type = VtuCellType::tetra;
  std::vector<int> connectivity;
};

/// A per-point field: `components` (1 or 3) values per point.
struct VtuPointField {
  std::string name;
  int components = 1;
  std::vector<double> values;
};

/// Writes points, cells and per-point fields as an ASCII .vtu file.
void write_vtu(const std::string& path, std::span<const Vec3> points, const VtuCells& cells,
               std::span<const VtuPointField> fields = {});

/// Convenience: a tet mesh at positions x (tetra cells) with fields.
void write_tet_mesh_vtu(const std::string& path, const TetMesh& mesh, std::span<const Vec3> x,
                        std::span<const VtuPointField> fields = {});

/// A .pvd collection: one dataset per time, written (atomically) on each add.
class PvdSeries {
 public:
  explicit PvdSeries(std::string path) : path_(std::move(path)) {}
  /// Records that `file` (relative to the .pvd's folder) holds the state at `time` (s), then
  /// rewrites the .pvd.
  void add(double time, const std::string& file);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::vector<std::pair<double, std::string>> entries_;
};

}  // namespace pliant
