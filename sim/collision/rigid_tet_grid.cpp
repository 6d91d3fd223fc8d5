#include "sim/collision/rigid_tet_grid.h"

#include <algorithm>
#include <cmath>

namespace pliant {

void RigidTetGrid::build(const TetMesh& mesh) {
  mesh_ = &mesh;
  const auto& rest = mesh.rest_positions();
  const auto& tets = mesh.tets();
  rest_ = rest.data();
  tets_ = tets.data();
  vertex_count_ = rest.size();
  tet_count_ = tets.size();
  edge_ = mesh.mean_edge_length();
  Aabb bounds;
  for (const Vec3& x : rest) bounds.extend(x);
  const double edge = mesh.mean_edge_length() > 0.0 ? mesh.mean_edge_length() : 1.0;
  pad_ = 1e-3 * edge;
  origin_ = bounds.min - Vec3::Constant(pad_);
  const Vec3 extent = bounds.extent() + Vec3::Constant(2.0 * pad_);
  double cell = edge;
  const double max_cells = 64.0 * static_cast<double>(std::max<size_t>(tets.size(), 1));
  for (;;) {
    double cells = 1.0;
    for (int k = 0; k < 3; ++k) cells *= std::floor(extent[k] / cell) + 1.0;
    if (cells <= max_cells) break;
    cell *= 1.25;
  }
  inv_cell_ = 1.0 / cell;
  for (int k = 0; k < 3; ++k) dims_[k] = static_cast<int>(std::floor(extent[k] / cell)) + 1;
  const auto cell_count = static_cast<size_t>(dims_[0]) * static_cast<size_t>(dims_[1]) * static_cast<size_t>(dims_[2]);

  // Two passes (count, then fill) over each tet's padded rest bounds; tets ascend within a cell.
  auto cell_range = [&](size_t t, int lo[3], int hi[3]) {
    Aabb box;
    for (int v : tets[t]) box.extend(rest[static_cast<size_t>(v)]);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::clamp(static_cast<int>(std::floor((box.min[k] - pad_ - origin_[k]) * inv_cell_)), 0, dims_[k] - 1);
      hi[k] = std::clamp(static_cast<int>(std::floor((box.max[k] + pad_ - origin_[k]) * inv_cell_)), 0, dims_[k] - 1);
    }
  };
  cell_offsets_.assign(cell_count + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<int> fill;
    if (pass == 1) {
      for (size_t c = 0; c < cell_count; ++c) cell_offsets_[c + 1] += cell_offsets_[c];
      cell_tets_.assign(static_cast<size_t>(cell_offsets_[cell_count]), -1);
      fill.assign(cell_offsets_.begin(), cell_offsets_.end() - 1);
    }
    for (size_t t = 0; t < tets.size(); ++t) {
      int lo[3], hi[3];
      cell_range(t, lo, hi);
      for (int z = lo[2]; z <= hi[2]; ++z) {
        for (int y = lo[1]; y <= hi[1]; ++y) {
          for (int x = lo[0]; x <= hi[0]; ++x) {
            const auto c = static_cast<size_t>((z * dims_[1] + y) * dims_[0] + x);
            if (pass == 0) {
              ++cell_offsets_[c + 1];
            } else {
              cell_tets_[static_cast<size_t>(fill[c]++)] = static_cast<int>(t);
            }
          }
        }
      }
    }
  }
}

}  // namespace pliant
