// What collision detection (stage 1) and penetration depth (stage 2) hand to the response stages.
#pragma once

#include <algorithm>
#include <span>
#include <vector>

#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

/// Stage 1: a vertex of one body inside a tetrahedron of another body (or of itself).
struct VertexInTet {
  int body = -1;              ///< body index of the colliding vertex
  int vertex = -1;            ///< vertex index in that body
  int penetrated_body = -1;   ///< body index owning the tetrahedron
  int tet = -1;               ///< tetrahedron index in the penetrated body
  Vec4 barycentric = Vec4::Zero();  ///< vertex position in the tet's barycentric coordinates
};

/// How a colliding vertex got its penetration depth.
enum class DepthSource {
  border,             ///< border point: from intersections of its outgoing edges (Heidelberger)
  propagated,         ///< inner point: propagated layer by layer from border points
  enclosed_fallback,  ///< no border point reached it: nearest point on the penetrated surface
};

/// How a colliding vertex got its contact triangle.
enum class ContactTriangleSource {
  ray,                    ///< first surface triangle hit by the ray x + t r, t >= 0
  nearest_point_fallback, ///< direction vanished or the ray missed: closest surface triangle
};

/// Stage 2: one colliding vertex with its consistent penetration depth and contact triangle.
struct VertexContact {
  int body = -1;
  int vertex = -1;
  int penetrated_body = -1;
  int tet = -1;

  double penetration_depth = 0.0;         ///< d (m), >= 0
  Vec3 penetration_direction = Vec3::Zero();  ///< r, unit, out of the penetrated body
  DepthSource depth_source = DepthSource::border;
  int layer = 0;                          ///< propagation layer (0 = border)

  int contact_triangle = -1;              ///< surface triangle index in the penetrated body's mesh
  Vec3 contact_barycentric = Vec3::Zero();  ///< hit point in that triangle's barycentric coordinates
  Vec3 contact_point = Vec3::Zero();      ///< the hit point itself (m)
  ContactTriangleSource triangle_source = ContactTriangleSource::ray;

  /// d r: moving the vertex by this takes it to the penetrated body's surface.
  Vec3 depth_vector() const { return penetration_depth * penetration_direction; }
};

/// What collision detection needs to know about one body.
struct CollisionBody {
  const TetMesh* mesh = nullptr;
  std::span<const Vec3> positions;
  bool active = true;           ///< false: skipped entirely (removed, asleep with all partners)
  bool self_collision = false;  ///< look for this body's vertices inside its own tets
  unsigned collision_group = 1u;   ///< bit(s) this body belongs to
  unsigned collision_mask = ~0u;   ///< groups this body may touch
  /// A rigid body's pose (a kinematic instrument): positions are pose applied to the rest mesh, so
  /// detection may locate points among its tets in the rest frame (SpatialHash, RigidTetGrid).
  const Pose* rigid_pose = nullptr;
};

/// Which body pairs may touch, decided once per step by the world (groups, masks, explicit
/// exclusions, sleeping). The diagonal says whether a body self-collides.
class CollisionFilter {
 public:
  CollisionFilter() = default;
  explicit CollisionFilter(int body_count)
      : n_(body_count), allowed_(static_cast<size_t>(body_count * body_count), 0) {}
  int body_count() const { return n_; }
  bool allowed(int a, int b) const { return allowed_[static_cast<size_t>(a * n_ + b)] != 0; }
  /// The first body b >= from with allowed(a, b), or body_count() if there is none (a scan of row a,
  /// for callers that need one allowed partner, not all of them). allowed is symmetric (set writes both).
  int next_allowed(int a, int from) const {
    const auto row = allowed_.begin() + static_cast<std::ptrdiff_t>(a) * n_;
    return static_cast<int>(std::find(row + from, row + n_, char{1}) - row);
  }
  void set(int a, int b, bool allowed) {
    allowed_[static_cast<size_t>(a * n_ + b)] = allowed ? 1 : 0;
    allowed_[static_cast<size_t>(b * n_ + a)] = allowed ? 1 : 0;
  }
  /// Filter from bodies' active flags, groups and masks and self-collision flags.
  static CollisionFilter from_bodies(std::span<const CollisionBody> bodies) {
    CollisionFilter f;
    f.assign_from_bodies(bodies);
    return f;
  }
  /// Same as `*this = from_bodies(bodies)`, reusing this filter's storage (no allocation once it has
  /// held as many bodies): the world rebuilds its filter every step.
  void assign_from_bodies(std::span<const CollisionBody> bodies) {
    n_ = static_cast<int>(bodies.size());
    allowed_.assign(static_cast<size_t>(n_ * n_), 0);
    for (int a = 0; a < n_; ++a) {
      const auto& ba = bodies[static_cast<size_t>(a)];
      for (int b = a; b < n_; ++b) {
        const auto& bb = bodies[static_cast<size_t>(b)];
        bool ok = ba.active && bb.active;
        if (a == b) {
          ok = ok && ba.self_collision;
        } else {
          ok = ok && (ba.collision_group & bb.collision_mask) != 0u &&
               (bb.collision_group & ba.collision_mask) != 0u;
        }
        set(a, b, ok);
      }
    }
  }

 private:
  int n_ = 0;
  std::vector<char> allowed_;
};

}  // namespace pliant
