#include "sim/collision/vertex_normal_scratch.h"

#include <algorithm>

#include "sim/collision/vertex_normal_scratch_inl.h"

namespace pliant {

void VertexNormalScratch::begin(const TetMesh& mesh, std::span<const Vec3> x) {
  mesh_ = &mesh;
  x_ = x;
  if (normals_.empty()) {
    normals_.resize(kNormalSlots);
    crosses_.resize(kCrossSlots);
  }
  generation_ += std::uint64_t{1} << 32;
  if (generation_ == 0) {
    // 2^32 generations: forget the old tags, then start again at 1.
    std::fill(normals_.begin(), normals_.end(), Entry{});
    std::fill(crosses_.begin(), crosses_.end(), Entry{});
    generation_ = std::uint64_t{1} << 32;
  }
}

const Vec3& VertexNormalScratch::face_cross(int t) {
  Entry& e = crosses_[static_cast<std::uint32_t>(t) & (kCrossSlots - 1)];
  if (e.tag != tag(t)) {
    const auto& tri = mesh_->surface_triangles()[static_cast<std::size_t>(t)];
    const Vec3& a = x_[static_cast<std::size_t>(tri[0])];
    e.value = (x_[static_cast<std::size_t>(tri[1])] - a).cross(x_[static_cast<std::size_t>(tri[2])] - a);
    e.tag = tag(t);
  }
  return e.value;
}

const Vec3& VertexNormalScratch::compute_normal(int v, Entry& e) {
  // TetMesh::vertex_normals for one vertex, bit for bit: the area-weighted face normals summed in
  // ascending triangle order (vertex_surface_triangles is sorted), then normalised. Each face's
  // cross product is kept in the generation and shared by its three corners (same values).
  Vec3 n = Vec3::Zero();
  for (int t : mesh_->vertex_surface_triangles(v)) n += face_cross(t);
  const double len = n.norm();
  if (len > 0.0) n /= len;
  e.value = n;
  e.tag = tag(v);
  return e.value;
}

}  // namespace pliant
