#include "sim/collision/vertex_normal_scratch.h"

#include <algorithm>

namespace pliant {

void StampedSlotTable::new_generation() {
  size_ = 0;
  keys_.clear();
  if (table_.empty()) {
    // 256 entries (3 KB): a depth group reaches tens to a few hundred vertices or triangles.
    table_.resize(256);
    shift_ = 32 - 8;
  }
  if (++stamp_ == 0) {
    std::fill(table_.begin(), table_.end(), Entry{});
    stamp_ = 1;
  }
}

int StampedSlotTable::find_or_insert(int key) {
  // At most half full: probes stay short.
  if (2 * (static_cast<std::size_t>(size_) + 1) > table_.size()) grow();
  const std::size_t mask = table_.size() - 1;
  for (std::size_t i = home(key);; i = (i + 1) & mask) {
    Entry& e = table_[i];
    if (e.stamp != stamp_) {
      e = Entry{stamp_, key, size_};
      keys_.push_back(key);
      return -1 - size_++;
    }
    if (e.key == key) return e.slot;
  }
}

void StampedSlotTable::grow() {
  table_.assign(table_.size() * 2, Entry{});
  --shift_;
  const std::size_t mask = table_.size() - 1;
  for (int s = 0; s < size_; ++s) {
    const int key = keys_[static_cast<std::size_t>(s)];
    std::size_t i = home(key);
    while (table_[i].stamp == stamp_) i = (i + 1) & mask;
    table_[i] = Entry{stamp_, key, s};
  }
}

void VertexNormalScratch::begin(const TetMesh& mesh, std::span<const Vec3> x) {
  mesh_ = &mesh;
  x_ = x;
  vertices_.new_generation();
  triangles_.new_generation();
}

const Vec3& VertexNormalScratch::face_cross(int t) {
  const int s = triangles_.find_or_insert(t);
  if (s >= 0) return crosses_[static_cast<std::size_t>(s)];
  const auto slot = static_cast<std::size_t>(-1 - s);
  if (crosses_.size() <= slot) crosses_.resize(slot + 1);
  const auto& tri = mesh_->surface_triangles()[static_cast<std::size_t>(t)];
  const Vec3& a = x_[static_cast<std::size_t>(tri[0])];
  crosses_[slot] = (x_[static_cast<std::size_t>(tri[1])] - a).cross(x_[static_cast<std::size_t>(tri[2])] - a);
  return crosses_[slot];
}

const Vec3& VertexNormalScratch::compute_normal(int v, int s) {
  // TetMesh::vertex_normals for one vertex, bit for bit: the area-weighted face normals summed in
  // ascending triangle order (vertex_surface_triangles is sorted), then normalised. Each face's
  // cross product is computed once per generation and shared by its three corners (same values).
  Vec3 n = Vec3::Zero();
  for (int t : mesh_->vertex_surface_triangles(v)) n += face_cross(t);
  const double len = n.norm();
  if (len > 0.0) n /= len;
  const auto slot = static_cast<std::size_t>(s);
  if (normals_.size() <= slot) normals_.resize(slot + 1);
  normals_[slot] = n;
  return normals_[slot];
}

}  // namespace pliant
