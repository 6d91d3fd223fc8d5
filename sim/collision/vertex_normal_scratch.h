// Smoothed vertex normals of the surface vertices one depth group reaches, in a compact scratch.
//
// Design note. Stage 2 interpolates vertex normals at the few surface points its edges hit
// (Heidelberger 2004, section 4.2). Kept in per-vertex arrays of every penetrated surface (as up to
// session 12), each first use in a pose wrote a 24-byte normal and an 8-byte epoch, plus a face
// cross product and its epoch per incident triangle, into arrays of the whole surface: at 100k tets
// (260 bodies, ~10 MB of such arrays) nearly every one of those writes was an L2 write-allocate miss
// (docs/penetration-depth.md, session 12 profile). Here a generation (one depth group) keeps only
// the vertices and triangles it reaches, in first-reached order, behind two small open-addressing
// tables whose entries carry the generation's stamp (a new generation forgets everything in O(1),
// no clearing). The values are computed by the same expressions in the same order as
// TetMesh::vertex_normals: bit for bit the same normals.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Key -> dense slot map for one generation: open addressing, linear probing, stamped entries.
class StampedSlotTable {
 public:
  /// Forgets every key (O(1): the stamp advances; the table is cleared only when it wraps).
  void new_generation();
  /// The slot of `key` (>= 0), or, if absent, assigns it the next slot (size()) and returns
  /// -1 - that slot (so the caller knows to fill it).
  int find_or_insert(int key);
  /// Keys of this generation.
  int size() const { return size_; }

 private:
  struct Entry {
    std::uint32_t stamp = 0;  ///< generation that wrote the entry (0: never)
    std::int32_t key = 0;
    std::int32_t slot = 0;
  };
  /// Doubles the table and re-inserts this generation's keys (kept in keys_, slot order).
  void grow();
  std::size_t home(int key) const {
    return static_cast<std::size_t>((static_cast<std::uint32_t>(key) * 2654435769u) >> shift_);
  }

  std::vector<Entry> table_;
  std::vector<int> keys_;     ///< per slot: its key (for growing)
  std::uint32_t stamp_ = 0;
  int size_ = 0;
  int shift_ = 32;            ///< 32 - log2(table size)
};

/// Area-weighted vertex normals (TetMesh::vertex_normals, bit for bit) of one surface at one pose,
/// computed on first use and kept until the next begin().
class VertexNormalScratch {
 public:
  /// Starts a generation for `mesh` at positions `x` (both must outlive the generation).
  void begin(const TetMesh& mesh, std::span<const Vec3> x);
  /// The unit area-weighted normal of surface vertex v (zero for a vertex without surface triangles).
  const Vec3& normal(int v) {
    const int s = vertices_.find_or_insert(v);
    return s >= 0 ? normals_[static_cast<std::size_t>(s)] : compute_normal(v, -1 - s);
  }

 private:
  /// Computes vertex v's normal into slot s.
  const Vec3& compute_normal(int v, int s);
  /// (b - a) x (c - a) of surface triangle t, twice its area normal (once per generation).
  const Vec3& face_cross(int t);

  const TetMesh* mesh_ = nullptr;
  std::span<const Vec3> x_;
  StampedSlotTable vertices_, triangles_;
  std::vector<Vec3> normals_;   ///< per vertex slot, first-reached order
  std::vector<Vec3> crosses_;   ///< per triangle slot, first-reached order
};

}  // namespace pliant
