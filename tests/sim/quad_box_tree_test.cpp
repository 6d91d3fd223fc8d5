// The 4-wide box tree of the fan query (sim/collision/quad_box_tree.h) against the binary
// hierarchy it is collapsed from: for every query box, the same leaves in the same order, through
// builds, lazy refits (boxes kept, queries inflated), full refits and rebuilds.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "sim/collision/quad_box_tree.h"
#include "sim/collision/surface_bvh.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

Aabb box_around(const Vec3& c, const Vec3& half) {
  Aabb b;
  b.min = c - half;
  b.max = c + half;
  return b;
}

TEST(QuadBoxTree, FindsTheBinaryTraversalsLeavesInItsOrder) {
  if (!QuadBoxTree::available()) GTEST_SKIP() << "no AVX on this CPU: the fan query keeps the binary traversal";
  // Meshes from one cell (12 triangles, a shallow tree) to an uneven block (leaves of 1-4
  // triangles at several depths, so quad nodes have 2, 3 and 4 children).
  const BoxMeshSpec specs[] = {{Vec3(1.0, 1.0, 1.0), 1, 1, 1}, {Vec3(0.3, 0.2, 0.1), 2, 1, 1},
                               {Vec3(1.0, 0.6, 0.4), 10, 6, 4}, {Vec3(2.0, 0.5, 0.5), 17, 5, 3}};
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> jitter(-1.0, 1.0), unit(0.0, 1.0);
  long long queries = 0, nonempty = 0, leaves_found = 0, touching = 0;
  for (const BoxMeshSpec& spec : specs) {
    const auto mesh = make_box_mesh(spec);
    std::vector<Vec3> x = mesh->rest_positions();
    SurfaceBvh bvh;
    bvh.build(*mesh, x);
    std::vector<int> binary, quad;
    for (int pose = 0; pose < 9; ++pose) {
      if (pose > 0) {
        // Small (lazy), large (full refit) and large with a rebuild due.
        const double amplitude = pose % 3 == 0 ? 0.004 : (pose % 3 == 1 ? 0.05 : 0.0005);
        for (Vec3& p : x) p += amplitude * Vec3(jitter(rng), jitter(rng), jitter(rng));
        bvh.refit(x, 0.25, pose % 3 == 1 && pose > 4);
      }
      for (int q = 0; q < 400; ++q) {
        Aabb query;
        const Vec3& v = x[static_cast<size_t>(rng() % x.size())];
        switch (q % 5) {
          case 0: query = box_around(v, Vec3::Zero()); break;  // a point on the surface: boxes touch
          case 1: query = box_around(v, 0.1 * spec.size.minCoeff() * Vec3(unit(rng), unit(rng), unit(rng))); break;
          case 2: {  // a box whose face lies exactly on a surface vertex's coordinate
            query = box_around(v, 0.3 * spec.size.minCoeff() * Vec3::Ones());
            query.max[q % 3] = v[q % 3];
            break;
          }
          case 3: query = box_around(v, spec.size * unit(rng)); break;  // large
          default: query = box_around(v + spec.size.cwiseProduct(Vec3(jitter(rng), jitter(rng), jitter(rng))),
                                      0.05 * spec.size); break;  // anywhere, also outside
        }
        if (bvh.slack() > 0.0) {  // as the fan query inflates its box during a lazy step
          query.min.array() -= bvh.slack();
          query.max.array() += bvh.slack();
        }
        bvh.leaves_meeting(query, false, binary);
        bvh.leaves_meeting(query, true, quad);
        ASSERT_EQ(binary, quad) << "spec " << spec.nx << " pose " << pose << " query " << q;
        ++queries;
        nonempty += binary.empty() ? 0 : 1;
        leaves_found += static_cast<long long>(binary.size());
        touching += q % 5 == 0 && !binary.empty();
      }
    }
  }
  // The comparison saw real work: most queries found leaves, point queries on the surface touch
  // boxes exactly, and some large queries found many leaves.
  EXPECT_GT(nonempty, queries * 3 / 4);
  EXPECT_GT(touching, 1000);
  EXPECT_GT(leaves_found, 8 * queries);
}

TEST(QuadBoxTree, EmptySurfaceFindsNothing) {
  QuadBoxTree tree;
  struct BinaryNode {
    Aabb box;
    int first = 0;
    int count = 0;
  };
  tree.build(std::vector<BinaryNode>{});
  EXPECT_EQ(tree.leaf_count(), 0);
  if (QuadBoxTree::available()) {
    EXPECT_EQ(tree.leaves_meeting(box_around(Vec3::Zero(), Vec3::Ones()), nullptr), 0);
  }
}

}  // namespace
}  // namespace pliant
