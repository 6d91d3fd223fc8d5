// Consistent penetration depth (Heidelberger et al. 2004) against closed forms: a box and a ball
// pushed into a block's face (exact distance to the face plane at every layer), a box enclosed in a
// block (nearest-face distance, the fallback beyond the paper), a ball pressed across a block's edge
// (bounded error), and continuity of the depth vectors under small motions.
#include <gtest/gtest.h>

// This file replaces the global operator new/delete with malloc/free to count allocations; GCC's
// mismatched-new-delete check cannot see that both sides are replaced.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <map>
#include <new>
#include <random>

#include "sim/collision/penetration_depth.h"
#include "sim/collision/spatial_hash.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

std::vector<Vec3> posed(const std::vector<Vec3>& rest, const Quat& r, const Vec3& t) {
  std::vector<Vec3> x;
  for (const Vec3& p : rest) x.push_back(r * p + t);
  return x;
}

// A box mesh mapped onto a ball of radius `radius` (each point scaled by |p|_inf / |p|_2).
std::vector<Vec3> ball_positions(const TetMesh& cube, double radius) {
  std::vector<Vec3> x;
  const double half = cube.rest_bounds().extent().maxCoeff() / 2;
  for (const Vec3& p : cube.rest_positions()) {
    const double n2 = p.norm();
    x.push_back(n2 > 0.0 ? Vec3(p * (p.cwiseAbs().maxCoeff() / n2) * (radius / half)) : p);
  }
  return x;
}

// Two bodies: 0 = the probe (box or ball), 1 = a block [-1,1]^3 with 8^3 cells.
struct Scene {
  TetMeshPtr probe_mesh;
  TetMeshPtr block_mesh = make_box_mesh({Vec3(2.0, 2.0, 2.0), 8, 8, 8});
  std::vector<Vec3> probe_x;
  std::vector<Vec3> block_x = block_mesh->rest_positions();
  std::vector<VertexInTet> colliding;
  std::vector<VertexContact> contacts;
  SpatialHash hash;
  PenetrationDepthSolver solver;

  void run() {
    std::vector<CollisionBody> bodies(2);
    bodies[0].mesh = probe_mesh.get();
    bodies[0].positions = probe_x;
    bodies[1].mesh = block_mesh.get();
    bodies[1].positions = block_x;
    CollisionFilter filter = CollisionFilter::from_bodies(bodies);
    hash.detect(bodies, filter, colliding);
    // Only the probe's vertices in the block are of interest here.
    std::erase_if(colliding, [](const VertexInTet& c) { return c.body != 0; });
    solver.compute(bodies, colliding, contacts);
  }
};

TEST(PenetrationDepth, BoxInBlockFaceIsExactAtEveryLayer) {
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.6, 0.6, 0.6), 6, 6, 6});
  const Quat tilt(Eigen::AngleAxisd(0.2, Vec3(1, 1, 0).normalized()));
  s.probe_x = posed(s.probe_mesh->rest_positions(), tilt, Vec3(0.05, 0.03, 1.0 + 0.3 - 0.45));
  s.run();
  ASSERT_GT(s.contacts.size(), 50u);
  ASSERT_EQ(s.contacts.size(), s.colliding.size());
  int max_layer = 0;
  for (const auto& c : s.contacts) {
    const Vec3& p = s.probe_x[static_cast<size_t>(c.vertex)];
    const double exact = 1.0 - p.z();
    EXPECT_NEAR(c.penetration_depth, exact, 1e-9 * exact + 1e-13) << "layer " << c.layer;
    EXPECT_NEAR((c.penetration_direction - Vec3::UnitZ()).norm(), 0.0, 1e-12);
    EXPECT_NE(c.depth_source, DepthSource::enclosed_fallback);
    max_layer = std::max(max_layer, c.layer);
  }
  EXPECT_GE(max_layer, 3);
  EXPECT_EQ(s.solver.stats().border_points + s.solver.stats().propagated_points,
            static_cast<int>(s.contacts.size()));
}

TEST(PenetrationDepth, BallInBlockFaceMatchesDistanceToFace) {
  // Tolerance: 1e-9 relative. For a planar penetrated face eq. (2)-(5) are exact (algorithms.md,
  // section 2), so the only error left is rounding.
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.6, 0.6, 0.6), 8, 8, 8});
  const auto ball = ball_positions(*s.probe_mesh, 0.3);
  s.probe_x = posed(ball, Quat(Eigen::AngleAxisd(0.4, Vec3(1, 2, 3).normalized())), Vec3(-0.1, 0.2, 1.0 + 0.3 - 0.2));
  s.run();
  ASSERT_GT(s.contacts.size(), 30u);
  for (const auto& c : s.contacts) {
    const double exact = 1.0 - s.probe_x[static_cast<size_t>(c.vertex)].z();
    EXPECT_NEAR(c.penetration_depth, exact, 1e-9 * exact + 1e-13);
    EXPECT_NEAR((c.penetration_direction - Vec3::UnitZ()).norm(), 0.0, 1e-12);
  }
}

TEST(PenetrationDepth, BallAcrossBlockEdgeIsWithinStatedTolerance) {
  // Near the block's edge x = 1, z = 1 the smoothed normals blend the two faces, so the estimate is
  // approximate. Stated tolerance: |d - exact| <= 0.5 * block cell size (0.25 m) * 0.5 = 0.0625 m,
  // where exact = distance to the block surface = min(1 - x, 1 - z) for a point inside.
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.6, 0.6, 0.6), 8, 8, 8});
  const auto ball = ball_positions(*s.probe_mesh, 0.3);
  s.probe_x = posed(ball, Quat::Identity(), Vec3(1.0 + 0.3 - 0.2, 0.1, 1.0 + 0.3 - 0.2));
  s.run();
  ASSERT_GT(s.contacts.size(), 5u);
  double worst = 0.0;
  for (const auto& c : s.contacts) {
    const Vec3& p = s.probe_x[static_cast<size_t>(c.vertex)];
    const double exact = std::min(1.0 - p.x(), 1.0 - p.z());
    worst = std::max(worst, std::abs(c.penetration_depth - exact));
    EXPECT_NEAR(c.penetration_depth, exact, 0.0625);
    // Out of the block: a direction between the two face normals.
    EXPECT_GT(c.penetration_direction.x(), -1e-12);
    EXPECT_GT(c.penetration_direction.z(), -1e-12);
  }
  RecordProperty("worst_edge_depth_error_m", std::to_string(worst));
}

TEST(PenetrationDepth, EnclosedBoxUsesNearestSurfacePoint) {
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.4, 0.4, 0.4), 4, 4, 4});
  s.probe_x = posed(s.probe_mesh->rest_positions(), Quat(Eigen::AngleAxisd(0.5, Vec3(3, 1, 2).normalized())),
                    Vec3(0.5, 0.1, -0.2));
  s.run();
  ASSERT_EQ(s.contacts.size(), static_cast<size_t>(s.probe_mesh->vertex_count()));
  EXPECT_EQ(s.solver.stats().border_points, 0);
  EXPECT_EQ(s.solver.stats().enclosed_fallback_points, s.probe_mesh->vertex_count());
  for (const auto& c : s.contacts) {
    const Vec3& p = s.probe_x[static_cast<size_t>(c.vertex)];
    EXPECT_EQ(c.depth_source, DepthSource::enclosed_fallback);
    // Closed form: distance to the nearest of the six faces of [-1,1]^3, along that face's normal.
    double exact = 1e9;
    for (int k = 0; k < 3; ++k) exact = std::min({exact, 1.0 - p[k], 1.0 + p[k]});
    EXPECT_NEAR(c.penetration_depth, exact, 1e-12);
    bool along_a_nearest_face = false;
    for (int k = 0; k < 3; ++k) {
      for (double sign : {-1.0, 1.0}) {
        if (std::abs(1.0 - sign * p[k] - exact) < 1e-12) {
          along_a_nearest_face = along_a_nearest_face ||
                                 (c.penetration_direction - sign * Vec3::Unit(k)).norm() < 1e-9;
        }
      }
    }
    EXPECT_TRUE(along_a_nearest_face) << c.penetration_direction.transpose();
    EXPECT_NEAR((p + c.depth_vector() - c.contact_point).norm(), 0.0, 1e-12);
  }
}

// Session 19: an enclosed point whose nearest surface point is a vertex of the penetrated surface.
// The block's top-face vertex (0, 0, 1) is dented down, so the points right under it are nearer to
// that vertex than to any face, and a small box below it, wholly inside the block, has only
// enclosed-fallback points. The contact triangle is found by the ray x + t r towards the nearest
// point; a ray through a vertex exactly can slip between the triangles around it by rounding and
// leave the body far away (in the probe's slide a probe vertex 3e-5 m inside the tissue got a
// contact triangle on the tissue's bottom face, 31 mm away: a residual overlap of 31 mm in the
// report). Closed form: the contact point is x + d r, the nearest surface point (the dent vertex
// for the box's top corner), over 4,000 random dents and offsets.
// Session 20: the slips are the tet walk's (with the BVH answering the rays: none in 160,000). Where
// the ray leaves through the vertex, faces tie and rounding could send the walk through an interior
// face; its tie rule (tet_walk.cpp) now takes a surface face within a rounding margin: in the first
// 400 trials the one ray that slipped before no longer does. Rays shallower than the dent's walls
// graze the vertex and re-enter the body beyond it: the walk, which follows crossings, goes on
// (the later trials have a few), and the overshoot check keeps their contact point.
TEST(PenetrationDepth, EnclosedPointUnderADentedVertexKeepsItsNearestPoint) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> dent(0.05, 0.2), lateral(-1e-9, 1e-9), gap(1e-9, 1e-3), angle(-0.3, 0.3);
  int checked = 0, at_the_vertex = 0, overshoots = 0, overshoots_first_400 = 0;
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.02, 0.02, 0.02), 1, 1, 1});
  int top = -1;
  for (int i = 0; i < s.block_mesh->vertex_count(); ++i) {
    if ((s.block_x[static_cast<size_t>(i)] - Vec3(0, 0, 1)).norm() < 1e-12) top = i;
  }
  ASSERT_GE(top, 0);
  for (int trial = 0; trial < 4000; ++trial) {
    s.block_x = s.block_mesh->rest_positions();
    const double delta = dent(rng);
    s.block_x[static_cast<size_t>(top)].z() -= delta;
    const Vec3 corner(lateral(rng), lateral(rng), 1.0 - delta - gap(rng));
    const Quat tilt(Eigen::AngleAxisd(angle(rng), Vec3(1, 0, 0)) * Eigen::AngleAxisd(angle(rng), Vec3(0, 1, 0)));
    // The box hangs from `corner`: its highest corner there, the rest below it.
    s.probe_x = posed(s.probe_mesh->rest_positions(), tilt, Vec3::Zero());
    const Vec3 top_corner = *std::max_element(s.probe_x.begin(), s.probe_x.end(),
                                              [](const Vec3& a, const Vec3& b) { return a.z() < b.z(); });
    for (Vec3& x : s.probe_x) x += corner - top_corner;
    s.run();
    overshoots += s.solver.stats().enclosed_ray_overshoots;
    if (trial < 400) overshoots_first_400 += s.solver.stats().enclosed_ray_overshoots;
    ASSERT_EQ(s.contacts.size(), static_cast<size_t>(s.probe_mesh->vertex_count())) << "trial " << trial;
    for (const auto& c : s.contacts) {
      ASSERT_EQ(c.depth_source, DepthSource::enclosed_fallback);
      const Vec3& p = s.probe_x[static_cast<size_t>(c.vertex)];
      EXPECT_LE((p + c.depth_vector() - c.contact_point).norm(), 1e-9 * (1.0 + c.penetration_depth))
          << "trial " << trial << ", depth " << c.penetration_depth << ", contact point "
          << c.contact_point.transpose() << ", triangle " << c.contact_triangle;
      ++checked;
      if ((c.contact_point - s.block_x[static_cast<size_t>(top)]).norm() < 1e-12) ++at_the_vertex;
    }
  }
  EXPECT_EQ(checked, 4000 * 8);
  EXPECT_EQ(overshoots_first_400, 0);  // the walk's tie rule (one slip there without it)
  EXPECT_GT(overshoots, 0);  // grazing rays did pass their point: the check this test is about
  EXPECT_GT(at_the_vertex, 3000);  // the top corners' nearest point is the dent vertex
  RecordProperty("contacts_at_the_dent_vertex", std::to_string(at_the_vertex));
  RecordProperty("enclosed_ray_overshoots", std::to_string(overshoots));
}

// Largest change of depth vectors between consecutive poses of a sweep of the probe by `step`.
struct SweepChanges {
  double rate_same_set = 0.0;  ///< max |delta(d r)| / |step| over steps where the colliding set is unchanged
  double jump = 0.0;           ///< max |delta(d r)| (m) over steps where the colliding set changes
  int set_changes = 0;         ///< steps where the colliding set changed
};

// Vertices that start colliding count with their previous depth vector taken as zero.
SweepChanges sweep_changes(Scene& s, const std::vector<Vec3>& rest, const Quat& rotation, const Vec3& start,
                           const Vec3& step, int n) {
  SweepChanges out;
  std::map<int, Vec3> previous;
  for (int i = 0; i <= n; ++i) {
    s.probe_x = posed(rest, rotation, start + static_cast<double>(i) * step);
    s.run();
    std::map<int, Vec3> now;
    for (const auto& c : s.contacts) now[c.vertex] = c.depth_vector();
    if (i > 0) {
      bool same_set = now.size() == previous.size();
      double worst = 0.0;
      for (const auto& [v, dv] : now) {
        const auto it = previous.find(v);
        same_set = same_set && it != previous.end();
        worst = std::max(worst, it == previous.end() ? dv.norm() : (dv - it->second).norm());
      }
      for (const auto& [v, dv] : previous) {
        if (now.find(v) == now.end()) worst = std::max(worst, dv.norm());  // stopped colliding
      }
      if (same_set) {
        out.rate_same_set = std::max(out.rate_same_set, worst / step.norm());
      } else {
        out.jump = std::max(out.jump, worst);
        ++out.set_changes;
      }
    }
    previous = std::move(now);
  }
  return out;
}

TEST(PenetrationDepth, DepthVectorsAreContinuousUnderSmallMotions) {
  // Planar face: the depth vector is the exact normal offset, continuous with C = 1 (+1e-6 rounding)
  // even when vertices enter or leave the colliding set (they enter/leave with depth ~ 0).
  constexpr double kEps = 2e-3;
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.6, 0.6, 0.6), 6, 6, 6});
  const Quat tilt(Eigen::AngleAxisd(0.2, Vec3(1, 1, 0).normalized()));
  const auto c = sweep_changes(s, s.probe_mesh->rest_positions(), tilt, Vec3(0.0, 0.0, 1.3),
                               Vec3(0.3, 0.2, -1.0).normalized() * kEps, 150);
  EXPECT_LE(c.rate_same_set, 1.0 + 1e-6);
  EXPECT_LE(c.jump, (1.0 + 1e-6) * kEps);
  EXPECT_GT(c.set_changes, 10);
}

TEST(PenetrationDepth, DepthVectorsArePiecewiseContinuousAcrossAnEdge) {
  // Heidelberger's estimate is continuous while the set of colliding vertices stays the same (C = 4
  // there: smoothed normals turn over one block cell of 0.25 m; measured 2.65). When a vertex enters
  // or leaves the set, border/inner roles of its neighbours change and inner depth vectors jump: the
  // jump does not shrink with the step (a property of the paper's method, docs/penetration-depth.md).
  // Stated bound: 0.5 x block cell = 0.125 m (measured 0.115 m).
  constexpr double kEps = 2e-3;
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.6, 0.6, 0.6), 8, 8, 8});
  const auto ball = ball_positions(*s.probe_mesh, 0.3);
  const auto c = sweep_changes(s, ball, Quat::Identity(), Vec3(0.6, 0.1, 1.15),
                               Vec3(1.0, 0.0, -0.2).normalized() * kEps, 250);
  std::printf("edge sweep: rate while set unchanged %.3f, max jump at set changes %.4f m (%d changes)\n",
              c.rate_same_set, c.jump, c.set_changes);
  EXPECT_LE(c.rate_same_set, 4.0);
  EXPECT_LE(c.jump, 0.125);
}

TEST(PenetrationDepth, OutputOrderAndOneEntryPerPenetratedBody) {
  // The probe sits across two overlapping blocks: vertices inside both get one entry per block.
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.4, 0.4, 0.4), 4, 4, 4});
  s.probe_x = posed(s.probe_mesh->rest_positions(), Quat::Identity(), Vec3(0.9, 0.0, 0.0));
  const auto other = posed(s.block_x, Quat::Identity(), Vec3(1.8, 0.0, 0.05));
  std::vector<CollisionBody> bodies(3);
  bodies[0].mesh = s.probe_mesh.get();
  bodies[0].positions = s.probe_x;
  bodies[1].mesh = s.block_mesh.get();
  bodies[1].positions = s.block_x;
  bodies[2].mesh = s.block_mesh.get();
  bodies[2].positions = other;
  CollisionFilter filter = CollisionFilter::from_bodies(bodies);
  filter.set(1, 2, false);
  s.hash.detect(bodies, filter, s.colliding);
  s.solver.compute(bodies, s.colliding, s.contacts);
  ASSERT_EQ(s.contacts.size(), s.colliding.size());
  int in_both = 0;
  for (size_t i = 0; i < s.contacts.size(); ++i) {
    EXPECT_EQ(s.contacts[i].vertex, s.colliding[i].vertex);
    EXPECT_EQ(s.contacts[i].penetrated_body, s.colliding[i].penetrated_body);
    if (i > 0 && s.contacts[i].vertex == s.contacts[i - 1].vertex) ++in_both;
    EXPECT_GE(s.contacts[i].penetration_depth, 0.0);
    EXPECT_NEAR(s.contacts[i].penetration_direction.norm(), 1.0, 1e-12);
  }
  EXPECT_GT(in_both, 10);
  // Deterministic: a second run gives identical results.
  const auto first = s.contacts;
  s.solver.compute(bodies, s.colliding, s.contacts);
  for (size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(first[i].penetration_depth, s.contacts[i].penetration_depth);
    EXPECT_EQ(first[i].contact_triangle, s.contacts[i].contact_triangle);
  }
}

}  // namespace
}  // namespace pliant

// Counts heap allocations in this test executable (replaces the global operator new).
#include "support/allocation_counter.h"

namespace pliant {
namespace {

TEST(PenetrationDepth, NoAllocationPerStepAfterWarmUp) {
  // 40 steps: refits and (every 16th step) full BVH rebuilds reuse their buffers.
  Scene s;
  s.probe_mesh = make_box_mesh({Vec3(0.6, 0.6, 0.6), 6, 6, 6});
  const auto rest = s.probe_mesh->rest_positions();
  s.probe_x = posed(rest, Quat::Identity(), Vec3(0.0, 0.0, 1.1));
  s.run();
  ASSERT_FALSE(s.contacts.empty());
  s.colliding.reserve(4 * s.colliding.size());
  s.contacts.reserve(4 * s.contacts.size());
  std::vector<CollisionBody> bodies(2);
  bodies[0].mesh = s.probe_mesh.get();
  bodies[0].positions = s.probe_x;
  bodies[1].mesh = s.block_mesh.get();
  bodies[1].positions = s.block_x;
  const CollisionFilter filter = CollisionFilter::from_bodies(bodies);
  // Pass 0 warms up (buffers grow to the largest contact set of the motion); pass 1 repeats the same
  // motion and must not allocate.
  for (int pass = 0; pass < 2; ++pass) {
    for (int step = 0; step < 40; ++step) {
      for (size_t i = 0; i < rest.size(); ++i) {  // same vector, moved in place
        s.probe_x[i] = rest[i] + Vec3(1e-3 * step, 0.0, 1.1 - 2e-3 * step);
      }
      const long long before = testing::g_allocations.load();
      s.hash.detect(bodies, filter, s.colliding);
      s.solver.compute(bodies, s.colliding, s.contacts);
      if (pass == 1) {
        EXPECT_EQ(testing::g_allocations.load(), before) << step;
      }
    }
  }
}

}  // namespace
}  // namespace pliant
