#include "sim/mesh/tet_mesh.h"

#include <algorithm>
#include <cmath>

#include "sim/input_error.h"

namespace pliant {
namespace {

// Outward faces of a positively oriented tet (0,1,2,3): each listed counter-clockwise from outside.
constexpr const auto& kTetFaces = TetMesh::kTetFaceCorners;

// Compressed rows (CSR) from (row, value) pairs.
void build_csr(int rows, std::vector<std::pair<int, int>>& pairs, std::vector<int>& offsets,
               std::vector<int>& data) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  offsets.assign(static_cast<size_t>(rows) + 1, 0);
  for (const auto& [r, value] : pairs) offsets[static_cast<size_t>(r) + 1]++;
  for (size_t i = 1; i < offsets.size(); ++i) offsets[i] += offsets[i - 1];
  data.resize(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) data[i] = pairs[i].second;
}

}  // namespace

std::shared_ptr<const TetMesh> TetMesh::build(std::vector<Vec3> rest_positions,
                                              std::vector<TetIndices> tets, const std::string& source,
                                              TetMeshBuildReport* report, std::vector<int> tet_tags,
                                              const TetMeshOptions& options) {
  if (rest_positions.empty()) throw InputError(InputErrorKind::bad_value, source, "mesh has no vertices");
  if (tets.empty()) throw InputError(InputErrorKind::bad_value, source, "mesh has no tetrahedra");
  if (!tet_tags.empty() && tet_tags.size() != tets.size()) {
    throw InputError(InputErrorKind::count_mismatch, source, "tet tag count differs from tet count");
  }
  const int n = static_cast<int>(rest_positions.size());
  for (int i = 0; i < n; ++i) {
    if (!rest_positions[static_cast<size_t>(i)].allFinite()) {
      throw InputError(InputErrorKind::non_finite, source,
                       "vertex " + std::to_string(i) + " has a non-finite coordinate");
    }
  }
  auto mesh = std::shared_ptr<TetMesh>(new TetMesh());
  mesh->rest_volumes_.resize(tets.size());
  double sum_abs = 0.0;
  for (size_t t = 0; t < tets.size(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const int v = tets[t][static_cast<size_t>(k)];
      if (v < 0 || v >= n) {
        throw InputError(InputErrorKind::index_out_of_range, source,
                         "tetrahedron " + std::to_string(t) + " refers to vertex " + std::to_string(v) +
                             ", but there are " + std::to_string(n) + " vertices");
      }
    }
    auto& tet = tets[t];
    if (tet[0] == tet[1] || tet[0] == tet[2] || tet[0] == tet[3] || tet[1] == tet[2] || tet[1] == tet[3] ||
        tet[2] == tet[3]) {
      throw InputError(InputErrorKind::degenerate_element, source,
                       "tetrahedron " + std::to_string(t) + " repeats a vertex");
    }
    const auto& x = rest_positions;
    double vol = signed_tet_volume(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                   x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
    mesh->rest_volumes_[t] = vol;
    sum_abs += std::abs(vol);
  }
  const double mean_volume = sum_abs / static_cast<double>(tets.size());
  for (size_t t = 0; t < tets.size(); ++t) {
    double& vol = mesh->rest_volumes_[t];
    if (!(std::abs(vol) > options.min_relative_volume * mean_volume)) {
      throw InputError(InputErrorKind::degenerate_element, source,
                       "tetrahedron " + std::to_string(t) + " has (near-)zero volume " + std::to_string(vol) +
                           " (mean tet volume " + std::to_string(mean_volume) + ")");
    }
    if (vol < 0.0) {
      std::swap(tets[t][2], tets[t][3]);
      vol = -vol;
      if (report != nullptr) report->reoriented_tets.push_back(static_cast<int>(t));
    }
    mesh->total_rest_volume_ += vol;
  }
  mesh->rest_positions_ = std::move(rest_positions);
  mesh->tets_ = std::move(tets);
  mesh->tet_tags_ = std::move(tet_tags);
  mesh->build_boundary(source);
  mesh->build_adjacency();
  return mesh;
}

void TetMesh::build_boundary(const std::string& source) {
  struct Face {
    std::array<int, 3> key;       // sorted vertex ids
    TriIndices oriented;          // outward winding
    int tet;
    int face;                     // local face index k (opposite the tet's vertex k)
  };
  std::vector<Face> faces;
  faces.reserve(tets_.size() * 4);
  for (size_t t = 0; t < tets_.size(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const auto& f = kTetFaces[k];
      TriIndices tri{tets_[t][static_cast<size_t>(f[0])], tets_[t][static_cast<size_t>(f[1])],
                     tets_[t][static_cast<size_t>(f[2])]};
      std::array<int, 3> key = tri;
      std::sort(key.begin(), key.end());
      faces.push_back({key, tri, static_cast<int>(t), k});
    }
  }
  // Tet-face adjacency (filled below from the same sorted faces): neighbour across each face, or
  // the surface triangle a boundary face is.
  tet_face_neighbors_.assign(tets_.size(), {-1, -1, -1, -1});
  tet_face_triangles_.assign(tets_.size(), {-1, -1, -1, -1});
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
  for (size_t i = 0; i < faces.size();) {
    size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) {
      tet_face_triangles_[static_cast<size_t>(faces[i].tet)][static_cast<size_t>(faces[i].face)] =
          static_cast<int>(surface_triangles_.size());
      surface_triangles_.push_back(faces[i].oriented);
      surface_triangle_tets_.push_back(faces[i].tet);
    } else if (j - i == 2) {
      tet_face_neighbors_[static_cast<size_t>(faces[i].tet)][static_cast<size_t>(faces[i].face)] = faces[i + 1].tet;
      tet_face_neighbors_[static_cast<size_t>(faces[i + 1].tet)][static_cast<size_t>(faces[i + 1].face)] =
          faces[i].tet;
    } else if (j - i > 2) {
      throw InputError(InputErrorKind::topology, source,
                       "face (" + std::to_string(faces[i].key[0]) + ", " + std::to_string(faces[i].key[1]) +
                           ", " + std::to_string(faces[i].key[2]) + ") is shared by " + std::to_string(j - i) +
                           " tetrahedra (tetrahedra " + std::to_string(faces[i].tet) + " and " +
                           std::to_string(faces[i + 1].tet) + " ...)");
    }
    i = j;
  }
}

void TetMesh::build_adjacency() {
  const int n = vertex_count();
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(tets_.size() * 4);
  for (size_t t = 0; t < tets_.size(); ++t) {
    for (int v : tets_[t]) pairs.emplace_back(v, static_cast<int>(t));
  }
  build_csr(n, pairs, vertex_tets_offsets_, vertex_tets_);

  pairs.clear();
  for (size_t t = 0; t < surface_triangles_.size(); ++t) {
    for (int v : surface_triangles_[t]) pairs.emplace_back(v, static_cast<int>(t));
  }
  build_csr(n, pairs, vertex_triangles_offsets_, vertex_triangles_);

  pairs.clear();
  for (const auto& tet : tets_) {
    for (int a = 0; a < 4; ++a) {
      for (int b = 0; b < 4; ++b) {
        if (a != b) pairs.emplace_back(tet[static_cast<size_t>(a)], tet[static_cast<size_t>(b)]);
      }
    }
  }
  build_csr(n, pairs, vertex_neighbors_offsets_, vertex_neighbors_);

  double length_sum = 0.0;
  for (int v = 0; v < n; ++v) {
    for (int w : vertex_neighbors(v)) {
      if (v < w) {
        edges_.push_back({v, w});
        length_sum += (rest_positions_[static_cast<size_t>(w)] - rest_positions_[static_cast<size_t>(v)]).norm();
      }
    }
  }
  mean_edge_length_ = edges_.empty() ? 0.0 : length_sum / static_cast<double>(edges_.size());

  surface_vertex_flag_.assign(static_cast<size_t>(n), 0);
  for (const auto& tri : surface_triangles_) {
    for (int v : tri) surface_vertex_flag_[static_cast<size_t>(v)] = 1;
  }
  for (int v = 0; v < n; ++v) {
    if (surface_vertex_flag_[static_cast<size_t>(v)] != 0) surface_vertices_.push_back(v);
  }
}

std::vector<double> TetMesh::lumped_masses(double density) const {
  std::vector<double> m(rest_positions_.size(), 0.0);
  for (size_t t = 0; t < tets_.size(); ++t) {
    const double share = 0.25 * density * rest_volumes_[t];
    for (int v : tets_[t]) m[static_cast<size_t>(v)] += share;
  }
  return m;
}

Aabb TetMesh::rest_bounds() const {
  Aabb box;
  for (const auto& p : rest_positions_) box.extend(p);
  return box;
}

void TetMesh::vertex_normals(std::span<const Vec3> x, std::span<Vec3> normals) const {
  for (auto& n : normals) n.setZero();
  for (const auto& tri : surface_triangles_) {
    const Vec3& a = x[static_cast<size_t>(tri[0])];
    // The cross product's length is twice the area: area weighting comes for free.
    const Vec3 n = (x[static_cast<size_t>(tri[1])] - a).cross(x[static_cast<size_t>(tri[2])] - a);
    for (int v : tri) normals[static_cast<size_t>(v)] += n;
  }
  for (int v : surface_vertices_) {
    Vec3& n = normals[static_cast<size_t>(v)];
    const double len = n.norm();
    if (len > 0.0) n /= len;
  }
}

Vec3 TetMesh::triangle_normal(std::span<const Vec3> x, int t) const {
  const auto& tri = surface_triangles_[static_cast<size_t>(t)];
  const Vec3& a = x[static_cast<size_t>(tri[0])];
  Vec3 n = (x[static_cast<size_t>(tri[1])] - a).cross(x[static_cast<size_t>(tri[2])] - a);
  const double len = n.norm();
  return len > 0.0 ? Vec3(n / len) : Vec3::Zero();
}

double TetMesh::triangle_area(std::span<const Vec3> x, int t) const {
  const auto& tri = surface_triangles_[static_cast<size_t>(t)];
  const Vec3& a = x[static_cast<size_t>(tri[0])];
  return 0.5 * (x[static_cast<size_t>(tri[1])] - a).cross(x[static_cast<size_t>(tri[2])] - a).norm();
}

double TetMesh::vertex_surface_area(std::span<const Vec3> x, int v) const {
  double area = 0.0;
  for (int t : vertex_surface_triangles(v)) area += triangle_area(x, t);
  return area / 3.0;
}

}  // namespace pliant
