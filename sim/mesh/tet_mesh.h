// TetMesh: the constant part of a tetrahedral body (STYLE.md 2). Rest positions, tetrahedra,
// outward boundary triangles, adjacency and rest volumes; validated once on creation and shared
// (std::shared_ptr<const TetMesh>) by every body that uses it. Per-step state lives in Body.
#pragma once

#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sim/math_types.h"

namespace pliant {

/// Options checked when a mesh is built.
struct TetMeshOptions {
  /// A tet whose |volume| is below this fraction of the mesh's mean |volume| is an error.
  double min_relative_volume = 1e-10;
};

/// What validation changed while building a mesh (reported, not an error).
struct TetMeshBuildReport {
  std::vector<int> reoriented_tets;  ///< tets given with negative orientation and flipped
};

/// An undirected mesh edge, a < b.
struct Edge {
  int a = 0;
  int b = 0;
};

class TetMesh {
 public:
  /// Builds and validates a mesh. Throws InputError naming `source` and the offending tet or vertex
  /// for indices out of range, non-finite coordinates, (near-)zero volume or non-manifold faces.
  /// Negatively oriented tets are re-oriented and listed in `report`. `tet_tags` (optional, one per
  /// tet) keeps physical/region tags from the file.
  static std::shared_ptr<const TetMesh> build(std::vector<Vec3> rest_positions,
                                              std::vector<TetIndices> tets,
                                              const std::string& source = "<memory>",
                                              TetMeshBuildReport* report = nullptr,
                                              std::vector<int> tet_tags = {},
                                              const TetMeshOptions& options = {});

  int vertex_count() const { return static_cast<int>(rest_positions_.size()); }
  int tet_count() const { return static_cast<int>(tets_.size()); }
  int surface_triangle_count() const { return static_cast<int>(surface_triangles_.size()); }

  const std::vector<Vec3>& rest_positions() const { return rest_positions_; }
  const std::vector<TetIndices>& tets() const { return tets_; }
  /// Boundary triangles, counter-clockwise seen from outside (normal points out).
  const std::vector<TriIndices>& surface_triangles() const { return surface_triangles_; }
  /// For each surface triangle, the tet it belongs to.
  const std::vector<int>& surface_triangle_tets() const { return surface_triangle_tets_; }
  /// Rest volume of each tet (m^3), positive.
  const std::vector<double>& rest_volumes() const { return rest_volumes_; }
  double total_rest_volume() const { return total_rest_volume_; }
  /// Tags per tet from the file (physical group, region attribute); empty if none.
  const std::vector<int>& tet_tags() const { return tet_tags_; }
  /// Face k of a tet is the one opposite its vertex k, wound as kTetFaceCorners[k] (outward).
  static constexpr int kTetFaceCorners[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  /// Per tet and face k: the tet sharing that face, or -1 on the boundary.
  const std::vector<std::array<int, 4>>& tet_face_neighbors() const { return tet_face_neighbors_; }
  /// Per tet and face k: the surface triangle that face is (boundary faces), or -1 (interior faces).
  const std::vector<std::array<int, 4>>& tet_face_triangles() const { return tet_face_triangles_; }
  /// Unique edges of all tets.
  const std::vector<Edge>& edges() const { return edges_; }
  /// Mean rest length of all edges (m); the spatial hash's cell size.
  double mean_edge_length() const { return mean_edge_length_; }
  /// Vertices on the boundary, ascending.
  const std::vector<int>& surface_vertices() const { return surface_vertices_; }
  bool is_surface_vertex(int v) const { return surface_vertex_flag_[static_cast<size_t>(v)] != 0; }

  /// Tets that contain vertex v.
  std::span<const int> vertex_tets(int v) const { return row(vertex_tets_offsets_, vertex_tets_, v); }
  /// Surface triangles that contain vertex v (empty for interior vertices).
  std::span<const int> vertex_surface_triangles(int v) const {
    return row(vertex_triangles_offsets_, vertex_triangles_, v);
  }
  /// Vertices joined to v by a tet edge.
  std::span<const int> vertex_neighbors(int v) const {
    return row(vertex_neighbors_offsets_, vertex_neighbors_, v);
  }

  /// Lumped vertex masses (kg): each tet gives a quarter of density * volume to each vertex.
  std::vector<double> lumped_masses(double density) const;
  /// Bounding box of the rest positions.
  Aabb rest_bounds() const;

  /// Area-weighted outward normals at surface vertices for positions x (zero at interior vertices).
  void vertex_normals(std::span<const Vec3> x, std::span<Vec3> normals) const;
  /// Outward unit normal of surface triangle t at positions x (zero if degenerate).
  Vec3 triangle_normal(std::span<const Vec3> x, int t) const;
  /// Area of surface triangle t at positions x.
  double triangle_area(std::span<const Vec3> x, int t) const;
  /// A vertex's share of the surface: one third of the areas of its adjacent surface triangles.
  double vertex_surface_area(std::span<const Vec3> x, int v) const;

 private:
  TetMesh() = default;
  static std::span<const int> row(const std::vector<int>& offsets, const std::vector<int>& data, int v) {
    const auto b = static_cast<size_t>(offsets[static_cast<size_t>(v)]);
    const auto e = static_cast<size_t>(offsets[static_cast<size_t>(v) + 1]);
    return {data.data() + b, e - b};
  }
  void build_boundary(const std::string& source);
  void build_adjacency();

  std::vector<Vec3> rest_positions_;
  std::vector<TetIndices> tets_;
  std::vector<int> tet_tags_;
  std::vector<double> rest_volumes_;
  double total_rest_volume_ = 0.0;
  std::vector<TriIndices> surface_triangles_;
  std::vector<int> surface_triangle_tets_;
  std::vector<std::array<int, 4>> tet_face_neighbors_;
  std::vector<std::array<int, 4>> tet_face_triangles_;
  std::vector<Edge> edges_;
  double mean_edge_length_ = 0.0;
  std::vector<int> surface_vertices_;
  std::vector<char> surface_vertex_flag_;
  std::vector<int> vertex_tets_offsets_, vertex_tets_;
  std::vector<int> vertex_triangles_offsets_, vertex_triangles_;
  std::vector<int> vertex_neighbors_offsets_, vertex_neighbors_;
};

using TetMeshPtr = std::shared_ptr<const TetMesh>;

}  // namespace pliant
