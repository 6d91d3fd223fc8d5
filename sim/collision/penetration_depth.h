// Stage 2: consistent penetration depth (Heidelberger et al. 2004) and the contact triangle of
// every colliding vertex (algorithms.md section 2; choices in docs/penetration-depth.md).
//
// Design note. Colliding vertices are grouped by (colliding body, penetrated body); each group is
// solved on its own, so "colliding" below means "inside the same penetrated body". Per group:
// border points (a colliding vertex with a non-colliding tet-edge neighbour) intersect each such
// edge with the penetrated body's surface (a SurfaceBvh, refitted once per step per penetrated
// body) and keep the hit nearest the non-colliding end (one fan query per border point for all its
// edges); depth and direction are the 1/|x_i - p|^2 weighted means of Heidelberger eq. (2)/(3)
// with smoothed (interpolated vertex) normals. Inner
// points get theirs layer by layer from points of earlier layers only (eq. (4)/(5)). Points no
// layer reaches (a body enclosed by another, or a colliding island without border) take depth and
// direction from the nearest point of the penetrated surface (beyond the paper). The contact
// triangle is the first surface triangle hit by the ray x + t r, t >= 0; if the direction vanished
// or the ray misses, the nearest surface triangle; its search is bounded by the ray's parameter on
// the triangle of the point's nearest edge hit (a hint: same answer, fewer nodes). Vertex normals
// are computed on demand per group into a compact scratch (VertexNormalScratch). Scratch buffers
// are members and only grow. Session 22 (threads): the groups are solved penetrated body by
// penetrated body, in chunks of penetrated bodies with a scratch each, so with an executor a
// surface is only ever touched by one chunk; a group's result does not depend on the order, and the
// counters are summed afterwards: the serial result bit for bit.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sim/collision/contact_types.h"
#include "sim/collision/surface_bvh.h"
#include "sim/collision/tet_walk.h"
#include "sim/collision/vertex_normal_scratch.h"
#include "sim/parallel/task_executor.h"

namespace pliant {

/// How stage 2 finds where border edges and contact rays meet the penetrated surface.
enum class SurfaceQueryMethod {
  bvh,             ///< SurfaceBvh queries for edges and contact rays
  tet_walk_rays,   ///< contact rays by a tet walk (the same answer: the first crossing from p), edges by the BVH
  tet_walk,        ///< edges and contact rays by a tet walk; an edge that leaves and re-enters the
                   ///< penetrated body gets the crossing nearest p, not the paper's nearest q
};

/// Tuning of stage 2.
struct PenetrationDepthOptions {
  /// Edge and contact-ray queries (docs/penetration-depth.md, "Tet walk"). Self-collision groups
  /// always use the BVH. With tet_walk the surface hierarchy is only brought up to date when a query
  /// needs it (a failed walk, an enclosed point). A walk that fails falls back to the BVH.
  SurfaceQueryMethod surface_query = SurfaceQueryMethod::tet_walk_rays;
  /// A walk crossing more tets than this fails (the BVH answers instead).
  int tet_walk_max_steps = 256;
  /// Diagnostic: with tet_walk, also run the BVH query for every walked edge and ray and count the
  /// answers that differ (stats().walk_mismatches); the walk's answers are kept.
  bool tet_walk_verify = false;
  /// A penetrated body's surface hierarchy is rebuilt instead of its bvh_rebuild_interval-th full
  /// refit (1: every full update is a rebuild).
  int bvh_rebuild_interval = 16;
  /// While no surface vertex moved more than this many mean edge lengths since the hierarchy's
  /// boxes were fitted, a step only inflates them and refits the leaves queries reach (0: a full
  /// refit whenever anything moved). See SurfaceBvh.
  double bvh_lazy_refit_edges = 0.25;
};

/// What the last compute() did (for tests, benchmarks and diagnostics).
struct PenetrationDepthStats {
  int border_points = 0;            ///< depth from edge intersections (layer 0)
  int propagated_points = 0;        ///< depth propagated from earlier layers
  int enclosed_fallback_points = 0; ///< depth from the nearest surface point
  int direction_fallbacks = 0;      ///< r vanished: nearest hit's / neighbour's direction used
  int clamped_negative_depths = 0;  ///< weighted means below zero, clamped to d = 0
  int ray_misses = 0;               ///< contact triangle from the nearest-point fallback
  int dropped = 0;                  ///< no eligible surface triangle at all: no entry in `out`
  long long edge_intersections = 0; ///< border edges intersected with the surface
  int max_layer = 0;                ///< deepest propagation layer reached
  int surfaces_unchanged = 0;       ///< penetrated surfaces whose positions did not change
  int surfaces_lazy = 0;            ///< ... whose hierarchy only inflated its boxes (lazy refit)
  int surfaces_refitted = 0;        ///< ... whose hierarchy was refitted in full
  int surfaces_built = 0;           ///< ... whose hierarchy was (re)built
  long long walked_edges = 0;       ///< border edges answered by a tet walk
  long long walk_edge_fallbacks = 0;///< border edges whose walk failed (answered by the BVH)
  int walked_rays = 0;              ///< contact rays answered by a tet walk
  int walk_ray_fallbacks = 0;       ///< contact rays whose walk failed (answered by the BVH)
  long long walk_mismatches = 0;    ///< tet_walk_verify: walked answers (triangle or t) unlike the BVH's
  long long walk_tets = 0;          ///< tets visited by all walks (edges and rays)
  int enclosed_ray_overshoots = 0;  ///< enclosed points whose ray slipped past their nearest point (session 19)
};

class PenetrationDepthSolver {
 public:
  PenetrationDepthSolver() = default;
  /// A solver with non-default tuning.
  explicit PenetrationDepthSolver(const PenetrationDepthOptions& options) : options_(options) {}

  /// Depth, direction and contact triangle for every colliding vertex in `colliding`.
  /// `out` is cleared first and gets one entry per colliding vertex (same order), except vertices
  /// for which no contact triangle exists at all (documented in docs/penetration-depth.md).
  /// With an `executor` of two or more threads, chunks of penetrated bodies are solved side by side;
  /// the result and the counters are the serial run's, bit for bit.
  void compute(std::span<const CollisionBody> bodies, std::span<const VertexInTet> colliding,
               std::vector<VertexContact>& out, TaskExecutor* executor = nullptr);

  /// Counters of the last compute().
  const PenetrationDepthStats& stats() const { return stats_; }

 private:
  /// The penetrated body's surface at this step: its hierarchy.
  struct Surface {
    const TetMesh* mesh = nullptr;    ///< the penetrated body's mesh and positions at this call
    std::span<const Vec3> x;
    std::uint64_t bvh_in_call = 0;    ///< call counter value when bvh was last brought to x
    SurfaceBvh bvh;
    std::uint64_t built_in_call = 0;  ///< call counter value when last brought to this call's positions
    int refits = 0;                   ///< full refits since the last build
    TetFacePlanes planes;             ///< tet_walk: face normals of the tets walked in this call
  };

  /// One chunk's scratch (of penetrated bodies; one chunk: the serial pass). Buffers only grow.
  struct GroupScratch {
    PenetrationDepthStats stats;             ///< the chunk's counters, summed into stats_ afterwards
    VertexNormalScratch normals;             ///< vertex normals of the group's penetrated surface
    std::vector<std::uint32_t> vertex_stamp;  ///< per vertex of the colliding body: group stamp
    std::vector<int> vertex_slot;            ///< per vertex: index into the group (if stamped)
    std::uint32_t group_stamp = 0;
    std::vector<int> layer;                  ///< per group entry: -1 unprocessed, else layer
    std::vector<int> frontier, next;         ///< propagation fronts (group entry indices)
    std::vector<int> hint;                   ///< per group entry: a surface triangle its ray likely hits
    std::vector<Vec3> fan_origins;           ///< a border point's non-colliding neighbours (positions)
    std::vector<int> fan_exclude;            ///< their vertex indices in self-collision, else -1
    std::vector<SurfacePoint> fan_hits;      ///< first hit of each edge from the neighbour
    std::vector<char> fan_found;             ///< the edge crosses the surface
    std::vector<int> fan_failed;             ///< walk mode: fan entries whose walk failed
    std::vector<Vec3> fallback_origins;      ///< ... their origins, excludes, hits (BVH query)
    std::vector<int> fallback_exclude;
    std::vector<SurfacePoint> fallback_hits;
    std::vector<char> fallback_found;
  };

  /// The penetrated body's surface at this call; its hierarchy brought up to date if `need_bvh`.
  Surface& surface_of(std::span<const CollisionBody> bodies, int body, bool need_bvh, PenetrationDepthStats& stats);
  /// Brings the surface's hierarchy to this call's positions (once per call).
  void ensure_bvh(Surface& surface, PenetrationDepthStats& stats);
  /// Fan query for the border point p: the walk where it succeeds, the BVH for the rest.
  void walk_fan(Surface& surface, const VertexInTet& c, const Vec3& p, GroupScratch& g);
  /// One group (colliding body, penetrated body): its entries of results_ and has_result_.
  void solve_group(std::span<const CollisionBody> bodies, std::span<const VertexInTet> colliding,
                   std::span<const int> group, GroupScratch& g);
  /// Interpolated vertex normal at a hit of the group's penetrated surface (g.normals holds its
  /// vertex normals).
  static Vec3 smoothed_normal(const Surface& surface, const SurfacePoint& hit, GroupScratch& g);

  PenetrationDepthOptions options_;
  PenetrationDepthStats stats_;
  std::uint64_t call_ = 0;
  std::vector<Surface> surfaces_;             ///< per body index
  std::vector<int> order_;                    ///< colliding entries sorted by group
  std::vector<VertexContact> results_;        ///< per colliding entry
  std::vector<char> has_result_;              ///< per colliding entry: a contact triangle exists
  std::vector<int> group_begin_;              ///< per group (and one past the last): its first entry in order_
  std::vector<int> by_surface_;               ///< group indices by (penetrated body, group)
  std::vector<int> surface_begin_;            ///< per penetrated body in by_surface_ (and one past): its first group there
  std::vector<int> surface_fill_;      ///< the counting sort's next free place per penetrated body
  std::vector<GroupScratch> scratch_;         ///< one per chunk
};

}  // namespace pliant
