// The AVX segment-packet kernel of the fan query (sim/collision/segment_packet.h) against the exact
// path: the scalar Moller-Trumbore loop it replaces, bit for bit, on random and adversarial
// triangles and segments (slivers, degenerate and coplanar triangles, segments through triangle
// edges and corners, ends on the plane, ties between triangles); and whole fan queries of a
// hierarchy with and without the kernel on moving, lazily refitted surfaces.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <random>
#include <vector>

#include "sim/collision/segment_packet.h"
#include "sim/collision/surface_bvh.h"
#include "sim/collision/triangle_queries.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

std::uint64_t bits(double x) { return std::bit_cast<std::uint64_t>(x); }

// The scalar query's loop for one segment over triangles in order (surface_bvh.cpp,
// fan_chunk_scalar): box test, Moller-Trumbore with t in [0, best t], then the smaller (t, index).
struct ScalarBest {
  double t = 1.0;
  int triangle = -1;
  Vec3 barycentric = Vec3::Zero();
  int ties = 0;  // hits at exactly the best t so far (decided by the index)
};

void scalar_leaf(const Vec3& origin, const Vec3& end, const std::vector<PreparedTriangle>& tris,
                 const std::vector<Aabb>& boxes, const std::vector<int>& index, ScalarBest& best) {
  const Vec3 dir = end - origin;
  const double dir_squared = dir.squaredNorm();
  Aabb seg;
  seg.extend(origin);
  seg.extend(end);
  for (size_t j = 0; j < tris.size(); ++j) {
    if (!boxes[j].overlaps(seg)) continue;
    TriangleHit h;
    if (!ray_triangle_intersection(origin, dir, dir_squared, tris[j], 0.0, best.t, h)) continue;
    best.ties += best.triangle >= 0 && h.t == best.t;
    if (best.triangle < 0 || h.t < best.t || (h.t == best.t && index[j] < best.triangle)) {
      best.t = h.t;
      best.triangle = index[j];
      best.barycentric = h.barycentric;
    }
  }
}

// A random triangle of one of several kinds; some share corners and edges with `previous` so
// segments hit shared edges and vertices and two triangles can give the same t.
std::array<Vec3, 3> random_triangle(std::mt19937& rng, const std::array<Vec3, 3>& previous) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> kind(0, 6);
  const auto rnd = [&] { return Vec3(u(rng), u(rng), u(rng)); };
  switch (kind(rng)) {
    case 0: return {previous[0], previous[2], rnd()};               // shares an edge
    case 1: return {previous[1], rnd(), rnd()};                       // shares a corner
    case 2: { const Vec3 a = rnd(); return {a, a + 1e-9 * rnd(), rnd()}; }  // sliver
    case 3: { const Vec3 a = rnd(), b = rnd(); return {a, b, 0.5 * (a + b)}; }  // degenerate (collinear)
    case 4: return {Vec3(u(rng), u(rng), 0.0), Vec3(u(rng), u(rng), 0.0), Vec3(u(rng), u(rng), 0.0)};  // on z = 0
    case 5: return previous;                                           // a duplicate (equal t)
    default: return {rnd(), rnd(), rnd()};
  }
}

// A segment origin for end `end` aimed at something interesting on triangle `tri`.
Vec3 random_origin(std::mt19937& rng, const Vec3& end, const std::array<Vec3, 3>& tri) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), w(0.0, 1.0);
  std::uniform_int_distribution<int> kind(0, 5);
  const Vec3 d = Vec3(u(rng), u(rng), u(rng));
  switch (kind(rng)) {
    case 0: { const double s = w(rng); return end + 2.0 * ((1 - s) * tri[0] + s * tri[1] - end); }  // through an edge
    case 1: return end + 2.0 * (tri[2] - end);                                   // through a corner
    case 2: return tri[0] + 0.3 * (tri[1] - tri[0]);                             // starts on the triangle (t = 0)
    case 3: return Vec3(u(rng), u(rng), 0.0);                                    // in the plane z = 0
    case 4: return end;                                                          // zero length
    default: return end + 2.0 * d;
  }
}

TEST(SegmentPacket, LeafKernelKeepsTheScalarLoopsHitsBitForBit) {
  if (!segment_packets_available()) GTEST_SKIP() << "no AVX on this CPU: the scalar query runs";
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> segments(1, SegmentPacket::kCapacity), leaf(1, 4), leaves(1, 6);
  long long hits = 0, total = 0, replaced = 0, ties = 0;
  std::array<Vec3, 3> previous = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  for (int trial = 0; trial < 4000; ++trial) {
    const Vec3 end = trial % 5 == 0 ? Vec3(u(rng), u(rng), 0.0) : Vec3(0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng));
    // A few leaves of up to 4 triangles, visited in order as the traversal would.
    std::vector<std::vector<PreparedTriangle>> tris;
    std::vector<std::vector<Aabb>> boxes;
    std::vector<std::vector<int>> index;
    std::vector<std::array<Vec3, 3>> corners;
    const int nl = leaves(rng);
    for (int l = 0; l < nl; ++l) {
      tris.emplace_back();
      boxes.emplace_back();
      index.emplace_back();
      const int nt = leaf(rng);
      for (int j = 0; j < nt; ++j) {
        previous = random_triangle(rng, previous);
        corners.push_back(previous);
        tris.back().push_back(PreparedTriangle::of(previous[0], previous[1], previous[2]));
        Aabb box;
        for (const Vec3& c : previous) box.extend(c);
        boxes.back().push_back(box);
        index.back().push_back(static_cast<int>(std::uniform_int_distribution<int>(0, 50)(rng)));
      }
    }
    const int m = segments(rng);
    std::vector<Vec3> origins;
    std::uniform_int_distribution<size_t> pick(0, corners.size() - 1);
    for (int i = 0; i < m; ++i) origins.push_back(random_origin(rng, end, corners[pick(rng)]));

    SegmentPacket packet;
    packet.load(end, origins.data(), m);
    for (size_t l = 0; l < tris.size(); ++l) {
      segment_packet_leaf(packet, tris[l].data(), boxes[l].data(), index[l].data(), static_cast<int>(tris[l].size()));
    }
    for (int i = 0; i < m; ++i) {
      ScalarBest best;
      int accepted = 0;
      for (size_t l = 0; l < tris.size(); ++l) {
        const ScalarBest before = best;
        scalar_leaf(origins[static_cast<size_t>(i)], end, tris[l], boxes[l], index[l], best);
        accepted += best.triangle != before.triangle || bits(best.t) != bits(before.t);
      }
      ++total;
      replaced += accepted > 1;
      ties += best.ties;
      ASSERT_EQ(static_cast<int>(packet.best_triangle[i]), best.triangle) << "trial " << trial << " segment " << i;
      ASSERT_EQ(bits(packet.best_t[i]), bits(best.t)) << "trial " << trial << " segment " << i;
      if (best.triangle < 0) continue;
      ++hits;
      const Vec3 w = clamped_barycentric(packet.best_u[i], packet.best_v[i]);
      for (int k = 0; k < 3; ++k) ASSERT_EQ(bits(w[k]), bits(best.barycentric[k])) << "trial " << trial;
    }
  }
  // The cases must have occurred: many hits, segments whose best was replaced, and exact ties.
  EXPECT_GT(total, 30000);
  EXPECT_GT(hits, 5000);
  EXPECT_GT(replaced, 500);
  EXPECT_GT(ties, 100);
}

TEST(SegmentPacket, FanQueriesWithAndWithoutTheKernelAgreeBitForBit) {
  // One hierarchy follows a jittered block through small (lazy) and large (refit) motions; after
  // each pose, fans of 1-40 segments ending near the surface are asked with the kernel and with
  // the scalar loop: every field of every hit equal (bitwise), the same segments missing.
  if (!segment_packets_available()) GTEST_SKIP() << "no AVX on this CPU: the scalar query runs";
  const auto mesh = make_box_mesh({Vec3(1.0, 0.6, 0.4), 10, 6, 4});
  std::vector<Vec3> x = mesh->rest_positions();
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> jitter(-1.0, 1.0), u(-0.6, 0.6), r(-0.15, 0.15);
  std::uniform_int_distribution<int> count(1, 40);
  SurfaceBvh bvh;
  bvh.build(*mesh, x);
  long long hits = 0;
  for (int pose = 0; pose < 8; ++pose) {
    const double amplitude = pose % 3 == 2 ? 0.03 : 0.002;  // beyond / within the lazy limit
    for (Vec3& p : x) p += amplitude * Vec3(jitter(rng), jitter(rng), jitter(rng));
    bvh.refit(x, 0.25, false);
    for (int f = 0; f < 150; ++f) {
      const Vec3 end(u(rng), 0.6 * u(rng), 0.4 * u(rng));
      const int m = count(rng);
      std::vector<Vec3> origins;
      for (int k = 0; k < m; ++k) origins.push_back(end + Vec3(r(rng), r(rng), r(rng)));
      const std::vector<int> none(static_cast<size_t>(m), -1);
      std::vector<SurfacePoint> a(static_cast<size_t>(m)), b(static_cast<size_t>(m));
      std::vector<char> found_a(static_cast<size_t>(m)), found_b(static_cast<size_t>(m));
      bvh.set_segment_packets(true);
      bvh.first_segment_hits(end, -1, origins, none, a, found_a);
      bvh.set_segment_packets(false);
      bvh.first_segment_hits(end, -1, origins, none, b, found_b);
      for (size_t k = 0; k < origins.size(); ++k) {
        ASSERT_EQ(found_a[k], found_b[k]) << pose << " " << f << " " << k;
        if (!found_a[k]) continue;
        ++hits;
        EXPECT_EQ(a[k].triangle, b[k].triangle);
        EXPECT_EQ(bits(a[k].t), bits(b[k].t));
        EXPECT_EQ(bits(a[k].distance_squared), bits(b[k].distance_squared));
        for (int c = 0; c < 3; ++c) {
          EXPECT_EQ(bits(a[k].barycentric[c]), bits(b[k].barycentric[c]));
          EXPECT_EQ(bits(a[k].point[c]), bits(b[k].point[c]));
        }
      }
    }
  }
  EXPECT_GT(hits, 2000);
}

}  // namespace
}  // namespace pliant
