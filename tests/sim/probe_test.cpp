// The probe step's fixed costs (issue #6): what detection looks at when nothing can be inside.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace pliant
