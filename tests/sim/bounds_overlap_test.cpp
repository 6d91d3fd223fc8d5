// BoundsOverlap against the all-pairs loop: for every body, exactly the bodies whose boxes overlap
// its own (Aabb::overlaps, closed), ascending. Boxes on a coarse dyadic grid so that shared faces,
// edges and corners (the closed test's edge cases, and pairs whose intersection corner lies on a
// cell boundary) happen often; some huge boxes (the grid's large list), points, empty and excluded
// boxes, and non-finite ones.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "sim/collision/bounds_overlap.h"
#include "sim/collision/cell_coordinate.h"
#include "support/fp_traps.h"

namespace pliant {
namespace {

std::vector<int> all_pairs_partners(const std::vector<Aabb>& boxes, const std::vector<char>& include, size_t i) {
  std::vector<int> out;
  if (!include[i] || boxes[i].empty()) return out;
  for (size_t j = 0; j < boxes.size(); ++j) {
    if (j == i || !include[j] || boxes[j].empty()) continue;
    if (boxes[i].overlaps(boxes[j])) out.push_back(static_cast<int>(j));
  }
  return out;
}

void expect_all_pairs(const BoundsOverlap& overlap, const std::vector<Aabb>& boxes, const std::vector<char>& include,
                      int round) {
  for (size_t i = 0; i < boxes.size(); ++i) {
    const auto got = overlap.overlapping(static_cast<int>(i));
    const std::vector<int> expected = all_pairs_partners(boxes, include, i);
    ASSERT_EQ(std::vector<int>(got.begin(), got.end()), expected) << "round " << round << " body " << i;
  }
}

// A box with corners in {0, 1/8, ..., 8}: sizes of a few cells, so boxes touch often.
Aabb grid_box(std::mt19937& rng, int max_size) {
  std::uniform_int_distribution<int> corner(0, 64), size(0, max_size);
  const Vec3 lo(corner(rng), corner(rng), corner(rng));
  const Vec3 hi = lo + Vec3(size(rng), size(rng), size(rng));
  Aabb box;
  box.extend(lo / 8.0);
  box.extend(hi / 8.0);
  return box;
}

TEST(BoundsOverlap, EqualsTheAllPairsLoopOnManyBoxesWithTouchingLargeAndEmptyOnes) {
  std::mt19937 rng(1717);
  BoundsOverlap overlap;  // reused: nothing of one round may leak into the next
  long long overlapping = 0, tested = 0, all_pairs = 0;
  for (int round = 0; round < 120; ++round) {
    const int n = 1 + round * 5 % 400;  // 1 to ~400 boxes: both the pair loop and the grid
    std::vector<Aabb> boxes(static_cast<size_t>(n));
    std::vector<char> include(static_cast<size_t>(n), 1);
    std::uniform_int_distribution<int> kind(0, 39);
    for (size_t i = 0; i < boxes.size(); ++i) {
      const int k = kind(rng);
      if (k == 0) {
        boxes[i] = Aabb{};  // empty (a body whose vertices are all NaN)
      } else if (k == 1) {
        boxes[i] = grid_box(rng, 64);  // huge: the large list
      } else if (k == 2) {
        boxes[i] = grid_box(rng, 0);  // a point
      } else if (k == 3) {
        include[i] = 0;  // not taking part
        boxes[i] = grid_box(rng, 8);
      } else if (k == 4 && round % 3 == 0) {
        boxes[i] = grid_box(rng, 8);
        boxes[i].max.x() = std::numeric_limits<double>::infinity();  // a body flung to infinity
      } else {
        boxes[i] = grid_box(rng, 8);
      }
    }
    overlap.compute(boxes, include);
    expect_all_pairs(overlap, boxes, include, round);
    for (size_t i = 0; i < boxes.size(); ++i) overlapping += static_cast<long long>(overlap.overlapping(static_cast<int>(i)).size());
    tested += overlap.pairs_tested();
    all_pairs += static_cast<long long>(n) * (n - 1) / 2;
  }
  EXPECT_GT(overlapping, 1000);      // the rounds do have overlaps to find
  EXPECT_LT(tested, all_pairs / 2);  // and the grid compares far fewer pairs than all of them
}

// Bodies on a lattice (the collision benchmark's layout): each body overlaps its lattice
// neighbours only, and the number of compared pairs grows linearly with the bodies.
TEST(BoundsOverlap, LatticeComparesPairsInProportionToTheBodies) {
  BoundsOverlap overlap;
  for (int side : {4, 8}) {
    std::vector<Aabb> boxes;
    for (int x = 0; x < side; ++x) {
      for (int y = 0; y < side; ++y) {
        for (int z = 0; z < side; ++z) {
          Aabb box;
          box.extend(Vec3(x, y, z) * 0.9);
          box.extend(Vec3(x, y, z) * 0.9 + Vec3::Ones());
          boxes.push_back(box);
        }
      }
    }
    std::vector<char> include(boxes.size(), 1);
    overlap.compute(boxes, include);
    expect_all_pairs(overlap, boxes, include, side);
    // An interior body overlaps its 26 lattice neighbours.
    const int interior = (1 * side + 1) * side + 1;
    EXPECT_EQ(overlap.overlapping(interior).size(), 26u);
    EXPECT_LT(overlap.pairs_tested(), 60 * static_cast<long long>(boxes.size()));
  }
}

// The grids' cell coordinate is floor, clamped to +-1e9, with NaN in the lowest cell: against
// std::floor on integers, halves, values next to integers (both signs), zeros, huge and non-finite
// values. (Truncation instead of floor would still be monotone and pass every detection test;
// here it fails.)
TEST(CellCoordinate, IsTheClampedFloor) {
  std::vector<double> values = {0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.5, -2.5, 1e9, -1e9, 1e9 + 0.5, -1e9 - 0.5,
                                3e9, -3e9, 1e300, -1e300, std::numeric_limits<double>::infinity(),
                                -std::numeric_limits<double>::infinity(), std::numeric_limits<double>::denorm_min(),
                                -std::numeric_limits<double>::denorm_min()};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1e4, 1e4);
  for (int k = -1000; k <= 1000; ++k) {
    values.push_back(k);
    values.push_back(std::nextafter(static_cast<double>(k), 1e10));
    values.push_back(std::nextafter(static_cast<double>(k), -1e10));
  }
  for (int k = 0; k < 10000; ++k) values.push_back(u(rng));
  for (double v : values) {
    const double expected = std::max(-1.0e9, std::min(std::floor(v), 1.0e9));
    ASSERT_EQ(cell_coordinate(v, 1.0), static_cast<int>(expected)) << v;
  }
  testing::ScopedFpTrapsOff traps_off;  // the NaN is on purpose
  EXPECT_EQ(cell_coordinate(std::numeric_limits<double>::quiet_NaN(), 1.0), -1000000000);
  EXPECT_EQ(cell_coordinate(-0.75, 2.0), -2);  // -1.5 -> -2
}

TEST(BoundsOverlap, NoBoxesAndOneBox) {
  BoundsOverlap overlap;
  overlap.compute({}, {});
  std::vector<Aabb> one(1);
  one[0].extend(Vec3::Zero());
  const std::vector<char> include(1, 1);
  overlap.compute(one, include);
  EXPECT_TRUE(overlap.overlapping(0).empty());
}

}  // namespace
}  // namespace pliant
