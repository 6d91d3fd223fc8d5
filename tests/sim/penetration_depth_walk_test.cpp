// Stage 2 with the tet walk (PenetrationDepthOptions::surface_query) against the BVH path on the
// same stage-1 input, over several poses: contact rays by the walk give every field of every contact
// bit for bit as the BVH path does; edges and rays by the walk give the same contacts to 1e-12
// wherever no edge leaves and re-enters the penetrated body (counted by tet_walk_verify), with no
// fallback; self-collision groups keep the BVH path exactly; a bent bar pressed into a block
// re-crosses, and the verify counter sees it. Last, the solver's border sums and layer propagation
// (selects and counters since session 11) against Heidelberger's equations written out plainly,
// one edge and one neighbour at a time: every depth, direction, layer and contact bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <map>
#include <set>

#include <cmath>
#include <numbers>
#include <random>

#include "sim/collision/penetration_depth.h"
#include "sim/collision/spatial_hash.h"
#include "sim/collision/surface_bvh.h"
#include "sim/mesh/box_mesh.h"
#include "support/folded_bar.h"
#include "support/inline_two_thread_executor.h"

namespace pliant {
namespace {

struct Scene {
  std::vector<TetMeshPtr> meshes;
  std::vector<std::vector<Vec3>> x;
  std::vector<CollisionBody> bodies() const {
    std::vector<CollisionBody> b(meshes.size());
    for (size_t i = 0; i < meshes.size(); ++i) {
      b[i].mesh = meshes[i].get();
      b[i].positions = x[i];
    }
    return b;
  }
};

// Three tilted boxes overlapping a block and each other; interior vertices jittered (the surfaces
// stay planar, so every body is convex and no edge crosses a surface twice).
Scene overlapping_boxes(unsigned seed) {
  Scene s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  s.meshes.push_back(make_box_mesh({Vec3(2.0, 2.0, 1.0), 8, 8, 4}));
  s.x.push_back(s.meshes[0]->rest_positions());
  for (int i = 0; i < 3; ++i) {
    s.meshes.push_back(make_box_mesh({Vec3(0.6, 0.5, 0.4), 6, 5, 4}));
    const Quat r(Eigen::AngleAxisd(0.4 * u(rng), Vec3(u(rng), u(rng), 1.0).normalized()));
    const Vec3 t(0.5 * i - 0.5, 0.3 * u(rng), 0.5 + 0.1 * u(rng));
    std::vector<Vec3> x;
    const TetMesh& m = *s.meshes.back();
    for (int v = 0; v < m.vertex_count(); ++v) {
      const Vec3 jitter = m.is_surface_vertex(v) ? Vec3::Zero() : Vec3(0.01 * Vec3(u(rng), u(rng), u(rng)));
      x.push_back(r * m.rest_positions()[static_cast<size_t>(v)] + t + jitter);
    }
    s.x.push_back(x);
  }
  return s;
}

void move(Scene& s, double eps, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (size_t b = 1; b < s.x.size(); ++b) {
    const Vec3 shift = eps * Vec3(u(rng), u(rng), -1.0);
    for (Vec3& p : s.x[b]) p += shift;  // rigid: the boxes stay convex
  }
}

bool same_bits(const VertexContact& a, const VertexContact& b) {
  return a.body == b.body && a.vertex == b.vertex && a.penetrated_body == b.penetrated_body && a.tet == b.tet &&
         a.penetration_depth == b.penetration_depth && a.penetration_direction == b.penetration_direction &&
         a.depth_source == b.depth_source && a.layer == b.layer && a.contact_triangle == b.contact_triangle &&
         a.contact_barycentric == b.contact_barycentric && a.contact_point == b.contact_point &&
         a.triangle_source == b.triangle_source;
}

PenetrationDepthOptions with(SurfaceQueryMethod m, bool verify = false) {
  PenetrationDepthOptions o;
  o.surface_query = m;
  o.tet_walk_verify = verify;
  return o;
}

TEST(PenetrationDepthWalk, RaysByTheWalkAreBitIdenticalToTheBvhPath) {
  Scene s = overlapping_boxes(1);
  SpatialHash hash;
  PenetrationDepthSolver bvh(with(SurfaceQueryMethod::bvh)), rays(with(SurfaceQueryMethod::tet_walk_rays));
  std::vector<VertexInTet> colliding;
  std::vector<VertexContact> a, b;
  int walked = 0;
  for (int step = 0; step < 6; ++step) {
    const auto bodies = s.bodies();
    hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
    bvh.compute(bodies, colliding, a);
    rays.compute(bodies, colliding, b);
    ASSERT_GT(a.size(), 100u);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(same_bits(a[i], b[i])) << "step " << step << " contact " << i;
    EXPECT_EQ(rays.stats().walk_ray_fallbacks, 0);
    walked += rays.stats().walked_rays;
    move(s, step % 3 == 2 ? 0.05 : 2e-3, 10u + static_cast<unsigned>(step));
  }
  EXPECT_GT(walked, 600);
}

// Stage 2 in chunks of penetrated bodies (session 22: threads). Each chunk owns its surfaces (their
// hierarchies and walk caches) and its scratch; the counters are summed afterwards. The executor
// runs the chunks inline, last chunk first, so the groups are solved in another order than the
// serial pass's: every contact must still be the serial one bit for bit, with the same counters,
// in every query mode, over steps that move the bodies (lazy refits and rebuilds of the surfaces).
// The folded bar joins the boxes as a fifth body colliding with itself (the BVH path).
TEST(PenetrationDepthWalk, ChunksOfPenetratedBodiesGiveTheSerialResultBitForBit) {
  InlineTwoThreadExecutor executor;
  for (const SurfaceQueryMethod m : {SurfaceQueryMethod::bvh, SurfaceQueryMethod::tet_walk_rays, SurfaceQueryMethod::tet_walk}) {
    SCOPED_TRACE(static_cast<int>(m));
    Scene s = overlapping_boxes(7);
    const FoldedBar bar;
    s.meshes.push_back(bar.mesh);
    s.x.push_back(bar.x);
    for (Vec3& p : s.x.back()) p += Vec3(3.0, 0.0, 0.0);  // away from the boxes
    SpatialHash hash;
    PenetrationDepthSolver serial(with(m)), chunked(with(m));
    std::vector<VertexInTet> colliding;
    std::vector<VertexContact> a, b;
    int self = 0;
    for (int step = 0; step < 6; ++step) {
      SCOPED_TRACE(step);
      std::vector<CollisionBody> bodies = s.bodies();
      bodies.back().self_collision = true;
      hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
      serial.compute(bodies, colliding, a);
      chunked.compute(bodies, colliding, b, &executor);
      ASSERT_GT(a.size(), 100u);
      ASSERT_EQ(a.size(), b.size());
      for (size_t i = 0; i < a.size(); ++i) ASSERT_TRUE(same_bits(a[i], b[i])) << "contact " << i;
      for (const VertexContact& c : a) self += c.body == 4 && c.penetrated_body == 4 ? 1 : 0;
      const PenetrationDepthStats &x = serial.stats(), &y = chunked.stats();
      EXPECT_EQ(y.border_points, x.border_points);
      EXPECT_EQ(y.propagated_points, x.propagated_points);
      EXPECT_EQ(y.enclosed_fallback_points, x.enclosed_fallback_points);
      EXPECT_EQ(y.direction_fallbacks, x.direction_fallbacks);
      EXPECT_EQ(y.clamped_negative_depths, x.clamped_negative_depths);
      EXPECT_EQ(y.ray_misses, x.ray_misses);
      EXPECT_EQ(y.dropped, x.dropped);
      EXPECT_EQ(y.edge_intersections, x.edge_intersections);
      EXPECT_EQ(y.max_layer, x.max_layer);
      EXPECT_EQ(y.surfaces_unchanged, x.surfaces_unchanged);
      EXPECT_EQ(y.surfaces_lazy, x.surfaces_lazy);
      EXPECT_EQ(y.surfaces_refitted, x.surfaces_refitted);
      EXPECT_EQ(y.surfaces_built, x.surfaces_built);
      EXPECT_EQ(y.walked_edges, x.walked_edges);
      EXPECT_EQ(y.walk_edge_fallbacks, x.walk_edge_fallbacks);
      EXPECT_EQ(y.walked_rays, x.walked_rays);
      EXPECT_EQ(y.walk_ray_fallbacks, x.walk_ray_fallbacks);
      EXPECT_EQ(y.walk_tets, x.walk_tets);
      EXPECT_EQ(y.enclosed_ray_overshoots, x.enclosed_ray_overshoots);
      move(s, step % 3 == 2 ? 0.05 : 2e-3, 20u + static_cast<unsigned>(step));
    }
    EXPECT_GT(self, 20);  // the folded bar's self-collision groups took part
  }
}

TEST(PenetrationDepthWalk, EdgesByTheWalkMatchTheBvhWhereNoEdgeRecrosses) {
  Scene s = overlapping_boxes(2);
  SpatialHash hash;
  PenetrationDepthSolver bvh(with(SurfaceQueryMethod::bvh)), walk(with(SurfaceQueryMethod::tet_walk, true));
  std::vector<VertexInTet> colliding;
  std::vector<VertexContact> a, b;
  for (int step = 0; step < 6; ++step) {
    const auto bodies = s.bodies();
    hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
    bvh.compute(bodies, colliding, a);
    walk.compute(bodies, colliding, b);
    ASSERT_EQ(a.size(), b.size());
    const auto& st = walk.stats();
    EXPECT_GT(st.walked_edges, 300);
    EXPECT_EQ(st.walk_edge_fallbacks + st.walk_ray_fallbacks, 0);
    ASSERT_EQ(st.walk_mismatches, 0) << "convex boxes: every edge crosses once";
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].contact_triangle, b[i].contact_triangle);
      EXPECT_NEAR(a[i].penetration_depth, b[i].penetration_depth, 1e-12);
      EXPECT_LE((a[i].penetration_direction - b[i].penetration_direction).norm(), 1e-12);
      EXPECT_LE((a[i].contact_point - b[i].contact_point).norm(), 1e-12);
    }
    move(s, step % 3 == 2 ? 0.05 : 2e-3, 20u + static_cast<unsigned>(step));
  }
}

TEST(PenetrationDepthWalk, SelfCollisionKeepsTheBvhPath) {
  // The folded bar of contact_triangle_test: self-collision groups are solved by the BVH in every mode.
  const FoldedBar bar;
  const std::vector<CollisionBody> bodies = bar.bodies();
  SpatialHash hash;
  std::vector<VertexInTet> colliding;
  hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
  ASSERT_GT(colliding.size(), 20u);
  std::vector<VertexContact> a, b;
  PenetrationDepthSolver bvh(with(SurfaceQueryMethod::bvh)), walk(with(SurfaceQueryMethod::tet_walk));
  bvh.compute(bodies, colliding, a);
  walk.compute(bodies, colliding, b);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(same_bits(a[i], b[i]));
  EXPECT_EQ(walk.stats().walked_edges + walk.stats().walked_rays, 0);
}

TEST(PenetrationDepthWalk, RecrossingEdgesAreCountedAndTakeTheCrossingNearestTheCollidingPoint) {
  // A thin block (0.1 m) bent into a half ring (inner radius 0.5 m) and a coarse box (cell 0.65 m)
  // whose vertex (0.25, 0, 0.47) lies in the ring's wall: its edge to (-0.4, 0, 0.47) leaves the
  // wall inward at x = 0.17, re-enters at x = -0.17 and leaves at x = -0.37. The walk takes the
  // first exit (nearest p), the BVH the last (nearest q, the paper's rule).
  Scene s;
  s.meshes.push_back(make_box_mesh({Vec3(3.0, 1.0, 0.1), 30, 10, 1}));
  std::vector<Vec3> ring;
  for (const Vec3& p : s.meshes[0]->rest_positions()) {
    const double theta = p.x() / 3.0 * std::numbers::pi;
    const double r = 0.55 + p.z();  // inner radius 0.5, outer 0.6
    ring.emplace_back(r * std::sin(theta), p.y(), r * std::cos(theta));
  }
  s.x.push_back(ring);
  s.meshes.push_back(make_box_mesh({Vec3(1.3, 1.3, 1.3), 2, 2, 2}));
  std::vector<Vec3> x;
  for (const Vec3& p : s.meshes[1]->rest_positions()) x.push_back(p + Vec3(0.25, 0.0, 0.47));
  s.x.push_back(x);
  const auto bodies = s.bodies();
  SpatialHash hash;
  std::vector<VertexInTet> colliding;
  hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
  std::erase_if(colliding, [](const VertexInTet& c) { return c.body != 1; });
  ASSERT_GT(colliding.size(), 0u);
  PenetrationDepthSolver walk(with(SurfaceQueryMethod::tet_walk, true));
  std::vector<VertexContact> b;
  walk.compute(bodies, colliding, b);
  EXPECT_EQ(b.size(), colliding.size());
  std::printf("bent ring: %zu points, %lld edges walked, %lld mismatches with the BVH\n", colliding.size(),
              walk.stats().walked_edges, walk.stats().walk_mismatches);
  EXPECT_GT(walk.stats().walk_mismatches, 0);
  // The vertex in the wall (r = 0.532 m): printed beside the BVH path's (measured 0.0408 vs 0.0422 m;
  // both weighted means of its edges' hits, Heidelberger eq. (2)).
  PenetrationDepthSolver bvh(with(SurfaceQueryMethod::bvh));
  std::vector<VertexContact> a;
  bvh.compute(bodies, colliding, a);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    const Vec3& p = s.x[1][static_cast<size_t>(b[i].vertex)];
    std::printf("vertex (%.2f %.2f %.2f): depth walk %.4f, bvh %.4f\n", p.x(), p.y(), p.z(), b[i].penetration_depth,
                a[i].penetration_depth);
  }
}

// Heidelberger 2004 eq. (2)-(5) for one group (body a's vertices inside body b), written out with a
// branch per neighbour: each edge p-q to a non-colliding neighbour by its own single-segment query
// (first_ray_hit from q, t in [0, 1]), smoothed normals from TetMesh::vertex_normals, then layer by
// layer over neighbours of earlier layers. Same sums in the same order as the solver's.
std::map<int, VertexContact> plain_depths(const CollisionBody& a, const CollisionBody& b,
                                          const std::set<int>& inside) {
  SurfaceBvh bvh;
  bvh.build(*b.mesh, b.positions);
  std::vector<Vec3> normals(static_cast<size_t>(b.mesh->vertex_count()));
  b.mesh->vertex_normals(b.positions, normals);
  auto smoothed = [&](const SurfacePoint& h) {
    const auto& tri = b.mesh->surface_triangles()[static_cast<size_t>(h.triangle)];
    Vec3 n = Vec3::Zero();
    for (int k = 0; k < 3; ++k) n += h.barycentric[k] * normals[static_cast<size_t>(tri[static_cast<size_t>(k)])];
    const double len = n.norm();
    return len > 1e-12 ? Vec3(n / len) : b.mesh->triangle_normal(b.positions, h.triangle);
  };
  const double min_d2 = std::pow(1e-9 * std::max(a.mesh->mean_edge_length(), 1e-300), 2);
  auto x = [&](int v) -> const Vec3& { return a.positions[static_cast<size_t>(v)]; };
  std::map<int, VertexContact> out;
  for (int v : inside) {
    double depth_sum = 0.0, weight_sum = 0.0, nearest_d2 = std::numeric_limits<double>::max();
    Vec3 direction_sum = Vec3::Zero(), nearest_normal = Vec3::Zero();
    for (int q : a.mesh->vertex_neighbors(v)) {
      if (inside.count(q) != 0) continue;
      SurfacePoint h;
      if (!bvh.first_ray_hit(x(q), x(v) - x(q), -1, h, 1.0)) continue;
      const Vec3 n = smoothed(h);
      const double d2 = (h.point - x(v)).squaredNorm();
      const double w = 1.0 / std::max(d2, min_d2);
      depth_sum += w * (h.point - x(v)).dot(n);
      direction_sum += w * n;
      weight_sum += w;
      if (d2 < nearest_d2) {
        nearest_d2 = d2;
        nearest_normal = n;
      }
    }
    if (weight_sum == 0.0) continue;
    VertexContact& c = out[v];
    c.penetration_depth = depth_sum / weight_sum;
    const double len = direction_sum.norm();
    c.penetration_direction = len > 1e-12 * weight_sum ? Vec3(direction_sum / len) : nearest_normal;
    c.depth_source = DepthSource::border;
    c.layer = 0;
  }
  for (int layer = 1;; ++layer) {
    std::set<int> next;
    for (const auto& [v, c] : out) {
      if (c.layer != layer - 1) continue;
      for (int q : a.mesh->vertex_neighbors(v)) {
        if (inside.count(q) != 0 && out.count(q) == 0) next.insert(q);
      }
    }
    if (next.empty()) break;
    for (int v : next) {
      double depth_sum = 0.0, weight_sum = 0.0, nearest_d2 = std::numeric_limits<double>::max();
      Vec3 direction_sum = Vec3::Zero(), nearest_direction = Vec3::Zero();
      for (int q : a.mesh->vertex_neighbors(v)) {
        const auto it = out.find(q);
        if (it == out.end() || it->second.layer >= layer) continue;
        const Vec3 e = x(q) - x(v);
        const double d2 = e.squaredNorm();
        const double mu = 1.0 / std::max(d2, min_d2);
        depth_sum += mu * (e.dot(it->second.penetration_direction) + it->second.penetration_depth);
        direction_sum += mu * it->second.penetration_direction;
        weight_sum += mu;
        if (d2 < nearest_d2) {
          nearest_d2 = d2;
          nearest_direction = it->second.penetration_direction;
        }
      }
      VertexContact& c = out[v];
      c.penetration_depth = depth_sum / weight_sum;
      const double len = direction_sum.norm();
      c.penetration_direction = len > 1e-12 * weight_sum ? Vec3(direction_sum / len) : nearest_direction;
      c.depth_source = DepthSource::propagated;
      c.layer = layer;
    }
  }
  for (auto& [v, c] : out) {
    c.penetration_depth = std::max(c.penetration_depth, 0.0);
    SurfacePoint h;
    if (bvh.first_ray_hit(x(v), c.penetration_direction, -1, h)) {
      c.contact_triangle = h.triangle;
      c.contact_point = h.point;
    }
  }
  return out;
}

TEST(PenetrationDepthWalk, BorderSumsAndLayersEqualThePlainEquationsBitForBit) {
  // The solver classifies neighbours by selects and counters (session 11); the plain loops above
  // must give the same bits for every contact, over poses with several layers.
  Scene s = overlapping_boxes(3);
  SpatialHash hash;
  PenetrationDepthSolver solver;  // default: contact rays by the walk
  std::vector<VertexInTet> colliding;
  std::vector<VertexContact> contacts;
  int compared = 0, propagated = 0;
  for (int step = 0; step < 6; ++step) {
    const auto bodies = s.bodies();
    hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
    solver.compute(bodies, colliding, contacts);
    std::map<std::pair<int, int>, std::set<int>> groups;
    for (const VertexInTet& c : colliding) groups[{c.body, c.penetrated_body}].insert(c.vertex);
    for (const auto& [pair, inside] : groups) {
      const auto plain = plain_depths(bodies[static_cast<size_t>(pair.first)],
                                      bodies[static_cast<size_t>(pair.second)], inside);
      for (const VertexContact& c : contacts) {
        if (c.body != pair.first || c.penetrated_body != pair.second) continue;
        const auto it = plain.find(c.vertex);
        ASSERT_NE(it, plain.end()) << "vertex " << c.vertex << " has no plain depth (enclosed?)";
        const VertexContact& r = it->second;
        EXPECT_EQ(c.penetration_depth, r.penetration_depth) << "step " << step << " vertex " << c.vertex;
        EXPECT_EQ(c.penetration_direction, r.penetration_direction) << "step " << step << " vertex " << c.vertex;
        EXPECT_EQ(c.depth_source, r.depth_source);
        EXPECT_EQ(c.layer, r.layer);
        EXPECT_EQ(c.contact_triangle, r.contact_triangle);
        EXPECT_EQ(c.contact_point, r.contact_point);
        ++compared;
        propagated += c.depth_source == DepthSource::propagated ? 1 : 0;
      }
    }
    move(s, step % 3 == 2 ? 0.05 : 2e-3, 30u + static_cast<unsigned>(step));
  }
  EXPECT_GT(compared, 600);
  EXPECT_GT(propagated, 50);  // the propagation loops were exercised
}

}  // namespace
}  // namespace pliant
