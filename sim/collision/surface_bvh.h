// Bounding volume hierarchy over the surface triangles of one body at its current positions: the
// accelerator of stage 2 (edge-surface intersections, the contact-triangle ray, nearest surface
// point). Rebuilt each step for every penetrated body; buffers are reused, so a rebuild allocates
// nothing once they have grown.
//
// Design note. Built per penetrated body and refitted (boxes recomputed bottom-up) on later steps;
// rebuilt when the mesh changes or every few steps (PenetrationDepthOptions). Median split on the longest axis of the triangle centroids, up to 4 triangles per
// leaf, nodes in depth-first order (left child follows its parent). Queries keep an explicit stack
// of fixed size (the median split bounds the depth by log2 of the triangle count). Ties between
// equally near triangles go to the smaller triangle index, so results do not depend on the tree.
// The fan query (all edges ending at one border point) visits every node whose box meets the
// fan's box instead of ordering by entry parameter: it keeps the same minimum per edge.
#pragma once

#include <limits>
#include <span>
#include <vector>

#include "sim/math_types.h"
#include "sim/collision/triangle_queries.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// A point on a surface triangle of a body.
struct SurfacePoint {
  int triangle = -1;                  ///< index into mesh.surface_triangles()
  Vec3 barycentric = Vec3::Zero();    ///< weights of the triangle's corners (sum 1, each in [0,1])
  Vec3 point = Vec3::Zero();          ///< the point itself (m)
  double t = 0.0;                     ///< ray/segment parameter (ray and segment queries)
  double distance_squared = 0.0;      ///< squared distance to the query point (nearest query), m^2
};

class SurfaceBvh {
 public:
  /// Builds the hierarchy over mesh's surface triangles at positions x (which must outlive queries).
  void build(const TetMesh& mesh, std::span<const Vec3> x);
  /// Keeps the tree of the last build() and recomputes its boxes for new positions x of the same
  /// mesh: O(n), always correct, slower queries as the surface deforms away from the build pose.
  void refit(std::span<const Vec3> x);

  /// Calls visit(point) for every surface triangle crossed by the segment a + t (b - a), t in [0,1],
  /// skipping triangles that contain vertex exclude_a or exclude_b (-1: none).
  template <class Visit>
  void for_each_segment_hit(const Vec3& a, const Vec3& b, int exclude_a, int exclude_b, Visit&& visit) const;

  /// First triangle hit by origin + t dir, t in [0, t_max] (smallest t); false if the ray misses.
  /// Triangles containing vertex exclude_a or exclude_b (-1: none) are skipped.
  bool first_ray_hit(const Vec3& origin, const Vec3& dir, int exclude_a, SurfacePoint& hit,
                     double t_max = std::numeric_limits<double>::max(), int exclude_b = -1) const;

  /// For each segment origins[i] -> end (t in [0, 1], origin at t = 0): the first triangle hit, as
  /// first_ray_hit(origins[i], end - origins[i], exclude_origins[i], hits[i], 1.0, exclude_end)
  /// would return it; found[i] = 0 if the segment misses. One traversal per kFanChunk segments
  /// (a border point's outgoing edges share their end), culled by boxes instead of slab tests.
  void first_segment_hits(const Vec3& end, int exclude_end, std::span<const Vec3> origins,
                          std::span<const int> exclude_origins, std::span<SurfacePoint> hits,
                          std::span<char> found) const;

  /// Does origin + t dir, t >= 0, cross surface triangle `triangle`? Its parameter in t (a cheap
  /// upper bound for first_ray_hit's t_max when the answer is likely that triangle).
  bool ray_hits_triangle(const Vec3& origin, const Vec3& dir, int triangle, double& t) const {
    TriangleHit h;
    if (!ray_triangle_intersection(origin, dir, corner(triangle, 0), corner(triangle, 1), corner(triangle, 2), 0.0,
                                   std::numeric_limits<double>::max(), h)) {
      return false;
    }
    t = h.t;
    return true;
  }

  /// Closest point of the surface to p; false only if no triangle is eligible. Triangles containing
  /// vertex `exclude` (-1: none) are skipped.
  bool nearest_point(const Vec3& p, int exclude, SurfacePoint& nearest) const;

  /// The mesh the hierarchy was built for.
  const TetMesh* mesh() const { return mesh_; }
  /// The positions the hierarchy was built for (m).
  std::span<const Vec3> positions() const { return x_; }

 private:
  struct Node {
    Aabb box;
    int first = 0;   ///< leaf: first entry in order_; inner: index of the right child
    int count = 0;   ///< leaf: number of triangles (> 0); inner: 0
  };
  static constexpr int kLeafSize = 4;
  static constexpr int kMaxStack = 128;
  static constexpr int kFanChunk = 16;

  int build_node(int begin, int end, int depth);
  bool excluded(int tri, int exclude_a, int exclude_b) const;
  const Vec3& corner(int tri, int k) const;

  const TetMesh* mesh_ = nullptr;
  std::span<const Vec3> x_;
  std::vector<Node> nodes_;
  std::vector<int> order_;
  std::vector<Vec3> centroids_;
  std::vector<Aabb> boxes_;
  std::vector<PreparedTriangle> prepared_;  ///< per entry of order_ (leaf order): corner and edges
  void prepare_triangles();
};

}  // namespace pliant

#include "sim/collision/surface_bvh_inl.h"
