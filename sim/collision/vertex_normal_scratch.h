// Smoothed vertex normals of the surface vertices one depth group reaches, in a small scratch.
//
// Design note. Stage 2 interpolates vertex normals at the few surface points its edges hit
// (Heidelberger 2004, section 4.2). Kept in per-vertex arrays of every penetrated surface (up to
// session 12), each first use in a pose wrote a 24-byte normal and an 8-byte epoch, plus a face
// cross product and its epoch per incident triangle, into arrays of the whole surface: at 100k tets
// (260 bodies) nearly every such write was an L2 write-allocate miss (docs/penetration-depth.md,
// session 12's profile). Here one generation (a depth group: one penetrated surface at one pose)
// keeps normals and face cross products in two small direct-mapped tables (slot = index modulo the
// table size), each entry tagged with its generation and index: a new generation forgets everything
// in O(1), and a lookup is a mask, a load and a compare. Two indices of one group that share a slot
// evict each other and are recomputed: the same expressions from the same positions, so the
// normals are bit for bit TetMesh::vertex_normals' whatever the table size (session 13 tried an
// open-addressing map of exactly the reached indices first: the same misses saved, twice the
// instructions of the normals).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Area-weighted vertex normals (TetMesh::vertex_normals, bit for bit) of one surface at one pose,
/// computed on first use and kept (while their slot is not taken) until the next begin().
class VertexNormalScratch {
 public:
  /// Starts a generation for `mesh` at positions `x` (both must outlive the generation).
  void begin(const TetMesh& mesh, std::span<const Vec3> x);
  /// The unit area-weighted normal of surface vertex v (zero for a vertex without surface
  /// triangles); valid until the next call. Inline in vertex_normal_scratch_inl.h (the hot path).
  const Vec3& normal(int v);

 private:
  /// A table entry: a value and whose it is.
  struct Entry {
    std::uint64_t tag = 0;  ///< generation << 32 | index (generation 0: never written)
    Vec3 value;
  };
  static constexpr std::size_t kNormalSlots = 256;  ///< a 4-cell block body has 125 vertices
  static constexpr std::size_t kCrossSlots = 512;   ///< ... and 192 surface triangles
  std::uint64_t tag(int index) const { return generation_ | static_cast<std::uint32_t>(index); }
  /// Computes vertex v's normal into `e`.
  const Vec3& compute_normal(int v, Entry& e);
  /// (b - a) x (c - a) of surface triangle t, twice its area normal (once per generation and slot).
  const Vec3& face_cross(int t);

  const TetMesh* mesh_ = nullptr;
  std::span<const Vec3> x_;
  std::vector<Entry> normals_;   ///< kNormalSlots entries, vertex v in slot v mod kNormalSlots
  std::vector<Entry> crosses_;   ///< kCrossSlots entries, triangle t in slot t mod kCrossSlots
  std::uint64_t generation_ = 0; ///< this generation's number << 32
};

}  // namespace pliant
