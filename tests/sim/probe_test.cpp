// The probe step's fixed costs (issue #6): what detection looks at when nothing can be inside, and
// the rigid pass (a kinematic body's tets located in its rest frame) against the cell walk.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <random>

#include "sim/collision/spatial_hash.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

// Two one-cell bars crossing like a plus sign: their bounding boxes overlap in the middle, but no
// vertex of either lies inside the other's bounds, so pass 1 inserts nothing and no tet needs a
// cell lookup. Before the fix the empty partner bounds were extended to an infinite box and every
// tet of both bars was visited (the probe scene: 8,448 tets per step before first contact).
TEST(ProbeDetection, NoVertexInsidePartnerBoundsVisitsNoTet) {
  const auto bar_x = make_box_mesh({Vec3(0.3, 0.06, 0.06), 1, 1, 1});
  const auto bar_y = make_box_mesh({Vec3(0.1, 0.3, 0.1), 1, 1, 1});
  std::vector<CollisionBody> bodies(2);
  bodies[0].mesh = bar_x.get();
  bodies[0].positions = bar_x->rest_positions();
  bodies[1].mesh = bar_y.get();
  bodies[1].positions = bar_y->rest_positions();
  const CollisionFilter filter = CollisionFilter::from_bodies(bodies);
  SpatialHash hash;
  std::vector<VertexInTet> found;
  hash.detect(bodies, filter, found);
  EXPECT_TRUE(found.empty());  // brute force: no corner of one bar is inside the other
  EXPECT_EQ(hash.stats().inserted_vertices, 0);
  EXPECT_EQ(hash.stats().tets_visited, 0);

  // Shifted so that the x bar's end corners enter the y bar: found again, tets looked up.
  std::vector<Vec3> shifted(bar_x->rest_positions().begin(), bar_x->rest_positions().end());
  for (Vec3& p : shifted) p.x() += 0.19;  // corners at x = 0.04 and 0.34; the y bar spans |x| <= 0.05
  bodies[0].positions = shifted;
  hash.detect(bodies, filter, found);
  EXPECT_GT(hash.stats().inserted_vertices, 0);
  EXPECT_GT(hash.stats().tets_visited, 0);
  EXPECT_FALSE(found.empty());
}

// Same entries, bit for bit (barycentric coordinates compared as bytes).
void expect_identical(const std::vector<VertexInTet>& a, const std::vector<VertexInTet>& b, int trial) {
  ASSERT_EQ(a.size(), b.size()) << trial;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].body, b[i].body) << trial;
    EXPECT_EQ(a[i].vertex, b[i].vertex) << trial;
    EXPECT_EQ(a[i].penetrated_body, b[i].penetrated_body) << trial;
    EXPECT_EQ(a[i].tet, b[i].tet) << trial;
    EXPECT_EQ(std::memcmp(a[i].barycentric.data(), b[i].barycentric.data(), sizeof(double) * 4), 0) << trial;
  }
}

// A jittered "tissue" block and a rigid "probe" block at random poses pressed into it: detection
// with the probe's pose given (the rigid pass) finds exactly the cell walk's contacts (the second
// method, pose not given), in both directions, while testing fewer probe tets. With the probe's
// positions off its pose by more than the grid's pad, the hash falls back to the walk: same again.
TEST(ProbeDetection, RigidPassFindsTheCellWalksContactsBitForBit) {
  const auto tissue = make_box_mesh({Vec3(0.1, 0.1, 0.04), 8, 8, 4});
  const auto probe = make_box_mesh({Vec3(0.02, 0.02, 0.06), 4, 4, 12});
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g;
  long long rigid_tets = 0, walk_tets = 0;
  int contacts = 0;
  for (int trial = 0; trial < 40; ++trial) {
    std::vector<Vec3> xt(tissue->rest_positions().begin(), tissue->rest_positions().end());
    for (Vec3& p : xt) p += 1e-3 * Vec3(u(rng), u(rng), u(rng));
    Pose pose;
    pose.rotation = Quat(1.0 + 0.3 * g(rng), 0.3 * g(rng), 0.3 * g(rng), 0.3 * g(rng)).normalized();
    pose.translation = Vec3(0.03 * u(rng), 0.03 * u(rng), 0.02 + 0.01 * u(rng) + 0.3 * (trial % 2));
    std::vector<Vec3> xp;
    for (const Vec3& r : probe->rest_positions()) xp.push_back(pose.apply(r));
    std::vector<CollisionBody> bodies(2);
    bodies[0].mesh = tissue.get();
    bodies[0].positions = xt;
    bodies[1].mesh = probe.get();
    bodies[1].positions = xp;
    const CollisionFilter filter = CollisionFilter::from_bodies(bodies);
    SpatialHash hash;
    std::vector<VertexInTet> walk, rigid;
    hash.detect(bodies, filter, walk);
    // The walk's tets past its out-code and box rejects, looked up or (session 11) skipped for want
    // of a partner vertex in their cells: the work the rigid pass replaces (session 8's count).
    walk_tets += hash.stats().tets_visited + hash.stats().tets_skipped_unoccupied;
    bodies[1].rigid_pose = &pose;
    hash.detect(bodies, filter, rigid);
    rigid_tets += hash.stats().tets_visited;
    expect_identical(rigid, walk, trial);
    contacts += static_cast<int>(walk.size());

    // Positions 1 mm off the pose (far beyond the pad of ~2 um): the walk's result again.
    for (Vec3& p : xp) p.z() -= 1e-3;
    bodies[1].rigid_pose = nullptr;
    hash.detect(bodies, filter, walk);
    bodies[1].rigid_pose = &pose;
    hash.detect(bodies, filter, rigid);
    expect_identical(rigid, walk, trial);
  }
  EXPECT_GT(contacts, 200);  // the probe is in the tissue in half of the trials, with both bodies' vertices inside
  EXPECT_LT(rigid_tets, walk_tets);
  std::printf("rigid pass vs cell walk: %d contacts, tets visited %lld vs %lld\n", contacts, rigid_tets, walk_tets);
}

}  // namespace
}  // namespace pliant
