// The tet walk (sim/collision/tet_walk.h) against the surface BVH's exact queries and brute force
// over all surface triangles, on many random segments and rays in a jittered box, a sphere, a
// cylinder, a bent (non-convex) bar and an unjittered box with segments along its grid lines
// (through tet edges and vertices). Where a segment crosses the surface once, the walk reports the
// BVH's hit (triangle and point to 1e-12); where it crosses more than once, the crossing nearest its
// start; rays always the BVH's first hit. Failed walks (the caller's fallbacks) are counted and bounded.
// Walks with the per-pose face-plane cache (TetFacePlanes) are bit for bit the walks without it, and a
// pose change without new_pose() is seen (the check is sensitive to stale normals).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "sim/collision/surface_bvh.h"
#include "sim/collision/tet_barycentric.h"
#include "sim/collision/tet_walk.h"
#include "sim/mesh/box_mesh.h"
#include "sim/mesh/cylinder_mesh.h"
#include "sim/mesh/sphere_mesh.h"

namespace pliant {
namespace {

struct Body {
  TetMeshPtr mesh;
  std::vector<Vec3> x;
};

Body jittered_box(unsigned seed) {
  Body b{make_box_mesh({Vec3(1.0, 0.8, 0.6), 5, 4, 3}), {}};
  b.x = b.mesh->rest_positions();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.04, 0.04);
  for (int v = 0; v < b.mesh->vertex_count(); ++v) {
    if (!b.mesh->is_surface_vertex(v)) b.x[static_cast<size_t>(v)] += Vec3(u(rng), u(rng), u(rng));
  }
  return b;
}

// A 4 x 0.5 x 0.5 bar bent into a half ring of mean radius 1 (concave on its inner side).
Body bent_bar() {
  Body b{make_box_mesh({Vec3(4.0, 0.5, 0.5), 16, 2, 2}), {}};
  for (const Vec3& p : b.mesh->rest_positions()) {
    const double theta = (p.x() / 4.0) * std::numbers::pi;  // -pi/2 .. pi/2
    const double r = 1.0 + p.z();
    b.x.emplace_back(r * std::sin(theta), p.y(), r * std::cos(theta));
  }
  return b;
}

// Tet containing p (brute force), -1 if none.
int containing_tet(const Body& b, const Vec3& p) {
  for (int t = 0; t < b.mesh->tet_count(); ++t) {
    const auto& v = b.mesh->tets()[static_cast<size_t>(t)];
    const auto f = TetBarycentricFrame::of(b.x[static_cast<size_t>(v[0])], b.x[static_cast<size_t>(v[1])],
                                           b.x[static_cast<size_t>(v[2])], b.x[static_cast<size_t>(v[3])]);
    if (f.contains(p)) return t;
  }
  return -1;
}

// Parameters t (from origin) of all surface crossings of origin + t dir, t in [0, t_max], brute force.
std::vector<double> crossings(const Body& b, const Vec3& origin, const Vec3& dir, double t_max) {
  std::vector<double> ts;
  for (const auto& tri : b.mesh->surface_triangles()) {
    TriangleHit h;
    if (ray_triangle_intersection(origin, dir, b.x[static_cast<size_t>(tri[0])], b.x[static_cast<size_t>(tri[1])],
                                  b.x[static_cast<size_t>(tri[2])], 0.0, t_max, h)) {
      ts.push_back(h.t);
    }
  }
  std::sort(ts.begin(), ts.end());
  // One crossing through a shared edge or corner is hit on several triangles: merge.
  std::vector<double> distinct;
  for (double t : ts) {
    if (distinct.empty() || t - distinct.back() > 1e-9) distinct.push_back(t);
  }
  return distinct;
}

struct Counts {
  int single = 0, multiple = 0, rays = 0, failed_edges = 0, failed_rays = 0, max_steps = 0;
};

// Random points inside random tets; segments to random outside points and random rays.
Counts check_body(const Body& b, unsigned seed, int samples, bool axis_aligned = false) {
  SurfaceBvh bvh;
  bvh.build(*b.mesh, b.x);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double h = b.mesh->mean_edge_length();
  Counts c;
  for (int i = 0; i < samples; ++i) {
    int tet = std::uniform_int_distribution<int>(0, b.mesh->tet_count() - 1)(rng);
    const auto& v = b.mesh->tets()[static_cast<size_t>(tet)];
    Vec3 p = Vec3::Zero();
    Vec3 dir;
    if (axis_aligned) {
      // An interior grid vertex, or a point a quarter cell from it along a grid axis, and a ray
      // along a grid axis: through tet vertices, edges and faces all the way out.
      int vertex = -1;
      while (vertex < 0 || b.mesh->is_surface_vertex(vertex)) {
        vertex = std::uniform_int_distribution<int>(0, b.mesh->vertex_count() - 1)(rng);
      }
      p = b.x[static_cast<size_t>(vertex)];
      const int offset_axis = std::uniform_int_distribution<int>(-1, 2)(rng);
      if (offset_axis >= 0) p[offset_axis] += 0.25 * h;
      tet = containing_tet(b, p);
      dir = Vec3::Zero();
      dir[std::uniform_int_distribution<int>(0, 2)(rng)] = u01(rng) < 0.5 ? -1.0 : 1.0;
    } else {
      double w[4], sum = 0.0;
      for (double& wk : w) sum += (wk = -std::log(1.0 - u01(rng)));  // uniform in the tet
      for (int k = 0; k < 4; ++k) p += (w[k] / sum) * b.x[static_cast<size_t>(v[static_cast<size_t>(k)])];
      dir = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
    }
    if (tet < 0) continue;
    // Ray from p: the walk reports the BVH's first hit.
    SurfacePoint ref, got;
    int steps = 0;
    if (!bvh.first_ray_hit(p, dir, -1, ref)) {
      ADD_FAILURE() << "ray from inside missed";
      continue;
    }
    ++c.rays;
    if (walk_ray_hit(*b.mesh, b.x, tet, p, dir, 1000, got, &steps)) {
      EXPECT_EQ(got.triangle, ref.triangle) << "ray " << i;
      EXPECT_LE((got.point - ref.point).norm(), 1e-12) << "ray " << i;
      EXPECT_LE(std::abs(got.t - ref.t), 1e-12 * (1.0 + ref.t)) << "ray " << i;
      c.max_steps = std::max(c.max_steps, steps);
    } else {
      ++c.failed_rays;
    }
    // Segment p -> q with q outside the body (length 0.3 to 3 mean edges, or to far outside).
    const Vec3 q = p + dir * (u01(rng) < 0.2 ? 10.0 : h * (0.3 + 2.7 * u01(rng)));
    if (containing_tet(b, q) >= 0) continue;
    const std::vector<double> ts = crossings(b, q, p - q, 1.0);
    if (ts.empty()) {
      ADD_FAILURE() << "segment from outside to inside crosses nothing";
      continue;
    }
    const bool walked = walk_edge_hit(*b.mesh, b.x, tet, p, q, 1000, got, &steps);
    if (!walked) {
      ++c.failed_edges;
      continue;
    }
    c.max_steps = std::max(c.max_steps, steps);
    if (ts.size() == 1) {
      ++c.single;
      SurfacePoint fan_hit;
      char found = 0;
      const Vec3 origins[1] = {q};
      const int excl[1] = {-1};
      bvh.first_segment_hits(p, -1, origins, excl, std::span<SurfacePoint>(&fan_hit, 1), std::span<char>(&found, 1));
      if (!found) {
        ADD_FAILURE() << "BVH segment missed";
        continue;
      }
      EXPECT_EQ(got.triangle, fan_hit.triangle) << "segment " << i;
      EXPECT_LE((got.point - fan_hit.point).norm(), 1e-12) << "segment " << i;
      EXPECT_LE((got.barycentric - fan_hit.barycentric).norm(), 1e-12) << "segment " << i;
    } else {
      ++c.multiple;  // the crossing nearest p: the largest t from q
      EXPECT_LE(std::abs(got.t - ts.back()), 1e-9) << "segment " << i;
    }
  }
  return c;
}

void report(const char* name, const Counts& c, int samples) {
  std::printf("%s: %d rays (%d failed), %d single-crossing segments, %d multiple, %d failed edges, max %d tets\n",
              name, c.rays, c.failed_rays, c.single, c.multiple, c.failed_edges, c.max_steps);
  // Failures are only the rounding cases the caller hands to the BVH: bounded at 1%.
  EXPECT_LE(c.failed_rays, samples / 100 + 1);
  EXPECT_LE(c.failed_edges, samples / 100 + 1);
}

// A unit box of one cell whose tet 0 is inverted (its vertex 0 reflected through the opposite
// face's centroid); `inside` = tet 0's centroid before the reflection (m).
Body box_with_tet_0_inverted(Vec3& inside) {
  Body box{make_box_mesh({Vec3(1.0, 1.0, 1.0), 1, 1, 1}), {}};
  box.x = box.mesh->rest_positions();
  const auto& v = box.mesh->tets()[0];
  inside = 0.25 * (box.x[static_cast<size_t>(v[0])] + box.x[static_cast<size_t>(v[1])] +
                   box.x[static_cast<size_t>(v[2])] + box.x[static_cast<size_t>(v[3])]);
  const Vec3 centroid = (box.x[static_cast<size_t>(v[1])] + box.x[static_cast<size_t>(v[2])] +
                         box.x[static_cast<size_t>(v[3])]) / 3.0;
  box.x[static_cast<size_t>(v[0])] = 2.0 * centroid - box.x[static_cast<size_t>(v[0])];
  return box;
}

TEST(TetWalk, JitteredBoxMatchesBvh) {
  for (unsigned seed : {1u, 2u}) {
    const Counts c = check_body(jittered_box(seed), seed, 1500);
    report("jittered box", c, 1500);
    EXPECT_GT(c.single, 500);
  }
}

TEST(TetWalk, SphereAndCylinderMatchBvh) {
  Body sphere{make_sphere_mesh({0.5, 73, 3}), {}};
  sphere.x = sphere.mesh->rest_positions();
  Body cylinder{make_cylinder_mesh({0.5, 1.0, 3, 6}), {}};
  cylinder.x = cylinder.mesh->rest_positions();
  report("sphere", check_body(sphere, 7, 1500), 1500);
  report("cylinder", check_body(cylinder, 8, 1500), 1500);
}

TEST(TetWalk, BentBarReentryGivesTheCrossingNearestTheStart) {
  const Counts c = check_body(bent_bar(), 9, 3000);
  report("bent bar", c, 3000);
  EXPECT_GT(c.multiple, 0);  // the concave side is crossed twice by some segments
}

TEST(TetWalk, GridLinesThroughEdgesAndVertices) {
  Body box{make_box_mesh({Vec3(1.0, 1.0, 1.0), 4, 4, 4}), {}};
  box.x = box.mesh->rest_positions();
  report("aligned box", check_body(box, 11, 800, true), 800);
}

// Walks from random points of random tets along random directions (segments of 0.3-3 mean edges
// and rays), each with and without the face-plane cache; returns how many walks differed in any
// of result, exit triangle, tet, s (bitwise) and steps.
int cache_differences(const Body& b, TetFacePlanes& planes, unsigned seed, int samples) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double h = b.mesh->mean_edge_length();
  int differ = 0;
  for (int i = 0; i < samples; ++i) {
    // Several walks per start tet, as a border point's edges and ray start in one tet.
    const int tet = std::uniform_int_distribution<int>(0, b.mesh->tet_count() - 1)(rng);
    const auto& v = b.mesh->tets()[static_cast<size_t>(tet)];
    Vec3 p = Vec3::Zero();
    double w[4], sum = 0.0;
    for (double& wk : w) sum += (wk = -std::log(1.0 - u01(rng)));
    for (int k = 0; k < 4; ++k) p += (w[k] / sum) * b.x[static_cast<size_t>(v[static_cast<size_t>(k)])];
    for (int j = 0; j < 5; ++j) {
      const Vec3 d =
          Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized() * (j == 4 ? 1.0 : h * (0.3 + 2.7 * u01(rng)));
      const double s_max = j == 4 ? std::numeric_limits<double>::infinity() : 1.0;
      TetWalkExit plain, cached;
      const TetWalkResult r0 = walk_to_surface(*b.mesh, b.x, tet, p, d, s_max, 1000, plain);
      const TetWalkResult r1 = walk_to_surface(*b.mesh, b.x, tet, p, d, s_max, 1000, cached, &planes);
      if (r0 != r1 || plain.triangle != cached.triangle || plain.tet != cached.tet || plain.s != cached.s ||
          plain.steps != cached.steps) {
        ++differ;
      }
    }
  }
  return differ;
}

TEST(TetWalk, FacePlanesCacheGivesTheSameWalksAndIsRenewedPerPose) {
  for (Body b : {jittered_box(3), bent_bar()}) {
    TetFacePlanes planes;
    planes.new_pose(b.mesh->tet_count());
    EXPECT_EQ(cache_differences(b, planes, 21, 600), 0);
    // Reused across a second batch of walks in the same pose (most tets already cached).
    EXPECT_EQ(cache_differences(b, planes, 22, 600), 0);
    // A new pose: every vertex moved by up to 2% of an edge.
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double h = 0.02 * b.mesh->mean_edge_length();
    for (Vec3& xv : b.x) xv += h * Vec3(u(rng), u(rng), u(rng));
    // Sensitivity check: the previous pose's normals do change walks (s differs in its last bits).
    EXPECT_GT(cache_differences(b, planes, 22, 600), 0);
    planes.new_pose(b.mesh->tet_count());
    EXPECT_EQ(cache_differences(b, planes, 22, 600), 0);
    EXPECT_EQ(cache_differences(b, planes, 23, 600), 0);
  }
  // An inverted tet fails with the cache too.
  Vec3 p;
  const Body box = box_with_tet_0_inverted(p);
  TetFacePlanes planes;
  planes.new_pose(box.mesh->tet_count());
  TetWalkExit exit;
  EXPECT_EQ(walk_to_surface(*box.mesh, box.x, 0, p, Vec3(1, 0, 0), 10.0, 100, exit, &planes),
            TetWalkResult::failed);
}

TEST(TetWalk, InvertedTetFailsInsteadOfAnsweringWrongly) {
  Vec3 p;
  Body box = box_with_tet_0_inverted(p);
  TetWalkExit exit;
  EXPECT_EQ(walk_to_surface(*box.mesh, box.x, 0, p, Vec3(1, 0, 0), 10.0, 100, exit), TetWalkResult::failed);
  // Flat tet: all four corners on one plane (vertex 0 at the opposite face's centroid).
  const auto& v = box.mesh->tets()[0];
  box.x[static_cast<size_t>(v[0])] = (box.x[static_cast<size_t>(v[1])] + box.x[static_cast<size_t>(v[2])] +
                                      box.x[static_cast<size_t>(v[3])]) / 3.0;
  EXPECT_EQ(walk_to_surface(*box.mesh, box.x, 0, p, Vec3(1, 0, 0), 10.0, 100, exit), TetWalkResult::failed);
}

TEST(TetWalk, StepCapAndSegmentEndingInside) {
  Body box{make_box_mesh({Vec3(1.0, 1.0, 1.0), 8, 8, 8}), {}};
  box.x = box.mesh->rest_positions();
  const Vec3 p(0.01, 0.02, 0.03);
  const int tet = containing_tet(box, p);
  ASSERT_GE(tet, 0);
  TetWalkExit exit;
  EXPECT_EQ(walk_to_surface(*box.mesh, box.x, tet, p, Vec3(1, 0, 0), 10.0, 2, exit), TetWalkResult::failed);
  EXPECT_EQ(walk_to_surface(*box.mesh, box.x, tet, p, Vec3(0.1, 0, 0), 1.0, 100, exit), TetWalkResult::beyond_end);
  ASSERT_EQ(walk_to_surface(*box.mesh, box.x, tet, p, Vec3(1, 0, 0), 10.0, 100, exit), TetWalkResult::exited);
  EXPECT_NEAR(exit.s, 0.49, 1e-12);  // the face x = 0.5
}

}  // namespace
}  // namespace pliant
