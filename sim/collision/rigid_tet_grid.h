// A rigid body's tets binned once in its rest frame, for detection against a kinematic instrument.
//
// Design note (session 8, issue #6). The probe scene's instrument is kinematic and rigid: its
// positions are its pose applied to the rest mesh, so which of its tets may hold a point follows
// from the point in the rest frame alone. The spatial hash's pass 2 walked the cells of every
// instrument tet near the tissue (~800 per step); this grid lets it start from the tissue vertices
// instead (~100 inserted), each mapped into the rest frame and looked up in one cell. The grid only
// proposes candidates: every proposed (vertex, tet) pair then takes the hash's own test at the
// world positions (bounds, barycentric frame, internal faces), so the contacts found are the same
// bits. Tets are binned by their rest bounds grown by `pad()`; a query is exact when the body's
// positions lie within pad() of pose(rest) and the rounding of the frame change is below it (the
// hash measures both per step and falls back to its cell walk otherwise). Cells have the mean rest
// edge length, enlarged until there are at most 64 cells per tet.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// The tets of one mesh binned on a regular grid over its rest positions.
class RigidTetGrid {
 public:
  /// Bins every tet of `mesh` (kept by address: the mesh must outlive the grid's use).
  void build(const TetMesh& mesh);
  /// Whether the grid was built for `mesh`: its address, the addresses and sizes of its arrays and
  /// its mean edge length (a mesh freed and another made at the same address is not taken for it).
  bool built_for(const TetMesh& mesh) const {
    return mesh_ == &mesh && rest_ == mesh.rest_positions().data() && tets_ == mesh.tets().data() &&
           vertex_count_ == mesh.rest_positions().size() && tet_count_ == mesh.tets().size() &&
           edge_ == mesh.mean_edge_length();
  }
  /// How far (m) beyond its rest bounds a tet is still listed in a cell.
  double pad() const { return pad_; }
  /// The tets whose padded rest bounds may contain the rest-frame point p (empty outside the grid).
  std::span<const int> tets_near(const Vec3& p) const {
    int c[3];
    for (int k = 0; k < 3; ++k) {
      const double s = (p[k] - origin_[k]) * inv_cell_;
      if (!(s >= 0.0) || s >= static_cast<double>(dims_[k])) return {};
      c[k] = static_cast<int>(s);
    }
    const auto cell = static_cast<size_t>((c[2] * dims_[1] + c[1]) * dims_[0] + c[0]);
    const auto first = static_cast<size_t>(cell_offsets_[cell]), last = static_cast<size_t>(cell_offsets_[cell + 1]);
    return std::span<const int>(cell_tets_).subspan(first, last - first);
  }

 private:
  const TetMesh* mesh_ = nullptr;
  const Vec3* rest_ = nullptr;          ///< the mesh's rest positions when built
  const TetIndices* tets_ = nullptr;    ///< the mesh's tets when built
  size_t vertex_count_ = 0;
  size_t tet_count_ = 0;
  double edge_ = 0.0;                   ///< the mesh's mean edge length when built (m)
  Vec3 origin_ = Vec3::Zero();  ///< rest-frame corner of cell (0, 0, 0) (m)
  double inv_cell_ = 0.0;       ///< 1 / cell edge (1/m)
  double pad_ = 0.0;            ///< tolerance (m) the bins are grown by
  int dims_[3] = {0, 0, 0};     ///< cells along x, y, z
  std::vector<int> cell_offsets_;  ///< per cell, first index into cell_tets_ (one past the end last)
  std::vector<int> cell_tets_;     ///< tets of each cell, ascending
};

}  // namespace pliant
