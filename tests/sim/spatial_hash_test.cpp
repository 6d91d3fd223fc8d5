// Spatial hash (Teschner et al. 2003) against a brute-force oracle: every vertex against every tet
// of every allowed body by the same barycentric test, on many random overlapping poses of box
// meshes of different resolutions, including self-collision of folded meshes.
#include <gtest/gtest.h>

// This file replaces the global operator new/delete with malloc/free to count allocations; GCC's
// mismatched-new-delete check cannot see that both sides are replaced.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <numbers>
#include <random>

#include "sim/collision/spatial_hash.h"
#include "sim/collision/tet_barycentric.h"
#include "sim/mesh/box_mesh.h"
#include "sim/mesh/sphere_mesh.h"
#include "support/fp_traps.h"
#include "support/inline_two_thread_executor.h"

namespace pliant {
namespace {

// Oracle: all vertex-tet pairs; per (vertex, penetrated body) the tet with the largest minimum
// barycentric coordinate, ties by the smaller tet index (the documented choice). The inside test is
// the hash's closed one (contains_in_body: a coordinate may be negative within rounding across a
// face shared with another tet). With the strict test the oracle missed a vertex of a folded bar
// lying on an edge of another tet of the fold (every tet around the edge said "outside" by 1e-15),
// the hole of issue #4 (aligned_detection_test.cpp).
std::vector<VertexInTet> brute_force(std::span<const CollisionBody> bodies, const CollisionFilter& filter) {
  std::vector<VertexInTet> out;
  const int n = static_cast<int>(bodies.size());
  for (int a = 0; a < n; ++a) {
    const auto& ba = bodies[static_cast<size_t>(a)];
    if (!ba.active || ba.mesh == nullptr) continue;
    for (int v = 0; v < ba.mesh->vertex_count(); ++v) {
      const Vec3& p = ba.positions[static_cast<size_t>(v)];
      for (int b = 0; b < n; ++b) {
        const auto& bb = bodies[static_cast<size_t>(b)];
        if (!bb.active || bb.mesh == nullptr || !filter.allowed(a, b)) continue;
        VertexInTet best;
        double best_min = -1.0;
        for (int t = 0; t < bb.mesh->tet_count(); ++t) {
          const auto& tet = bb.mesh->tets()[static_cast<size_t>(t)];
          if (a == b && std::find(tet.begin(), tet.end(), v) != tet.end()) continue;
          const auto& x = bb.positions;
          const auto f = TetBarycentricFrame::of(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                                 x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
          Vec4 bary;
          const auto internal = [&](int k) { return is_internal_tet_face(*bb.mesh, t, k); };
          if (f.contains_in_body(p, internal, &bary) && bary.minCoeff() > best_min) {
            best_min = bary.minCoeff();
            best = VertexInTet{a, v, b, t, bary};
          }
        }
        if (best.tet >= 0) out.push_back(best);
      }
    }
  }
  return out;
}

Quat random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> g;
  Quat q(g(rng), g(rng), g(rng), g(rng));
  q.normalize();
  return q;
}

std::vector<Vec3> posed(const TetMesh& mesh, const Quat& r, const Vec3& t) {
  std::vector<Vec3> x;
  for (const Vec3& p : mesh.rest_positions()) x.push_back(r * p + t);
  return x;
}

// Folds a bar along x onto itself: the part x > 0 turns about the z axis by up to `angle` (rad)
// over a hinge of width w, so the far end lies across the near end.
// One collision body per position set, all of the same mesh (the positions are viewed, not copied).
std::vector<CollisionBody> bodies_of(const TetMesh& mesh, const std::vector<std::vector<Vec3>>& x) {
  std::vector<CollisionBody> bodies(x.size());
  for (size_t b = 0; b < x.size(); ++b) {
    bodies[b].mesh = &mesh;
    bodies[b].positions = x[b];
  }
  return bodies;
}

std::vector<Vec3> folded(const TetMesh& mesh, double angle, double w) {
  std::vector<Vec3> x;
  for (const Vec3& p : mesh.rest_positions()) {
    const double s = std::clamp(p.x() / w, 0.0, 1.0);
    const double phi = angle * s;
    const Vec3 pivot(0.0, 0.0, 0.0);
    x.push_back(pivot + Eigen::AngleAxisd(phi, Vec3::UnitZ()) * (p - pivot));
  }
  return x;
}

void expect_same(const std::vector<VertexInTet>& hash, const std::vector<VertexInTet>& brute,
                 std::span<const CollisionBody> bodies) {
  if (hash.size() != brute.size()) {
    for (const auto& b : brute) {
      bool f = false;
      for (const auto& h : hash) f = f || (h.body == b.body && h.vertex == b.vertex && h.penetrated_body == b.penetrated_body);
      if (!f) {
        const auto& p = bodies[static_cast<size_t>(b.body)].positions[static_cast<size_t>(b.vertex)];
        ADD_FAILURE() << "missed " << b.body << " " << b.vertex << " in " << b.penetrated_body << " tet " << b.tet
                      << " p " << p.transpose() << " bary " << b.barycentric.transpose();
      }
    }
  }
  if (hash.size() != brute.size()) {
    for (const auto& h : hash) {
      bool f = false;
      for (const auto& b : brute) f = f || (h.body == b.body && h.vertex == b.vertex && h.penetrated_body == b.penetrated_body);
      if (!f) {
        const auto& p = bodies[static_cast<size_t>(h.body)].positions[static_cast<size_t>(h.vertex)];
        ADD_FAILURE() << "extra " << h.body << " " << h.vertex << " in " << h.penetrated_body << " tet " << h.tet
                      << " p " << p.transpose() << " bary " << h.barycentric.transpose();
      }
    }
  }
  ASSERT_EQ(hash.size(), brute.size());
  for (size_t i = 0; i < hash.size(); ++i) {
    const auto& h = hash[i];
    const auto& b = brute[i];
    ASSERT_EQ(h.body, b.body) << i;
    ASSERT_EQ(h.vertex, b.vertex) << i;
    ASSERT_EQ(h.penetrated_body, b.penetrated_body) << i;
    EXPECT_EQ(h.tet, b.tet) << i;
    EXPECT_EQ(h.barycentric, b.barycentric) << i;
    // Second method for the coordinates themselves: an LU solve of A b = p - x0.
    const auto& pb = bodies[static_cast<size_t>(h.penetrated_body)];
    const auto& tet = pb.mesh->tets()[static_cast<size_t>(h.tet)];
    const auto& x = pb.positions;
    Mat3 A;
    A << x[static_cast<size_t>(tet[1])] - x[static_cast<size_t>(tet[0])],
        x[static_cast<size_t>(tet[2])] - x[static_cast<size_t>(tet[0])],
        x[static_cast<size_t>(tet[3])] - x[static_cast<size_t>(tet[0])];
    const Vec3 p = bodies[static_cast<size_t>(h.body)].positions[static_cast<size_t>(h.vertex)];
    const Vec3 sol = A.partialPivLu().solve(p - x[static_cast<size_t>(tet[0])]);
    EXPECT_NEAR(h.barycentric[1], sol[0], 1e-9);
    EXPECT_NEAR(h.barycentric[2], sol[1], 1e-9);
    EXPECT_NEAR(h.barycentric[3], sol[2], 1e-9);
    // A negative coordinate only within rounding of a face shared with another tet.
    const auto f = TetBarycentricFrame::of(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                           x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
    for (int k = 0; k < 4; ++k) {
      if (h.barycentric[k] >= 0.0) continue;
      EXPECT_TRUE(f.within_rounding_of_face(k, h.barycentric[k])) << i << " " << h.barycentric.transpose();
      EXPECT_TRUE(is_internal_tet_face(*pb.mesh, h.tet, k)) << i;
    }
  }
}

TEST(SpatialHash, HashIsFloorBasedAndInRange) {
  const std::uint64_t n = SpatialHash::next_prime(3001);
  EXPECT_EQ(n, 3001u);
  EXPECT_EQ(SpatialHash::next_prime(3002), 3011u);
  EXPECT_EQ(SpatialHash::next_prime(1), 2u);
  for (int i = -5; i <= 5; ++i) {
    for (int j = -5; j <= 5; ++j) {
      EXPECT_LT(SpatialHash::hash_cell(i, j, -i * j, n), n);
    }
  }
  // Extreme cells do not overflow (unsigned arithmetic) and stay in range.
  EXPECT_LT(SpatialHash::hash_cell(std::numeric_limits<int>::min(), std::numeric_limits<int>::max(), -1, n), n);
  EXPECT_EQ(SpatialHash::hash_cell(0, 0, 0, n), 0u);
}

TEST(SpatialHash, MatchesBruteForceOnRandomPoses) {
  const std::vector<TetMeshPtr> meshes = {
      make_box_mesh({Vec3(0.4, 0.3, 0.2), 2, 2, 2}),
      make_box_mesh({Vec3(0.5, 0.2, 0.3), 5, 2, 3}),
      make_box_mesh({Vec3(0.3, 0.3, 0.3), 6, 6, 6}),
      make_box_mesh({Vec3(0.6, 0.1, 0.1), 12, 2, 2}),
      make_box_mesh({Vec3(0.2, 0.25, 0.15), 1, 1, 1}),
  };
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(meshes.size()) - 1);
  std::bernoulli_distribution coin(0.8);
  SpatialHash hash;  // reused across trials: stamps and buffers carry over
  long long total = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int body_count = 2 + trial % 4;
    std::vector<std::vector<Vec3>> x;
    std::vector<CollisionBody> bodies;
    for (int b = 0; b < body_count; ++b) {
      const auto& mesh = meshes[static_cast<size_t>(pick(rng))];
      x.push_back(posed(*mesh, random_rotation(rng), Vec3(u(rng), u(rng), u(rng))));
    }
    for (int b = 0; b < body_count; ++b) {
      CollisionBody cb;
      cb.mesh = meshes[static_cast<size_t>(trial + b) % meshes.size()].get();
      bodies.push_back(cb);
    }
    // Re-pose with the mesh actually used by each body.
    for (int b = 0; b < body_count; ++b) {
      x[static_cast<size_t>(b)] = posed(*bodies[static_cast<size_t>(b)].mesh, random_rotation(rng),
                                        Vec3(u(rng), u(rng), u(rng)));
      bodies[static_cast<size_t>(b)].positions = x[static_cast<size_t>(b)];
      bodies[static_cast<size_t>(b)].active = trial % 7 != 3 || b != 0;
    }
    CollisionFilter filter = CollisionFilter::from_bodies(bodies);
    for (int a = 0; a < body_count; ++a) {
      for (int b = a + 1; b < body_count; ++b) {
        if (bodies[static_cast<size_t>(a)].active && bodies[static_cast<size_t>(b)].active) {
          filter.set(a, b, coin(rng));
        }
      }
    }
    std::vector<VertexInTet> found;
    hash.detect(bodies, filter, found);
    const auto oracle = brute_force(bodies, filter);
    SCOPED_TRACE(trial);
    expect_same(found, oracle, bodies);
    total += static_cast<long long>(oracle.size());
  }
  EXPECT_GT(total, 1000);  // the poses really overlap
}

// A pile (session 11): 27 balls on a jittered 3 x 3 x 3 lattice, each sunk into its neighbours,
// so every ball lies inside the union of its partners' bounds and the partners' box culls nothing.
// Pass 2 skips the tets whose cells hold no partner vertex (the occupied-cell bitmap); the result
// must still be the brute force's, entry for entry, and the skip must really happen (most of a
// ball's tets are far from its neighbours' vertices).
TEST(SpatialHash, PileSkipsTetsWithoutPartnerVerticesAndMatchesBruteForce) {
  const auto ball = make_sphere_mesh({0.015, 40, 2});
  std::mt19937 rng(811);
  std::uniform_real_distribution<double> jitter(-0.002, 0.002);
  SpatialHash hash;
  long long total = 0, skipped = 0, visited = 0;
  for (int trial = 0; trial < 2; ++trial) {
    std::vector<std::vector<Vec3>> x;
    const double spacing = 0.0285 - 0.001 * trial;  // diameter 0.03: overlaps 1.5 and 2.5 mm
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) {
          const Vec3 centre = spacing * Vec3(i, j, k) + Vec3(jitter(rng), jitter(rng), jitter(rng));
          x.push_back(posed(*ball, random_rotation(rng), centre));
        }
      }
    }
    const std::vector<CollisionBody> bodies = bodies_of(*ball, x);
    const CollisionFilter filter = CollisionFilter::from_bodies(bodies);
    std::vector<VertexInTet> found;
    hash.detect(bodies, filter, found);
    const auto oracle = brute_force(bodies, filter);
    SCOPED_TRACE(trial);
    expect_same(found, oracle, bodies);
    total += static_cast<long long>(oracle.size());
    skipped += hash.stats().tets_skipped_unoccupied + hash.stats().tets_skipped_partner_boxes;
    visited += hash.stats().tets_visited;
  }
  EXPECT_GT(total, 100);        // the balls really overlap (168 found)
  EXPECT_GT(skipped, visited);  // and most tets were skipped, exactly (since session 16 most by the partner boxes)
}

// The piled fruit dish in small (session 15): the 27-ball pile sunk 2 mm into a rigid floor and two
// rigid walls of one cell each (the dish's boxes), plus a rigid wall no ball reaches. Pass 2 looks
// up only the marked cells of a ball's tets, and each box's rigid pass reads only the partners whose
// inserted vertices can reach its bounds. The result must be the brute force's entry for entry, and
// the boxes' pass the cell walk's (poses not given) bit for bit.
TEST(SpatialHash, PileInRigidDishMatchesBruteForceAndTheCellWalk) {
  const auto ball = make_sphere_mesh({0.015, 40, 2});
  const auto floor = make_box_mesh({Vec3(0.12, 0.12, 0.02), 1, 1, 1});
  const auto wall_x = make_box_mesh({Vec3(0.02, 0.12, 0.12), 1, 1, 1});
  const auto wall_y = make_box_mesh({Vec3(0.12, 0.02, 0.12), 1, 1, 1});
  std::mt19937 rng(1507);
  std::uniform_real_distribution<double> jitter(-0.002, 0.002);
  const double spacing = 0.0285;  // diameter 0.03: neighbours overlap ~1.5 mm
  std::vector<std::vector<Vec3>> x;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) {
        const Vec3 centre = spacing * Vec3(i, j, k) + Vec3(jitter(rng), jitter(rng), jitter(rng));
        x.push_back(posed(*ball, random_rotation(rng), centre));
      }
    }
  }
  // Box faces 13 mm from the lattice's first row of centres: balls of the first row sink ~2 mm.
  const double c = spacing;  // the lattice's middle
  std::vector<Pose> poses(4);
  poses[0].translation = Vec3(c, c, -0.023);   // floor
  poses[1].translation = Vec3(-0.023, c, c);   // wall at x-
  poses[2].translation = Vec3(c, -0.023, c);   // wall at y-
  poses[3].translation = Vec3(0.3, c, c);      // a wall far away
  const TetMesh* box_meshes[4] = {floor.get(), wall_x.get(), wall_y.get(), wall_x.get()};
  for (int w = 0; w < 4; ++w) x.push_back(posed(*box_meshes[w], Quat::Identity(), poses[static_cast<size_t>(w)].translation));
  std::vector<CollisionBody> bodies = bodies_of(*ball, x);
  for (int w = 0; w < 4; ++w) bodies[static_cast<size_t>(27 + w)].mesh = box_meshes[w];
  CollisionFilter filter = CollisionFilter::from_bodies(bodies);
  for (int a = 27; a < 31; ++a) {
    for (int b = a + 1; b < 31; ++b) filter.set(a, b, false);  // boxes never touch each other
  }
  SpatialHash hash;
  std::vector<VertexInTet> walk, rigid;
  hash.detect(bodies, filter, walk);
  for (int w = 0; w < 4; ++w) bodies[static_cast<size_t>(27 + w)].rigid_pose = &poses[static_cast<size_t>(w)];
  hash.detect(bodies, filter, rigid);
  const auto oracle = brute_force(bodies, filter);
  expect_same(rigid, oracle, bodies);
  expect_same(walk, oracle, bodies);
  int in_boxes = 0, boxes_in = 0;
  for (const VertexInTet& v : oracle) {
    in_boxes += v.penetrated_body >= 27 ? 1 : 0;
    boxes_in += v.body >= 27 ? 1 : 0;
  }
  EXPECT_GT(in_boxes, 20);  // ball vertices really lie in the near boxes
  EXPECT_GT(static_cast<int>(oracle.size()) - in_boxes - boxes_in, 50) << in_boxes << " " << boxes_in;  // and in each other
}

// 64 balls (body 5 self-colliding, body 17 inactive) on a jittered 4 x 4 x 4 lattice sunk into their
// neighbours, over a dish floor (body 64, a box far larger than the body grid's cells) in which the
// first row sinks ~2 mm; ~10% of the allowed pairs filtered out at random. `two_piles`: the second
// half of the balls moved far away.
struct BallPile {
  TetMeshPtr ball = make_sphere_mesh({0.015, 20, 1});
  TetMeshPtr floor = make_box_mesh({Vec3(0.3, 0.3, 0.02), 2, 2, 1});
  Pose floor_pose;
  std::vector<std::vector<Vec3>> x;
  std::vector<CollisionBody> bodies;
  CollisionFilter filter;

  BallPile(std::mt19937& rng, double spacing, bool two_piles) {
    std::uniform_real_distribution<double> jitter(-0.002, 0.002);
    std::bernoulli_distribution coin(0.9);
    for (int n = 0; n < 64; ++n) {
      Vec3 centre = spacing * Vec3(n % 4, (n / 4) % 4, n / 16) + Vec3(jitter(rng), jitter(rng), jitter(rng));
      if (two_piles && n >= 32) centre += Vec3(1.0, 0.0, -2.0 * spacing);  // a second pile, far away
      x.push_back(posed(*ball, random_rotation(rng), centre));
    }
    floor_pose.translation = Vec3(0.05, 0.05, -0.023);
    x.push_back(posed(*floor, Quat::Identity(), floor_pose.translation));
    bodies = bodies_of(*ball, x);
    bodies[64].mesh = floor.get();
    bodies[5].self_collision = true;
    bodies[17].active = false;
    filter = CollisionFilter::from_bodies(bodies);
    for (int a = 0; a < 65; ++a) {
      for (int b = a + 1; b < 65; ++b) {
        if (filter.allowed(a, b) && !coin(rng)) filter.set(a, b, false);
      }
    }
  }
};

// More bodies than BoundsOverlap compares pair by pair (session 17): pass 1 and pass 2 read each
// body's partners from the body-level grid, not from every body. 64 balls (one self-colliding, one
// inactive) on a jittered 4 x 4 x 4 lattice sunk into their neighbours, in a rigid dish floor (a box
// far larger than the grid's cells: the large list), some pairs filtered out at random; two
// far-apart piles in the second trial. Entry for entry the brute force, which asks every body.
TEST(SpatialHash, ManyBodiesMatchBruteForceThroughTheBodyGrid) {
  std::mt19937 rng(1717);
  SpatialHash hash;
  for (int trial = 0; trial < 2; ++trial) {
    const BallPile pile(rng, 0.0285 - 0.001 * trial, trial == 1);
    const auto& bodies = pile.bodies;
    const CollisionFilter& filter = pile.filter;
    std::vector<VertexInTet> found;
    hash.detect(bodies, filter, found);
    const auto oracle = brute_force(bodies, filter);
    SCOPED_TRACE(trial);
    expect_same(found, oracle, bodies);
    int in_floor = 0;
    for (const VertexInTet& v : oracle) in_floor += v.penetrated_body == 64 ? 1 : 0;
    EXPECT_GT(in_floor, 10);                                 // balls really lie in the floor
    EXPECT_GT(static_cast<int>(oracle.size()) - in_floor, 40);  // and in each other (57 and 82)
  }
}

// Pass 2 in chunks of penetrated bodies (session 22: threads): each chunk has its own scratch, and
// the merged candidates are sorted, so the result must be the serial pass's bit for bit, and the
// counters its sums. The executor runs the chunks inline, last chunk first, so a partner mark, a
// bitmap or a candidate left over from another chunk's bodies would show. The scene holds every
// kind of penetrated body: a pile of 64 balls with self-collision in one, an inactive one, pairs
// filtered out at random, and a rigid floor searched through its grid (its pose given).
TEST(SpatialHash, PassTwoInChunksIsTheSerialPassBitForBit) {
  std::mt19937 rng(2211);
  BallPile pile(rng, 0.0285, false);
  pile.bodies[64].rigid_pose = &pile.floor_pose;
  const auto& bodies = pile.bodies;
  const CollisionFilter& filter = pile.filter;
  auto& x = pile.x;
  SpatialHash serial_hash, chunked_hash;
  InlineTwoThreadExecutor executor;
  std::vector<VertexInTet> serial, chunked;
  for (int step = 0; step < 2; ++step) {  // the second time with the chunks' scratch already used
    SCOPED_TRACE(step);
    for (auto& p : x[3]) p += Vec3(0.0, 0.0, -1e-3);  // one ball sinks further
    serial_hash.detect(bodies, filter, serial);
    chunked_hash.detect(bodies, filter, chunked, &executor);
    ASSERT_EQ(chunked.size(), serial.size());
    for (size_t i = 0; i < serial.size(); ++i) {
      const VertexInTet &s = serial[i], &c = chunked[i];
      ASSERT_TRUE(c.body == s.body && c.vertex == s.vertex && c.penetrated_body == s.penetrated_body && c.tet == s.tet) << i;
      for (int k = 0; k < 4; ++k) ASSERT_EQ(c.barycentric[k], s.barycentric[k]) << i;  // the same bits
    }
    const SpatialHashStats &a = serial_hash.stats(), &b = chunked_hash.stats();
    EXPECT_EQ(b.tets_visited, a.tets_visited);
    EXPECT_EQ(b.cells_visited, a.cells_visited);
    EXPECT_EQ(b.inside_tests, a.inside_tests);
    EXPECT_EQ(b.candidates_found, a.candidates_found);
    EXPECT_EQ(b.entries_scanned, a.entries_scanned);
    EXPECT_EQ(b.tets_skipped_unoccupied, a.tets_skipped_unoccupied);
    EXPECT_EQ(b.tets_skipped_partner_boxes, a.tets_skipped_partner_boxes);
    expect_same(chunked, brute_force(bodies, filter), bodies);
  }
  int in_floor = 0, self = 0;
  for (const VertexInTet& v : serial) {
    in_floor += v.penetrated_body == 64 ? 1 : 0;
    self += v.body == v.penetrated_body ? 1 : 0;
  }
  EXPECT_GT(in_floor, 10);  // the floor's rigid pass found ball vertices
  EXPECT_GT(static_cast<int>(serial.size()) - in_floor - self, 40);  // and the balls each other
}

// Pass 2 skips a tet whose box meets no partner's box of inserted vertices inside the penetrated
// body's bounds (session 16, BoxSetOutcodes). Its edge cases, against the brute force entry for
// entry: blocks that touch only at a shared face (the partner's vertices inside the bounds form a
// flat box), edge and corner (a box of one line or one point), all on dyadic coordinates so that the
// contact is exact; a pair that may not touch (a sleeping pair: the filter says no) overlapping
// deeply, whose vertices must not keep the other's tets; a self-colliding folded bar (its own
// vertices are its partner: no tet of it may be skipped) with a block in it; a block far from all.
// The number of tets skipped must also be the count of a direct second method: per penetrated body,
// its tets whose box meets none of the boxes {vertices of an allowed partner inside its bounds}.
TEST(SpatialHash, PartnerBoxSkipMatchesBruteForceAtBoundariesFiltersAndSelfCollision) {
  const auto block = make_box_mesh({Vec3(0.25, 0.25, 0.25), 2, 2, 2});  // [-0.125, 0.125]^3, cells 0.125
  const auto small = make_box_mesh({Vec3(0.1, 0.1, 0.1), 2, 2, 2});
  const auto bar = make_box_mesh({Vec3(1.0, 0.3, 0.1), 16, 4, 2});
  std::mt19937 rng(1616);
  std::uniform_int_distribution<int> sixty_fourths(-8, 8);
  SpatialHash hash;
  long long skipped_total = 0, found_self = 0, found_at_boundary = 0;
  for (int trial = 0; trial < 6; ++trial) {
    // The whole scene shifted by a dyadic offset (exact sums) and, in the last trials, by an inexact one.
    Vec3 shift(sixty_fourths(rng), sixty_fourths(rng), sixty_fourths(rng));
    shift /= 64.0;
    if (trial >= 4) shift += Vec3(1e-3, -2e-3, 3e-3) / 3.0;
    std::vector<std::vector<Vec3>> x = {
        posed(*block, Quat::Identity(), shift),                                // 0: B
        posed(*block, Quat::Identity(), shift + Vec3(0.0, 0.0, 0.25)),         // 1: on B's top face
        posed(*block, Quat::Identity(), shift + Vec3(0.25, 0.25, 0.0)),        // 2: B's edge, 1's corner
        posed(*block, Quat::Identity(), shift + Vec3(0.1875, 0.0625, 0.0)),    // 3: deep in B (filtered) and in 2
        posed(*block, Quat::Identity(), shift + Vec3(10.0, 10.0, 10.0)),       // 4: far from all
        folded(*bar, 0.97 * std::numbers::pi, 0.15),                           // 5: self-colliding fold
        posed(*small, Quat::Identity(), Vec3(-0.3, 0.05, 0.0)),                // 6: in the fold
    };
    for (std::vector<Vec3>* moved : {&x[5], &x[6]}) {
      for (Vec3& p : *moved) p += shift + Vec3(5.0, 0.0, 0.0);
    }
    std::vector<CollisionBody> bodies = bodies_of(*block, x);
    bodies[5].mesh = bar.get();
    bodies[6].mesh = small.get();
    bodies[5].self_collision = true;
    CollisionFilter filter = CollisionFilter::from_bodies(bodies);
    filter.set(0, 3, false);  // a sleeping pair: both at rest, the world filters it out
    std::vector<VertexInTet> found;
    hash.detect(bodies, filter, found);
    const auto oracle = brute_force(bodies, filter);
    SCOPED_TRACE(trial);
    expect_same(found, oracle, bodies);
    for (const VertexInTet& v : oracle) {
      found_self += v.body == 5 && v.penetrated_body == 5 ? 1 : 0;
      found_at_boundary += v.body <= 2 && v.penetrated_body <= 2 ? 1 : 0;
    }

    // Second method for the skip count.
    long long expected_skips = 0;
    for (int b = 0; b < static_cast<int>(bodies.size()); ++b) {
      const CollisionBody& pb = bodies[static_cast<size_t>(b)];
      Aabb bounds;
      for (const Vec3& p : pb.positions) bounds.extend(p);
      std::vector<Aabb> near_boxes;
      for (int a = 0; a < static_cast<int>(bodies.size()); ++a) {
        if (!filter.allowed(a, b)) continue;
        Aabb near;
        for (const Vec3& p : bodies[static_cast<size_t>(a)].positions) {
          if ((p.array() >= bounds.min.array()).all() && (p.array() <= bounds.max.array()).all()) near.extend(p);
        }
        if (!near.empty()) near_boxes.push_back(near);
      }
      if (near_boxes.empty()) continue;  // the body is skipped whole, its tets not counted
      for (const TetIndices& tet : pb.mesh->tets()) {
        Aabb box;
        for (int k : tet) box.extend(pb.positions[static_cast<size_t>(k)]);
        bool meets = false;
        for (const Aabb& near : near_boxes) meets = meets || box.overlaps(near);
        expected_skips += meets ? 0 : 1;
      }
    }
    EXPECT_EQ(hash.stats().tets_skipped_partner_boxes, expected_skips);
    skipped_total += expected_skips;
  }
  EXPECT_GT(found_at_boundary, 6 * 18);  // B and 1 share 9 vertices each way, plus the edge and corner
  EXPECT_GT(found_self, 6 * 10);         // the fold overlaps itself
  EXPECT_GT(skipped_total, 6 * 50);      // and the skip happens
}

// A body that integrated to NaN or infinity must not take the hash down: the occupancy bitmap was
// sized from its bounds (a NaN cell coordinate, then a negative cell count cast to size_t:
// std::bad_alloc). Non-finite vertices are found in no tet and their tets contain nothing; every
// finite pair is still found, as brute force finds them. (World::step also stops a non-finite step
// before detection; this is the hash on its own, as a library user may call it.)
TEST(SpatialHash, NonFiniteVerticesAreNotFatalAndFinitePairsAreStillFound) {
  const auto ball = make_sphere_mesh({0.015, 40, 2});
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  testing::ScopedFpTrapsOff traps_off;  // the non-finite vertices are on purpose (here and in brute force)
  SpatialHash hash;
  for (const Vec3& bad : {Vec3(nan, 0, 0), Vec3(0, 0, inf), Vec3(-inf, nan, inf), Vec3(1e300, 0, 0)}) {
    // One vertex (the first, the last, one in the middle), every third vertex, or every vertex (what
    // an implicit step with one NaN force gives) of the second ball.
    for (int where = 0; where < 5; ++where) {
      // The third ball overlaps the first, so the first's vertices are hashed and are partners of
      // the second (the case that reached the bitmap with the second's empty bounds).
      std::vector<std::vector<Vec3>> x = {posed(*ball, Quat::Identity(), Vec3::Zero()),
                                          posed(*ball, Quat::Identity(), Vec3(0.022, 0.003, 0.0)),
                                          posed(*ball, Quat::Identity(), Vec3(-0.022, 0.0, 0.003))};
      const int n = ball->vertex_count();
      const int first = where == 0 ? 0 : where == 1 ? n - 1 : where == 2 ? n / 2 : 0;
      const int stride = where == 3 ? 3 : where == 4 ? 1 : n;
      for (int v = first; v < n; v += stride) x[1][static_cast<size_t>(v)] = bad;
      const std::vector<CollisionBody> bodies = bodies_of(*ball, x);
      const CollisionFilter filter = CollisionFilter::from_bodies(bodies);
      std::vector<VertexInTet> found;
      ASSERT_NO_THROW(hash.detect(bodies, filter, found)) << bad.transpose() << " case " << where;
      const auto oracle = brute_force(bodies, filter);
      SCOPED_TRACE(where);
      expect_same(found, oracle, bodies);
      if (where < 3) {
        EXPECT_GT(oracle.size(), 5u);  // the balls overlap by 8 mm (10 pairs)
      }
    }
  }
}

TEST(SpatialHash, SelfCollisionOfFoldedBarsMatchesBruteForce) {
  SpatialHash hash;
  for (const auto& [nx, ny, nz] : {std::array{16, 4, 2}, std::array{24, 6, 2}, std::array{10, 3, 1}}) {
    const auto mesh = make_box_mesh({Vec3(1.0, 0.3, 0.1), nx, ny, nz});
    for (double angle : {0.9 * std::numbers::pi, 0.97 * std::numbers::pi, 1.04 * std::numbers::pi}) {
      const auto x = folded(*mesh, angle, 0.15);
      std::vector<CollisionBody> bodies(1);
      bodies[0].mesh = mesh.get();
      bodies[0].positions = x;
      bodies[0].self_collision = true;
      const CollisionFilter filter = CollisionFilter::from_bodies(bodies);
      ASSERT_TRUE(filter.allowed(0, 0));
      std::vector<VertexInTet> found;
      hash.detect(bodies, filter, found);
      const auto oracle = brute_force(bodies, filter);
      EXPECT_GT(oracle.size(), 10u) << "the fold must overlap";
      expect_same(found, oracle, bodies);

      // Without self-collision the same pose finds nothing.
      bodies[0].self_collision = false;
      hash.detect(bodies, CollisionFilter::from_bodies(bodies), found);
      EXPECT_TRUE(found.empty());
    }
  }
}

TEST(SpatialHash, UndeformedMeshHasNoSelfCollision) {
  const auto mesh = make_box_mesh({Vec3(0.3, 0.2, 0.1), 6, 4, 3});
  std::vector<CollisionBody> bodies(1);
  bodies[0].mesh = mesh.get();
  bodies[0].positions = mesh->rest_positions();
  bodies[0].self_collision = true;
  SpatialHash hash;
  std::vector<VertexInTet> found;
  hash.detect(bodies, CollisionFilter::from_bodies(bodies), found);
  EXPECT_TRUE(found.empty());
}

TEST(SpatialHash, VertexInTwoBodiesGetsOneEntryPerBodyAndOrderIsDeterministic) {
  const auto small = make_box_mesh({Vec3(0.1, 0.1, 0.1), 2, 2, 2});
  const auto big = make_box_mesh({Vec3(1.0, 1.0, 1.0), 3, 3, 3});
  // Two big overlapping blocks; the small box sits in their overlap.
  const auto xa = posed(*big, Quat::Identity(), Vec3(-0.3, 0.0, 0.0));
  const auto xb = posed(*big, Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ())), Vec3(0.3, 0.01, 0.02));
  const auto xs = posed(*small, Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized())), Vec3(0.01, 0.02, 0.03));
  std::vector<CollisionBody> bodies(3);
  bodies[0].mesh = small.get();
  bodies[0].positions = xs;
  bodies[1].mesh = big.get();
  bodies[1].positions = xa;
  bodies[2].mesh = big.get();
  bodies[2].positions = xb;
  CollisionFilter filter = CollisionFilter::from_bodies(bodies);
  filter.set(1, 2, false);
  SpatialHash hash;
  std::vector<VertexInTet> found;
  hash.detect(bodies, filter, found);
  int small_entries = 0;
  for (const auto& c : found) {
    if (c.body == 0) ++small_entries;
  }
  EXPECT_EQ(small_entries, 2 * small->vertex_count());
  for (size_t i = 1; i < found.size(); ++i) {
    const auto& p = found[i - 1];
    const auto& q = found[i];
    EXPECT_TRUE(std::tie(p.body, p.vertex, p.penetrated_body) < std::tie(q.body, q.vertex, q.penetrated_body));
  }
  // Same input, same output; the output buffer is reused without reallocating.
  const auto first = found;
  const auto* data = found.data();
  hash.detect(bodies, filter, found);
  EXPECT_EQ(found.data(), data);
  ASSERT_EQ(found.size(), first.size());
  for (size_t i = 0; i < found.size(); ++i) {
    EXPECT_EQ(found[i].tet, first[i].tet);
    EXPECT_EQ(found[i].barycentric, first[i].barycentric);
  }
  expect_same(found, brute_force(bodies, filter), bodies);
}

TEST(SpatialHash, FilteredAndInactiveBodiesAreNotHashed) {
  const auto mesh = make_box_mesh({Vec3(0.3, 0.3, 0.3), 3, 3, 3});
  const auto x0 = posed(*mesh, Quat::Identity(), Vec3::Zero());
  const auto x1 = posed(*mesh, Quat::Identity(), Vec3(0.1, 0.05, 0.0));
  std::vector<CollisionBody> bodies(3);
  for (auto& b : bodies) b.mesh = mesh.get();
  bodies[0].positions = x0;
  bodies[1].positions = x1;
  bodies[2].positions = x1;
  bodies[2].active = false;
  CollisionFilter filter = CollisionFilter::from_bodies(bodies);
  filter.set(0, 1, false);
  SpatialHash hash;
  std::vector<VertexInTet> found;
  hash.detect(bodies, filter, found);
  EXPECT_TRUE(found.empty());
  EXPECT_EQ(hash.stats().hashed_vertices, 0);
  EXPECT_EQ(hash.stats().tets_visited, 0);
  bodies[2].active = true;  // body 2 now overlaps 0 and 1 (positions of 1)
  filter = CollisionFilter::from_bodies(bodies);
  filter.set(0, 1, false);
  filter.set(1, 2, false);
  hash.detect(bodies, filter, found);
  EXPECT_EQ(hash.stats().hashed_vertices, 2 * mesh->vertex_count());
  expect_same(found, brute_force(bodies, filter), bodies);
  EXPECT_FALSE(found.empty());
}

}  // namespace
}  // namespace pliant

// Counts heap allocations in this test executable (replaces the global operator new).
#include "support/allocation_counter.h"

namespace pliant {
namespace {

TEST(SpatialHash, NoAllocationPerStepAfterWarmUp) {
  const auto mesh = make_box_mesh({Vec3(0.3, 0.3, 0.3), 4, 4, 4});
  std::vector<std::vector<Vec3>> x;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  for (int b = 0; b < 4; ++b) x.push_back(posed(*mesh, random_rotation(rng), Vec3(u(rng), u(rng), u(rng))));
  std::vector<CollisionBody> bodies(4);
  for (int b = 0; b < 4; ++b) {
    bodies[static_cast<size_t>(b)].mesh = mesh.get();
    bodies[static_cast<size_t>(b)].positions = x[static_cast<size_t>(b)];
  }
  const CollisionFilter filter = CollisionFilter::from_bodies(bodies);
  SpatialHash hash;
  std::vector<VertexInTet> found;
  hash.detect(bodies, filter, found);  // warm-up
  const size_t warm = found.size();
  ASSERT_GT(warm, 0u);
  // Later steps with moved (not grown) content allocate nothing.
  for (int step = 0; step < 5; ++step) {
    for (auto& p : x[0]) p += Vec3(1e-3, 0.0, 0.0);
    found.reserve(2 * warm);
    const long long before = testing::g_allocations.load();
    hash.detect(bodies, filter, found);
    EXPECT_EQ(testing::g_allocations.load(), before) << step;
  }
}

TEST(CollisionFilter, RebuiltInPlaceEqualsFromBodiesWithoutAllocating) {
  // The world rebuilds its filter every step: in place it must equal a new filter from the same
  // bodies (groups, masks, active and self-collision flags), and allocate nothing once grown.
  std::mt19937 rng(12);
  std::uniform_int_distribution<unsigned> bits(0u, 3u);
  std::bernoulli_distribution coin(0.3);
  CollisionFilter in_place;
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<CollisionBody> bodies(static_cast<size_t>(1 + trial % 6));
    for (auto& b : bodies) {
      b.active = !coin(rng);
      b.self_collision = coin(rng);
      b.collision_group = 1u << bits(rng);
      b.collision_mask = coin(rng) ? ~0u : (1u << bits(rng));
    }
    const CollisionFilter fresh = CollisionFilter::from_bodies(bodies);
    const long long before = testing::g_allocations.load();
    in_place.assign_from_bodies(bodies);
    if (trial >= 6) {  // grown to 6 bodies
      EXPECT_EQ(testing::g_allocations.load(), before) << trial;
    }
    ASSERT_EQ(in_place.body_count(), fresh.body_count());
    for (int a = 0; a < fresh.body_count(); ++a) {
      for (int b = 0; b < fresh.body_count(); ++b) EXPECT_EQ(in_place.allowed(a, b), fresh.allowed(a, b)) << a << b;
    }
  }
}

}  // namespace
}  // namespace pliant
