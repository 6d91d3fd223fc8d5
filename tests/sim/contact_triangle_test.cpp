// Contact triangles (the ray x + t r onto the penetrated surface, first hit with t >= 0) and the
// surface BVH behind them, against brute force over all surface triangles; the missed-ray and
// vanishing-direction fallbacks (nearest surface triangle); self-collision contacts.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <unistd.h>
#include <numbers>
#include <random>

#include "sim/collision/contact_debug.h"
#include "sim/collision/contact_triangle.h"
#include "sim/collision/penetration_depth.h"
#include "sim/collision/spatial_hash.h"
#include "sim/collision/triangle_queries.h"
#include "sim/mesh/box_mesh.h"
#include "support/folded_bar.h"

namespace pliant {
namespace {

const Vec3& corner(const TetMesh& m, std::span<const Vec3> x, int tri, int k) {
  return x[static_cast<size_t>(m.surface_triangles()[static_cast<size_t>(tri)][static_cast<size_t>(k)])];
}

// Brute force: smallest t >= 0 over all surface triangles (infinity if none).
double brute_first_hit(const TetMesh& m, std::span<const Vec3> x, const Vec3& o, const Vec3& d, int exclude = -1) {
  double best = std::numeric_limits<double>::infinity();
  for (int t = 0; t < m.surface_triangle_count(); ++t) {
    const auto& tri = m.surface_triangles()[static_cast<size_t>(t)];
    if (std::find(tri.begin(), tri.end(), exclude) != tri.end()) continue;
    TriangleHit h;
    if (ray_triangle_intersection(o, d, corner(m, x, t, 0), corner(m, x, t, 1), corner(m, x, t, 2), 0.0,
                                  std::numeric_limits<double>::max(), h)) {
      best = std::min(best, h.t);
    }
  }
  return best;
}

// Brute force: squared distance from p to the surface.
double brute_nearest_d2(const TetMesh& m, std::span<const Vec3> x, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (int t = 0; t < m.surface_triangle_count(); ++t) {
    const Vec3 w = closest_point_on_triangle_barycentric(p, corner(m, x, t, 0), corner(m, x, t, 1), corner(m, x, t, 2));
    const Vec3 q = w[0] * corner(m, x, t, 0) + w[1] * corner(m, x, t, 1) + w[2] * corner(m, x, t, 2);
    best = std::min(best, (q - p).squaredNorm());
  }
  return best;
}

// The hit lies on its triangle: weights in [0,1] summing to 1, point = weighted corners, on the plane.
void expect_on_triangle(const TetMesh& m, std::span<const Vec3> x, int tri, const Vec3& bary, const Vec3& point) {
  ASSERT_GE(tri, 0);
  ASSERT_LT(tri, m.surface_triangle_count());
  EXPECT_GE(bary.minCoeff(), 0.0);
  EXPECT_LE(bary.maxCoeff(), 1.0);
  EXPECT_NEAR(bary.sum(), 1.0, 1e-14);
  const Vec3 a = corner(m, x, tri, 0), b = corner(m, x, tri, 1), c = corner(m, x, tri, 2);
  EXPECT_NEAR((bary[0] * a + bary[1] * b + bary[2] * c - point).norm(), 0.0, 1e-12);
  const Vec3 n = (b - a).cross(c - a).normalized();
  EXPECT_NEAR(n.dot(point - a), 0.0, 1e-12);
}

std::vector<Vec3> jittered(const TetMesh& m, double amplitude, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amplitude, amplitude);
  std::vector<Vec3> x;
  for (const Vec3& p : m.rest_positions()) x.push_back(p + Vec3(u(rng), u(rng), u(rng)));
  return x;
}

TEST(SurfaceBvh, RayAndNearestQueriesMatchBruteForce) {
  const auto mesh = make_box_mesh({Vec3(1.0, 0.6, 0.4), 10, 6, 4});
  const auto x = jittered(*mesh, 0.02, 7);
  SurfaceBvh bvh;
  bvh.build(*mesh, x);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  std::normal_distribution<double> g;
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vec3 o(u(rng), u(rng), u(rng));
    const Vec3 d = Vec3(g(rng), g(rng), g(rng)).normalized();
    SurfacePoint hit;
    const double brute = brute_first_hit(*mesh, x, o, d);
    const bool found = bvh.first_ray_hit(o, d, -1, hit);
    ASSERT_EQ(found, std::isfinite(brute)) << i;
    if (found) {
      ++hits;
      EXPECT_NEAR(hit.t, brute, 1e-12);
      expect_on_triangle(*mesh, x, hit.triangle, hit.barycentric, hit.point);
      EXPECT_NEAR((o + hit.t * d - hit.point).norm(), 0.0, 1e-12);
    }
    SurfacePoint nearest;
    ASSERT_TRUE(bvh.nearest_point(o, -1, nearest));
    EXPECT_NEAR(nearest.distance_squared, brute_nearest_d2(*mesh, x, o), 1e-14);
    expect_on_triangle(*mesh, x, nearest.triangle, nearest.barycentric, nearest.point);
  }
  EXPECT_GT(hits, 300);
}

// Brute force: smallest (t, triangle) with t in [0, 1] on the segment o -> e, skipping triangles
// holding exclude_a or exclude_b; -1 if none.
int brute_first_segment_hit(const TetMesh& m, std::span<const Vec3> x, const Vec3& o, const Vec3& e, int exclude_a,
                            int exclude_b, double& t_best) {
  int best = -1;
  t_best = std::numeric_limits<double>::infinity();
  for (int t = 0; t < m.surface_triangle_count(); ++t) {
    const auto& tri = m.surface_triangles()[static_cast<size_t>(t)];
    if (std::find(tri.begin(), tri.end(), exclude_a) != tri.end() ||
        std::find(tri.begin(), tri.end(), exclude_b) != tri.end()) {
      continue;
    }
    TriangleHit h;
    if (ray_triangle_intersection(o, e - o, corner(m, x, t, 0), corner(m, x, t, 1), corner(m, x, t, 2), 0.0, 1.0, h) &&
        h.t < t_best) {
      t_best = h.t;
      best = t;
    }
  }
  return best;
}

TEST(SurfaceBvh, FanOfSegmentsMatchesSingleQueriesAndBruteForce) {
  // Fans of 1..40 segments (more than one chunk) ending at points near the surface of a jittered
  // block, with and without excluded vertices: each segment's first hit equals first_ray_hit's
  // (bit for bit) and brute force's smallest t on [0, 1].
  const auto mesh = make_box_mesh({Vec3(1.0, 0.6, 0.4), 10, 6, 4});
  const auto x = jittered(*mesh, 0.02, 11);
  SurfaceBvh bvh;
  bvh.build(*mesh, x);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.6, 0.6), r(-0.15, 0.15);
  std::uniform_int_distribution<int> count(1, 40), vertex(0, mesh->vertex_count() - 1);
  int hits = 0, segments = 0;
  for (int i = 0; i < 300; ++i) {
    const Vec3 end(u(rng), 0.6 * u(rng), 0.4 * u(rng));
    const int m = count(rng);
    const bool exclude = i % 3 == 0;
    const int exclude_end = exclude ? vertex(rng) : -1;
    std::vector<Vec3> origins;
    std::vector<int> exclude_origins;
    for (int k = 0; k < m; ++k) {
      origins.push_back(end + Vec3(r(rng), r(rng), r(rng)));
      exclude_origins.push_back(exclude ? vertex(rng) : -1);
    }
    std::vector<SurfacePoint> fan(static_cast<size_t>(m));
    std::vector<char> found(static_cast<size_t>(m));
    bvh.first_segment_hits(end, exclude_end, origins, exclude_origins, fan, found);
    for (size_t k = 0; k < origins.size(); ++k) {
      ++segments;
      SurfacePoint single;
      const bool single_found = bvh.first_ray_hit(origins[k], end - origins[k], exclude_origins[k], single, 1.0, exclude_end);
      double t_brute = 0.0;
      const int brute = brute_first_segment_hit(*mesh, x, origins[k], end, exclude_origins[k], exclude_end, t_brute);
      ASSERT_EQ(found[k] != 0, single_found) << i << " " << k;
      ASSERT_EQ(single_found, brute >= 0) << i << " " << k;
      if (!single_found) continue;
      ++hits;
      EXPECT_EQ(fan[k].triangle, single.triangle);
      EXPECT_EQ(fan[k].t, single.t);
      EXPECT_EQ(fan[k].barycentric, single.barycentric);
      EXPECT_EQ(fan[k].point, single.point);
      EXPECT_EQ(fan[k].t, t_brute);
      expect_on_triangle(*mesh, x, fan[k].triangle, fan[k].barycentric, fan[k].point);
    }
  }
  EXPECT_GT(segments, 3000);
  EXPECT_GT(hits, 500);
}

// Every query of `refitted` gives bit for bit what a hierarchy freshly built at the same positions
// gives: rays (bounded and not), fans of segments and nearest points around the surface.
void expect_same_queries(const SurfaceBvh& refitted, const TetMesh& mesh, std::span<const Vec3> x, unsigned seed) {
  SurfaceBvh fresh;
  fresh.build(mesh, x);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.7, 0.7), r(-0.15, 0.15);
  std::normal_distribution<double> g;
  for (int i = 0; i < 200; ++i) {
    const Vec3 o(u(rng), 0.7 * u(rng), 0.5 * u(rng));
    const Vec3 d = Vec3(g(rng), g(rng), g(rng)).normalized();
    for (const double t_max : {std::numeric_limits<double>::max(), 0.1}) {
      SurfacePoint a, b;
      const bool fa = refitted.first_ray_hit(o, d, -1, a, t_max);
      ASSERT_EQ(fa, fresh.first_ray_hit(o, d, -1, b, t_max)) << i;
      if (fa) {
        EXPECT_EQ(a.triangle, b.triangle) << i;
        EXPECT_EQ(a.t, b.t) << i;
        EXPECT_EQ(a.barycentric, b.barycentric) << i;
      }
    }
    SurfacePoint na, nb;
    ASSERT_TRUE(refitted.nearest_point(o, -1, na));
    ASSERT_TRUE(fresh.nearest_point(o, -1, nb));
    EXPECT_EQ(na.triangle, nb.triangle) << i;
    EXPECT_EQ(na.distance_squared, nb.distance_squared) << i;
    std::vector<Vec3> origins;
    for (int k = 0; k < 6; ++k) origins.push_back(o + Vec3(r(rng), r(rng), r(rng)));
    const std::vector<int> none(origins.size(), -1);
    std::vector<SurfacePoint> fan_a(origins.size()), fan_b(origins.size());
    std::vector<char> found_a(origins.size()), found_b(origins.size());
    refitted.first_segment_hits(o, -1, origins, none, fan_a, found_a);
    fresh.first_segment_hits(o, -1, origins, none, fan_b, found_b);
    for (size_t k = 0; k < origins.size(); ++k) {
      ASSERT_EQ(found_a[k], found_b[k]) << i << " " << k;
      if (!found_a[k]) continue;
      EXPECT_EQ(fan_a[k].triangle, fan_b[k].triangle) << i << " " << k;
      EXPECT_EQ(fan_a[k].t, fan_b[k].t) << i << " " << k;
      EXPECT_EQ(fan_a[k].barycentric, fan_b[k].barycentric) << i << " " << k;
    }
  }
}

TEST(SurfaceBvh, RefitFollowsEveryPoseExactlyAsAFreshBuild) {
  // One hierarchy follows a sequence of poses: small motions (lazy: inflated node boxes, leaves
  // refitted on demand), a return to the fitted pose, a repeated pose, and large motions (full
  // refit or rebuild). After each refit every query equals a fresh build's.
  const auto mesh = make_box_mesh({Vec3(1.0, 0.6, 0.4), 10, 6, 4});
  const auto a = jittered(*mesh, 0.02, 21);
  std::vector<Vec3> small = a, large = a, stretched = a;
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (size_t i = 0; i < a.size(); ++i) {
    small[i] += 2e-3 * Vec3(u(rng), u(rng), u(rng));
    large[i] += Vec3(0.05, -0.02, 0.01) + 0.02 * Vec3(u(rng), u(rng), u(rng));
    stretched[i] = Vec3(1.3 * a[i].x(), a[i].y(), 0.8 * a[i].z());
  }
  SurfaceBvh bvh;
  bvh.build(*mesh, a);
  struct Step {
    const std::vector<Vec3>* x;
    bool rebuild_when_full;
    SurfaceBvhUpdate expected;
  };
  const double limit = 0.25;  // mean edge lengths (0.1 m cells: the small motion is lazy)
  const Step steps[] = {
      {&a, false, SurfaceBvhUpdate::unchanged}, {&small, false, SurfaceBvhUpdate::lazy},
      {&a, false, SurfaceBvhUpdate::lazy},      {&a, false, SurfaceBvhUpdate::unchanged},
      {&small, false, SurfaceBvhUpdate::lazy},  {&small, false, SurfaceBvhUpdate::lazy},
      {&large, false, SurfaceBvhUpdate::refit}, {&a, true, SurfaceBvhUpdate::rebuild},
      {&small, true, SurfaceBvhUpdate::lazy},   {&stretched, false, SurfaceBvhUpdate::refit},
      {&small, false, SurfaceBvhUpdate::refit}, {&large, true, SurfaceBvhUpdate::rebuild},
  };
  unsigned seed = 1;
  for (const Step& step : steps) {
    SCOPED_TRACE(seed);
    EXPECT_EQ(bvh.refit(*step.x, limit, step.rebuild_when_full), step.expected);
    expect_same_queries(bvh, *mesh, *step.x, seed++);
  }
  // A limit of zero refits in full whenever anything moved.
  EXPECT_EQ(bvh.refit(small, 0.0), SurfaceBvhUpdate::refit);
  expect_same_queries(bvh, *mesh, small, seed++);
  EXPECT_EQ(bvh.refit(small, 0.0), SurfaceBvhUpdate::unchanged);
}

TEST(ContactTriangle, BoundedSearchGivesTheUnboundedAnswer) {
  // find_contact_triangle with a bound at or above the first hit, or a bound below every hit (it
  // then searches again unbounded), returns exactly what the unbounded search returns.
  const auto mesh = make_box_mesh({Vec3(1.0, 0.6, 0.4), 10, 6, 4});
  const auto x = jittered(*mesh, 0.02, 13);
  SurfaceBvh bvh;
  bvh.build(*mesh, x);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.45, 0.45), scale(0.0, 3.0);
  std::normal_distribution<double> g;
  for (int i = 0; i < 1000; ++i) {
    const Vec3 o(u(rng), 0.6 * u(rng), 0.4 * u(rng));  // inside the block: the ray always hits
    const Vec3 d = Vec3(g(rng), g(rng), g(rng)).normalized();
    const auto free = find_contact_triangle(bvh, o, d, -1);
    ASSERT_TRUE(free.has_value());
    ASSERT_EQ(free->source, ContactTriangleSource::ray);
    for (const double bound : {free->point.t, free->point.t * (1.0 + scale(rng)), 0.5 * free->point.t}) {
      const auto bounded = find_contact_triangle(bvh, o, d, -1, bound);
      ASSERT_TRUE(bounded.has_value());
      EXPECT_EQ(bounded->source, free->source);
      EXPECT_EQ(bounded->point.triangle, free->point.triangle) << i << " " << bound;
      EXPECT_EQ(bounded->point.t, free->point.t);
      EXPECT_EQ(bounded->point.barycentric, free->point.barycentric);
    }
  }
}

TEST(ContactTriangle, FirstRayHitLiesOnTheTriangleAndDepthVectorLandsOnIt) {
  // A ball pressed into a block: planar penetrated face, so x + d r is the ray's hit exactly.
  const auto cube = make_box_mesh({Vec3(0.6, 0.6, 0.6), 6, 6, 6});
  const auto block = make_box_mesh({Vec3(2.0, 2.0, 2.0), 8, 8, 8});
  std::vector<Vec3> probe;
  for (const Vec3& p : cube->rest_positions()) {
    const double n = p.norm();
    probe.push_back((n > 0.0 ? Vec3(p * (p.cwiseAbs().maxCoeff() / n)) : p) + Vec3(0.2, -0.1, 1.1));
  }
  std::vector<CollisionBody> bodies(2);
  bodies[0].mesh = cube.get();
  bodies[0].positions = probe;
  bodies[1].mesh = block.get();
  bodies[1].positions = block->rest_positions();
  SpatialHash hash;
  PenetrationDepthSolver solver;
  std::vector<VertexInTet> colliding;
  std::vector<VertexContact> contacts;
  hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
  solver.compute(bodies, colliding, contacts);
  int checked = 0;
  for (const auto& c : contacts) {
    if (c.body != 0) continue;
    ++checked;
    const auto& x = bodies[1].positions;
    EXPECT_EQ(c.triangle_source, ContactTriangleSource::ray);
    expect_on_triangle(*block, x, c.contact_triangle, c.contact_barycentric, c.contact_point);
    const Vec3& p = probe[static_cast<size_t>(c.vertex)];
    EXPECT_NEAR((p + c.depth_vector() - c.contact_point).norm(), 0.0, 1e-9);
    EXPECT_NEAR((c.contact_point - p).norm(), brute_first_hit(*block, x, p, c.penetration_direction), 1e-12);
  }
  EXPECT_GT(checked, 20);
}

TEST(ContactTriangle, TiltedBlockContactsAreFirstHits) {
  // Penetrated body rotated and jittered (curved, non-axis-aligned surface): the contact triangle is
  // still the first hit along r, by brute force.
  const auto cube = make_box_mesh({Vec3(0.5, 0.5, 0.5), 5, 5, 5});
  const auto block = make_box_mesh({Vec3(2.0, 2.0, 2.0), 8, 8, 8});
  const Quat q(Eigen::AngleAxisd(0.3, Vec3(1, -2, 1).normalized()));
  auto xb = jittered(*block, 0.03, 11);
  for (auto& p : xb) p = q * p;
  std::vector<Vec3> probe;
  for (const Vec3& p : cube->rest_positions()) probe.push_back(p + q * Vec3(0.1, 0.2, 1.1));
  std::vector<CollisionBody> bodies(2);
  bodies[0].mesh = cube.get();
  bodies[0].positions = probe;
  bodies[1].mesh = block.get();
  bodies[1].positions = xb;
  CollisionFilter filter = CollisionFilter::from_bodies(bodies);
  SpatialHash hash;
  PenetrationDepthSolver solver;
  std::vector<VertexInTet> colliding;
  std::vector<VertexContact> contacts;
  hash.detect(bodies, filter, colliding);
  solver.compute(bodies, colliding, contacts);
  int checked = 0;
  for (const auto& c : contacts) {
    const auto& pen = bodies[static_cast<size_t>(c.penetrated_body)];
    const Vec3& p = bodies[static_cast<size_t>(c.body)].positions[static_cast<size_t>(c.vertex)];
    expect_on_triangle(*pen.mesh, pen.positions, c.contact_triangle, c.contact_barycentric, c.contact_point);
    EXPECT_NEAR(c.penetration_direction.norm(), 1.0, 1e-12);
    EXPECT_GE(c.penetration_depth, 0.0);
    if (c.triangle_source == ContactTriangleSource::ray) {
      ++checked;
      EXPECT_NEAR((c.contact_point - p).norm(), brute_first_hit(*pen.mesh, pen.positions, p, c.penetration_direction),
                  1e-12);
    }
  }
  EXPECT_GT(checked, 20);
}

TEST(ContactTriangle, MissedRayFallsBackToNearestTriangle) {
  const auto block = make_box_mesh({Vec3(2.0, 2.0, 2.0), 4, 4, 4});
  const auto x = jittered(*block, 0.02, 5);
  SurfaceBvh bvh;
  bvh.build(*block, x);
  // A point above the block looking up: the ray misses every triangle.
  const Vec3 p(0.3, -0.2, 1.5);
  ASSERT_FALSE(std::isfinite(brute_first_hit(*block, x, p, Vec3::UnitZ())));
  const auto hit = find_contact_triangle(bvh, p, Vec3::UnitZ(), -1);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->source, ContactTriangleSource::nearest_point_fallback);
  EXPECT_NEAR((hit->point.point - p).squaredNorm(), brute_nearest_d2(*block, x, p), 1e-14);
  expect_on_triangle(*block, x, hit->point.triangle, hit->point.barycentric, hit->point.point);
  // A vanishing direction takes the same fallback.
  const auto zero = find_contact_triangle(bvh, p, Vec3::Zero(), -1);
  ASSERT_TRUE(zero.has_value());
  EXPECT_EQ(zero->source, ContactTriangleSource::nearest_point_fallback);
  EXPECT_EQ(zero->point.triangle, hit->point.triangle);
  // A ray that does hit is reported as such.
  const auto down = find_contact_triangle(bvh, p, -Vec3::UnitZ(), -1);
  ASSERT_TRUE(down.has_value());
  EXPECT_EQ(down->source, ContactTriangleSource::ray);
  EXPECT_NEAR(down->point.t, brute_first_hit(*block, x, p, -Vec3::UnitZ()), 1e-12);
}

TEST(ContactTriangle, SelfCollisionContactsAvoidTheVertexOwnTriangles) {
  // A bar folded onto itself: contacts on its own surface, never on a triangle holding the vertex.
  const FoldedBar bar;
  const auto& mesh = bar.mesh;
  const auto& x = bar.x;
  const std::vector<CollisionBody> bodies = bar.bodies();
  SpatialHash hash;
  PenetrationDepthSolver solver;
  std::vector<VertexInTet> colliding;
  std::vector<VertexContact> contacts;
  hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
  solver.compute(bodies, colliding, contacts);
  ASSERT_GT(colliding.size(), 20u);
  EXPECT_EQ(contacts.size(), colliding.size());
  for (const auto& c : contacts) {
    const auto& tri = mesh->surface_triangles()[static_cast<size_t>(c.contact_triangle)];
    EXPECT_EQ(std::find(tri.begin(), tri.end(), c.vertex), tri.end());
    expect_on_triangle(*mesh, x, c.contact_triangle, c.contact_barycentric, c.contact_point);
    EXPECT_GE(c.penetration_depth, 0.0);
    EXPECT_NEAR(c.penetration_direction.norm(), 1.0, 1e-12);
  }
}

TEST(ContactDebug, WritesCollidingVerticesAndContactTrianglesAsVtu) {
  const auto cube = make_box_mesh({Vec3(0.4, 0.4, 0.4), 4, 4, 4});
  const auto block = make_box_mesh({Vec3(2.0, 2.0, 2.0), 4, 4, 4});
  std::vector<Vec3> probe;
  for (const Vec3& p : cube->rest_positions()) probe.push_back(p + Vec3(0.1, 0.1, 1.1));
  std::vector<CollisionBody> bodies(2);
  bodies[0].mesh = cube.get();
  bodies[0].positions = probe;
  bodies[1].mesh = block.get();
  bodies[1].positions = block->rest_positions();
  SpatialHash hash;
  PenetrationDepthSolver solver;
  std::vector<VertexInTet> colliding;
  std::vector<VertexContact> contacts;
  hash.detect(bodies, CollisionFilter::from_bodies(bodies), colliding);
  solver.compute(bodies, colliding, contacts);
  ASSERT_FALSE(contacts.empty());
  const auto dir = std::filesystem::temp_directory_path() / ("pliant_contact_debug_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto points_path = (dir / "contacts.vtu").string();
  const auto triangles_path = (dir / "contact_triangles.vtu").string();
  write_contact_debug_vtu(points_path, triangles_path, bodies, contacts);
  auto slurp = [](const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  const std::string points = slurp(points_path);
  const std::string triangles = slurp(triangles_path);
  const std::string n = std::to_string(contacts.size());
  EXPECT_NE(points.find("NumberOfPoints=\"" + n + "\" NumberOfCells=\"" + n + "\""), std::string::npos);
  EXPECT_NE(points.find("Name=\"depth_vector\" NumberOfComponents=\"3\""), std::string::npos);
  EXPECT_NE(points.find("Name=\"layer\""), std::string::npos);
  const std::string n3 = std::to_string(3 * contacts.size());
  EXPECT_NE(triangles.find("NumberOfPoints=\"" + n3 + "\" NumberOfCells=\"" + n + "\""), std::string::npos);
  EXPECT_NE(triangles.find("Name=\"barycentric\""), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace pliant
