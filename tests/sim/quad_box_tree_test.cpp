// The 4-wide box tree of the fan query (sim/collision/quad_box_tree.h) against the binary
// hierarchy it is collapsed from: for every query box, the same leaves in the same order, through
// builds, lazy refits (boxes kept, queries inflated), full refits and rebuilds; and its per-node
// box test (outward-rounded float boxes with a double re-test) against the double comparisons.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "sim/collision/quad_box_tree.h"
#include "sim/collision/surface_bvh.h"
#include "sim/mesh/box_mesh.h"
#include "support/fp_traps.h"

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

// The float test with its exact re-test decides every child as the double closed comparisons do
// (boxes_meet's <=, false for NaN), for box and query bounds placed at float rounding boundaries:
// equal to each other, one double ulp or one float ulp apart, exactly on a float or just off it,
// huge (beyond FLT_MAX), infinite and NaN.
TEST(QuadBoxTree, FloatBoxTestDecidesAsTheDoubleTest) {
  if (!QuadBoxTree::available()) GTEST_SKIP() << "no AVX on this CPU: the fan query keeps the binary traversal";
  // Infinities, NaN and values beyond the float range are injected on purpose.
  const testing::ScopedFpTrapsOff traps_off;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::mt19937 rng(14);
  std::uniform_real_distribution<double> coordinate(-2.0, 2.0);
  std::uniform_int_distribution<int> pick(0, 15);
  // A value near `base`: on it, one double or one float ulp either side, on the nearest floats,
  // or a special value.
  const auto near = [&](double base) {
    const float f = static_cast<float>(base);
    switch (pick(rng)) {
      case 0: case 1: case 2: return base;
      case 3: return std::nextafter(base, kInf);
      case 4: return std::nextafter(base, -kInf);
      case 5: case 6: return static_cast<double>(f);
      case 7: return static_cast<double>(std::nextafter(f, std::numeric_limits<float>::infinity()));
      case 8: return static_cast<double>(std::nextafter(f, -std::numeric_limits<float>::infinity()));
      case 9: return std::nextafter(static_cast<double>(f), kInf);
      case 10: return std::nextafter(static_cast<double>(f), -kInf);
      case 11: return base + 1e-9 * coordinate(rng);
      case 12: return coordinate(rng);
      default: {
        const double special[] = {kInf, -kInf, std::numeric_limits<double>::quiet_NaN(), 1e300, -1e300,
                                  static_cast<double>(FLT_MAX), std::nextafter(static_cast<double>(FLT_MAX), kInf),
                                  -static_cast<double>(FLT_MAX), 0.0, -0.0, 1e-320};
        return special[rng() % std::size(special)];
      }
    }
  };
  long long cases = 0, met = 0, close_met = 0, close_missed = 0;
  for (int round = 0; round < 200000; ++round) {
    Aabb query;
    for (int a = 0; a < 3; ++a) {
      const double c = coordinate(rng), h = 0.01 * std::abs(coordinate(rng));
      query.min[a] = pick(rng) == 0 ? near(c - h) : c - h;
      query.max[a] = pick(rng) == 0 ? near(c + h) : c + h;
    }
    double min[3][4], max[3][4];
    for (int k = 0; k < 4; ++k) {
      for (int a = 0; a < 3; ++a) {
        // Boxes whose faces lie at or next to the query's faces on this axis (touching, just apart,
        // just overlapping), or anywhere.
        const int kind = pick(rng) % 4;
        if (kind == 0) {
          min[a][k] = near(query.max[a]);
          max[a][k] = min[a][k] + 0.05;
        } else if (kind == 1) {
          max[a][k] = near(query.min[a]);
          min[a][k] = max[a][k] - 0.05;
        } else if (kind == 2) {
          min[a][k] = near(query.min[a]);
          max[a][k] = near(query.max[a]);
        } else {
          min[a][k] = near(coordinate(rng));
          max[a][k] = near(min[a][k] + 0.1);
        }
      }
    }
    int expected = 0;
    bool close = false;
    for (int k = 0; k < 4; ++k) {
      bool meets = true;
      for (int a = 0; a < 3; ++a) {
        meets = meets && min[a][k] <= query.max[a] && query.min[a] <= max[a][k];
        close = close || std::abs(min[a][k] - query.max[a]) < 1e-6 || std::abs(max[a][k] - query.min[a]) < 1e-6;
      }
      expected |= meets ? 1 << k : 0;
      met += meets ? 1 : 0;
    }
    ASSERT_EQ(QuadBoxTree::children_meeting(min, max, query), expected) << "round " << round;
    ++cases;
    if (close) (expected != 0 ? close_met : close_missed) += 1;
  }
  // Both outcomes occurred often with faces within a float ulp of each other (where the float test
  // alone cannot decide), and the boxes met in a good share of all cases.
  EXPECT_GT(close_met, cases / 10);
  EXPECT_GT(close_missed, cases / 20);
  EXPECT_GT(met, cases / 4);
}

// The outward roundings are the nearest floats on their side: float_below(d) <= d < the next float
// (std::nextafter), float_above symmetrically, for doubles near floats, zeros, denormals and
// values beyond the float range.
TEST(QuadBoxTree, OutwardRoundingIsTheNearestFloatOnItsSide) {
  const testing::ScopedFpTrapsOff traps_off;  // values beyond the float range on purpose
  constexpr float kInfF = std::numeric_limits<float>::infinity();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> values = {0.0, -0.0, 1e-320, -1e-320, 1e-46, -1e-46, 1e300, -1e300,
                                static_cast<double>(FLT_MAX), -static_cast<double>(FLT_MAX),
                                std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (int i = 0; i < 100000; ++i) {
    const double d = unit(rng) * std::pow(2.0, static_cast<int>(rng() % 80) - 40);
    const float f = static_cast<float>(d);
    values.insert(values.end(), {d, static_cast<double>(f), std::nextafter(static_cast<double>(f), 1e300),
                                 std::nextafter(static_cast<double>(f), -1e300)});
  }
  for (const double d : values) {
    const float below = QuadBoxTree::float_below(d), above = QuadBoxTree::float_above(d);
    ASSERT_LE(static_cast<double>(below), d) << d;
    ASSERT_GE(static_cast<double>(above), d) << d;
    if (std::isfinite(d)) {  // an infinite d is its own rounding
      ASSERT_GT(static_cast<double>(std::nextafter(below, kInfF)), d) << d;
      ASSERT_LT(static_cast<double>(std::nextafter(above, -kInfF)), d) << d;
    }
    if (below < kInfF && below > -kInfF) {
      ASSERT_EQ(QuadBoxTree::float_step_up(below), std::nextafter(below, kInfF));
    }
    if (above < kInfF && above > -kInfF) {
      ASSERT_EQ(QuadBoxTree::float_step_down(above), std::nextafter(above, -kInfF));
    }
  }
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
