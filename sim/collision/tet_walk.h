// Tet walk: the point where a segment or ray that starts inside a body leaves it, found by walking
// the body's tetrahedra from one that contains the start, face to face, to a boundary face
// (docs/penetration-depth.md, "Tet walk"). O(tets crossed), no surface hierarchy.
//
// Design note. Face k of a tet (opposite its vertex k, TetMesh::kTetFaceCorners, outward) has the
// outward normal n_k = (x_j - x_i) x (x_l - x_i). Along a + s d the side function
// f_k(s) = n_k.(a - x_i) + s n_k.d grows through face k where n_k.d > 0, and the line leaves the tet
// at the smallest such root s_k = -n_k.(a - x_i) / n_k.d (ties: the smaller k), never before the
// parameter at which it entered (clamped, so s never decreases); the face it entered by is skipped.
// Session 20: a surface face within a rounding margin of that root is taken instead (a line leaving
// through a surface vertex or edge ties faces there, and rounding could pick an interior one and
// walk on through the body).
// A tet whose signed volume is not clearly positive (flat or inverted by the deformation), a tet
// with no face to leave by, or more than `max_steps` tets end the walk as failed: callers then use
// the exact surface query (SurfaceBvh). The hit itself is computed as SurfaceBvh computes it
// (Moller-Trumbore on the exit triangle, same origin and direction, so bit for bit the same when the
// same triangle is hit); where the crossing lies within 1e-9 (barycentric) of the exit triangle's
// border, every surface triangle sharing a corner with it is tested and the smallest (t, triangle
// index) kept, the BVH's tie rule. Where a segment leaves and re-enters the body, the walk finds the
// crossing nearest its start, the BVH's segment query the one nearest the segment's origin.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "sim/collision/surface_bvh.h"
#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// How a walk ended.
enum class TetWalkResult {
  exited,      ///< left the body through a boundary face (TetWalkExit filled)
  beyond_end,  ///< still inside the body at s = s_max (the segment ends inside)
  failed,      ///< flat/inverted tet, no exit face, or the step cap: use the exact query
};

/// Where a walk left the body.
struct TetWalkExit {
  int triangle = -1;  ///< surface triangle of the exit face
  int tet = -1;       ///< tet the exit face belongs to
  double s = 0.0;     ///< line parameter of the exit: a + s d
  int steps = 0;      ///< tets visited
};

/// The four outward face normals of each tet a walk entered at one pose, computed the first time a
/// walk enters the tet and reused by later walks of the same pose (a border point's edges and its
/// contact ray all start in its stage-1 tet). Same values as computing them per visit, so a walk
/// with the cache is bit for bit a walk without it.
class TetFacePlanes {
 public:
  /// Forgets every tet's normals (the positions changed) and sizes the cache for `tet_count` tets.
  void new_pose(int tet_count);

  /// Tet `tet`'s face normals (TetMesh::kTetFaceCorners order, outward, twice the face area) and
  /// whether its volume is clearly positive, computed at positions x if not yet in this pose.
  struct Tet {
    std::array<Vec3, 4> normal;  ///< outward normal of the face opposite local vertex k (m^2, x 2)
    bool usable = false;         ///< signed volume clearly positive (else the walk fails there)
  };
  const Tet& tet(const TetMesh& mesh, std::span<const Vec3> x, int tet);

 private:
  std::vector<Tet> tets_;
  std::vector<std::uint32_t> stamp_;  ///< per tet: pose_ when tets_ was filled
  std::uint32_t pose_ = 0;
};

/// Walks a + s d, s in [0, s_max], from tet `start` (which should contain a, up to rounding) to the
/// boundary face through which it leaves the body with positions x. With `planes` (brought to this
/// pose by the caller) the tets' face normals are reused across walks; the answer is the same.
TetWalkResult walk_to_surface(const TetMesh& mesh, std::span<const Vec3> x, int start, const Vec3& a,
                              const Vec3& d, double s_max, int max_steps, TetWalkExit& exit,
                              TetFacePlanes* planes = nullptr);

/// The crossing of surface triangle `triangle` (or, near its border, of the triangles sharing a
/// corner with it) by origin + t dir, t in [0, t_max], as SurfaceBvh::first_ray_hit reports it
/// (smallest t, then smallest index); false if none of them is crossed.
bool surface_hit_near(const TetMesh& mesh, std::span<const Vec3> x, int triangle, const Vec3& origin,
                      const Vec3& dir, double t_max, SurfacePoint& hit);

/// The hit of the edge p -> q (p inside tet `tet_of_p` of the body, q outside) with the body's
/// surface, found by walking from p, reported as SurfaceBvh::first_segment_hits reports the segment
/// q -> p (origin q, t in [0, 1]). False: the walk failed or found no crossing (use the BVH).
bool walk_edge_hit(const TetMesh& mesh, std::span<const Vec3> x, int tet_of_p, const Vec3& p, const Vec3& q,
                   int max_steps, SurfacePoint& hit, int* steps = nullptr, TetFacePlanes* planes = nullptr);

/// The first surface triangle hit by p + t r, t >= 0 (p inside tet `tet_of_p`), as
/// SurfaceBvh::first_ray_hit reports it. False: the walk failed (use the BVH).
bool walk_ray_hit(const TetMesh& mesh, std::span<const Vec3> x, int tet_of_p, const Vec3& p, const Vec3& r,
                  int max_steps, SurfacePoint& hit, int* steps = nullptr, TetFacePlanes* planes = nullptr);

}  // namespace pliant
