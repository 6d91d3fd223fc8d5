// Bounding volume hierarchy over the surface triangles of one body at its current positions: the
// accelerator of stage 2 (edge-surface intersections, the contact-triangle ray, nearest surface
// point). Buffers are reused, so neither build nor refit allocates once they have grown.
//
// Design note. Built per penetrated body; rebuilt when the mesh changes or after a number of full
// refits (PenetrationDepthOptions). Median split on the longest axis of the triangle centroids, up
// to 4 triangles per leaf, nodes in depth-first order (left child follows its parent). Queries keep
// an explicit stack of fixed size (the median split bounds the depth by log2 of the triangle count).
// Ties between equally near triangles go to the smaller triangle index, so results do not depend on
// the tree, the order of visits or how loose the boxes are: every box only culls conservatively.
//
// Lazy refit. A refit first measures how far any surface vertex moved since the node boxes were
// last fitted (delta, max-norm). Zero, with no lazy step since the fit: nothing to do (a still
// body). Up to a limit (a fraction of the mean edge
// length): the node boxes are kept and every query inflates them by delta (plus a rounding
// margin), which still contains the current triangles; the exact per-triangle data (box, prepared
// corner and edges) of a leaf is recomputed the first time a query reaches that leaf in this pose.
// Beyond the limit: a full bottom-up refit (or a rebuild when one is due). A step with a few local
// contacts on a large, slowly deforming surface (the tissue under a probe) then costs one pass over
// the surface vertices plus the leaves actually visited, instead of a refit of the whole surface.
// Queries are const but fill that per-leaf cache (mutable): a SurfaceBvh is not shared between
// threads.
//
// The fan query (all edges ending at one border point) visits every node whose box meets the fan's
// box instead of ordering by entry parameter: it keeps the same minimum per edge. With AVX it finds
// those leaves through a 4-wide view of the tree (quad_box_tree.h): the same leaves in the same order.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "sim/math_types.h"
#include "sim/collision/quad_box_tree.h"
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

/// What SurfaceBvh::refit did to follow new positions.
enum class SurfaceBvhUpdate {
  unchanged,  ///< no surface vertex moved: every cached box and triangle is still exact
  lazy,       ///< node boxes kept, inflated by the motion; leaves refitted when a query reaches them
  refit,      ///< all boxes recomputed bottom-up on the same tree
  rebuild,    ///< a new tree (as build())
};

class SurfaceBvh {
 public:
  /// Builds the hierarchy over mesh's surface triangles at positions x (which must outlive queries).
  void build(const TetMesh& mesh, std::span<const Vec3> x);
  /// Follows new positions x of the same mesh (see the design note): keeps everything if nothing
  /// moved, inflates the node boxes if the surface moved by at most `lazy_limit_edges` mean edge
  /// lengths since they were fitted, else refits every box, or rebuilds the tree if
  /// `rebuild_when_full` is set. Always correct; only query speed depends on the choice.
  SurfaceBvhUpdate refit(std::span<const Vec3> x, double lazy_limit_edges = 0.0, bool rebuild_when_full = false);

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

  /// Fan queries by the AVX segment-packet kernel where the CPU has it (default; the same results
  /// bit for bit, segment_packet.h) or always by the scalar loop (false; for tests and benchmarks).
  void set_segment_packets(bool on) { segment_packets_ = on; }

  /// Leaves (node indices) whose box and every ancestor's box meet `query`, in depth-first order,
  /// as the fan query finds them: by the binary tree (quad = false) or its 4-wide view (true;
  /// quad_box_tree.h). For tests: both lists must be equal.
  void leaves_meeting(const Aabb& query, bool quad, std::vector<int>& out) const;

  /// Closest point of the surface to p; false only if no triangle is eligible. Triangles containing
  /// vertex `exclude` (-1: none) are skipped.
  bool nearest_point(const Vec3& p, int exclude, SurfacePoint& nearest) const;

  /// The mesh the hierarchy was built for.
  const TetMesh* mesh() const { return mesh_; }
  /// The positions the hierarchy was built for (m).
  std::span<const Vec3> positions() const { return x_; }
  /// Changes whenever the positions' values change (build, or a refit that was not `unchanged`):
  /// data derived from the positions (vertex normals) stays valid while it is the same.
  std::uint64_t pose_epoch() const { return pose_epoch_; }
  /// Amount by which queries currently inflate the node boxes (m); 0 after a build or full refit.
  double slack() const { return slack_; }

 private:
  struct Node {
    Aabb box;        ///< bounds at the last full fit (queries inflate it by slack_)
    int first = 0;   ///< leaf: first entry in order_; inner: index of the right child
    int count = 0;   ///< leaf: number of triangles (> 0); inner: 0
  };
  static constexpr int kLeafSize = 4;
  static constexpr int kMaxStack = 128;
  static constexpr int kFanChunk = 16;

  int build_node(int begin, int end, int depth);
  void full_refit();
  void fit_leaf(const Node& node) const;
  /// Makes the exact data (triangle boxes, prepared triangles) of leaf `n` current.
  void ensure_leaf(int n) const {
    if (leaf_epoch_[static_cast<size_t>(n)] != pose_epoch_) {
      fit_leaf(nodes_[static_cast<size_t>(n)]);
      leaf_epoch_[static_cast<size_t>(n)] = pose_epoch_;
    }
  }
  /// Calls leaf(node) for every leaf whose box meets `query` (depth first), its data made current.
  template <class Leaf>
  void visit_leaves_meeting(const Aabb& query, Leaf&& leaf) const;
  /// One chunk of first_segment_hits by the segment-packet kernel (no excluded vertices).
  void fan_chunk_packet(const Vec3& end, const Aabb& node_query, std::span<const Vec3> origins,
                        std::span<SurfacePoint> hits, std::span<char> found) const;
  /// One chunk of first_segment_hits by the scalar loop (masks of segment boxes, Moller-Trumbore).
  void fan_chunk_scalar(const Vec3& end, int exclude_end, const Aabb& fan, const Aabb& node_query, bool any_exclude,
                        std::span<const Vec3> origins, std::span<const int> exclude_origins,
                        std::span<SurfacePoint> hits, std::span<char> found) const;
  /// Node n's box as queries see it: inflated by slack_.
  Aabb query_box(int n) const;
  void remember_fitted_positions();
  bool excluded(int tri, int exclude_a, int exclude_b) const;
  const Vec3& corner(int tri, int k) const;

  const TetMesh* mesh_ = nullptr;
  std::span<const Vec3> x_;
  std::vector<Node> nodes_;
  std::vector<int> order_;                  ///< leaf order -> surface triangle index
  std::vector<Vec3> centroids_;             ///< build scratch, per triangle
  std::vector<Vec3> fitted_positions_;      ///< per surface vertex: its position when the boxes were fitted
  double fitted_scale_ = 0.0;               ///< largest |coordinate| of those positions (m)
  double slack_ = 0.0;                      ///< inflation of node boxes for queries (m)
  std::uint64_t pose_epoch_ = 0;
  // Per entry of order_ (leaf order), valid for a leaf whose leaf_epoch_ equals pose_epoch_.
  mutable std::vector<Aabb> triangle_boxes_;
  mutable std::vector<PreparedTriangle> prepared_;  ///< corner and edges (triangle_queries.h)
  mutable std::vector<std::uint64_t> leaf_epoch_;   ///< per node
  bool segment_packets_ = true;                     ///< fan queries may use the AVX kernel
  QuadBoxTree quad_;                                ///< 4-wide view of nodes_ for the packet fan query
  mutable std::vector<int> fan_leaves_;             ///< leaves a fan chunk meets (quad_.leaf_count())
};

}  // namespace pliant

#include "sim/collision/surface_bvh_inl.h"
