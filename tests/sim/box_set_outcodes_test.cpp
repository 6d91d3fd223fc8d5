// BoxSetOutcodes against the direct test: a tet misses every box exactly when the box of its four
// corners overlaps none of them (Aabb::overlaps, closed). Corners and boxes lie on a coarse grid so
// that shared faces, edges and corners (the closed test's edge cases) happen often.
#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <vector>

#include "sim/collision/box_set_outcodes.h"
#include "support/fp_traps.h"

namespace pliant {
namespace {

// A point with coordinates in {0, 1/8, ..., 1}.
Vec3 grid_point(std::mt19937& rng) {
  std::uniform_int_distribution<int> step(0, 8);
  return Vec3(step(rng), step(rng), step(rng)) / 8.0;
}

Aabb grid_box(std::mt19937& rng) {
  Aabb box;
  box.extend(grid_point(rng));
  box.extend(grid_point(rng));
  return box;
}

bool meets_some(const Aabb& tet_box, const std::vector<Aabb>& boxes) {
  for (const Aabb& box : boxes) {
    if (tet_box.overlaps(box)) return true;
  }
  return false;
}

TEST(BoxSetOutcodes, RejectsExactlyTheTetsWhoseBoxMeetsNoBox) {
  std::mt19937 rng(1616);
  BoxSetOutcodes codes;  // reused: boxes and codes of one round must not leak into the next
  long long rejected = 0, kept = 0, touching = 0;
  for (int round = 0; round < 200; ++round) {
    std::vector<Aabb> boxes(static_cast<size_t>(round % 13));  // 0 to 12 boxes, small ones: one word per vertex up to 8
    codes.clear_boxes();
    for (Aabb& box : boxes) {
      box = grid_box(rng);
      box.max = box.min + 0.5 * (box.max - box.min);  // halve it: more tets miss
      codes.add_box(box);
    }
    std::vector<Vec3> points(40);
    for (Vec3& p : points) p = grid_point(rng);
    codes.assign_codes(points);
    std::uniform_int_distribution<int> pick(0, static_cast<int>(points.size()) - 1);
    for (int t = 0; t < 100; ++t) {
      const TetIndices tet = {pick(rng), pick(rng), pick(rng), pick(rng)};
      Aabb tet_box;
      for (int k : tet) tet_box.extend(points[static_cast<size_t>(k)]);
      const bool meets = meets_some(tet_box, boxes);
      ASSERT_EQ(codes.misses_every_box(tet), !meets) << round << " " << t;
      (meets ? kept : rejected) += 1;
      // Count the tets that only touch a box (a shared face, edge or corner).
      bool touches = false;
      for (const Aabb& box : boxes) {
        touches = touches || (tet_box.overlaps(box) && ((tet_box.max.array() == box.min.array()).any() ||
                                                        (tet_box.min.array() == box.max.array()).any()));
      }
      touching += touches ? 1 : 0;
    }
  }
  EXPECT_GT(rejected, 2000);  // both answers are common
  EXPECT_GT(kept, 2000);
  EXPECT_GT(touching, 500);   // and the closed boundary is exercised
}

// Session 18: the range search first_tet_meeting_a_box finds, from every start, the first tet
// whose box meets some box (the direct test), with 0 to 12 boxes (one box: its own loop) and NaN
// corners among the points; so the hash's pass 2 visits the tets it visited with misses_every_box.
TEST(BoxSetOutcodes, RangeSearchFindsTheFirstMeetingTetFromEveryStart) {
  std::mt19937 rng(1818);
  testing::ScopedFpTrapsOff traps_off;  // the NaN corners are on purpose (ordered comparisons with them are invalid)
  BoxSetOutcodes codes;
  long long found = 0, none = 0, one_box_rounds = 0;
  for (int round = 0; round < 260; ++round) {
    std::vector<Aabb> boxes(static_cast<size_t>(round % 13));
    one_box_rounds += boxes.size() == 1 ? 1 : 0;
    codes.clear_boxes();
    for (Aabb& box : boxes) {
      box = grid_box(rng);
      box.max = box.min + 0.5 * (box.max - box.min);
      codes.add_box(box);
    }
    std::vector<Vec3> points(40);
    for (Vec3& p : points) p = grid_point(rng);
    if (round % 5 == 0) points[3].y() = std::numeric_limits<double>::quiet_NaN();
    codes.assign_codes(points);
    std::uniform_int_distribution<int> pick(0, static_cast<int>(points.size()) - 1);
    std::vector<TetIndices> tets(1 + static_cast<size_t>(round % 23));
    std::vector<char> meets(tets.size());
    for (size_t t = 0; t < tets.size(); ++t) {
      tets[t] = {pick(rng), pick(rng), pick(rng), pick(rng)};
      Aabb tet_box;
      bool nan_corner = false;
      for (int k : tets[t]) {
        tet_box.extend(points[static_cast<size_t>(k)]);
        nan_corner = nan_corner || !points[static_cast<size_t>(k)].allFinite();
      }
      // The direct test where the corners are numbers; with a NaN corner the per-tet decision (a
      // NaN sets no bit on its axis; the other axes still decide).
      meets[t] = codes.misses_every_box(tets[t]) ? 0 : 1;
      if (!nan_corner) {
        ASSERT_EQ(meets[t] != 0, meets_some(tet_box, boxes)) << round << " " << t;
      }
    }
    for (size_t first = 0; first <= tets.size(); ++first) {
      size_t expected = first;
      while (expected < tets.size() && meets[expected] == 0) ++expected;
      ASSERT_EQ(codes.first_tet_meeting_a_box(tets, first), expected) << round << " " << first;
      (expected < tets.size() ? found : none) += 1;
    }
  }
  EXPECT_GT(found, 1000);
  EXPECT_GT(none, 400);
  EXPECT_EQ(one_box_rounds, 20);
}

// Past 64 boxes the rest are merged into the last: never a tet rejected that meets a box (exact for
// the hash), and the first 63 boxes still reject as before.
TEST(BoxSetOutcodes, MoreThanSixtyFourBoxesStillNeverRejectAMeetingTet) {
  std::mt19937 rng(64);
  BoxSetOutcodes codes;
  std::vector<Aabb> boxes(100);
  for (size_t k = 0; k < boxes.size(); ++k) {
    // Points: most tets miss all 100. Those past the 63rd near one corner, so their merged box is small.
    boxes[k].min = k < BoxSetOutcodes::max_boxes - 1 ? grid_point(rng) : grid_point(rng) / 8.0;
    boxes[k].max = boxes[k].min;
    codes.add_box(boxes[k]);
  }
  EXPECT_EQ(codes.box_count(), BoxSetOutcodes::max_boxes);
  std::vector<Vec3> points(200);
  for (Vec3& p : points) p = grid_point(rng) + Vec3(0.0625, 0.0625, 0.0625);  // off the boxes' grid
  codes.assign_codes(points);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(points.size()) - 1);
  Aabb merged;
  for (size_t k = BoxSetOutcodes::max_boxes - 1; k < boxes.size(); ++k) {
    merged.extend(boxes[k].min);
    merged.extend(boxes[k].max);
  }
  std::vector<Aabb> held(boxes.begin(), boxes.begin() + BoxSetOutcodes::max_boxes - 1);
  held.push_back(merged);
  int rejected = 0;
  for (int t = 0; t < 20000; ++t) {
    const TetIndices tet = {pick(rng), pick(rng), pick(rng), pick(rng)};
    Aabb tet_box;
    for (int k : tet) tet_box.extend(points[static_cast<size_t>(k)]);
    const bool rejects = codes.misses_every_box(tet);
    if (rejects) {
      ASSERT_FALSE(meets_some(tet_box, boxes)) << t;
    }
    ASSERT_EQ(rejects, !meets_some(tet_box, held)) << t;
    rejected += rejects ? 1 : 0;
  }
  EXPECT_GT(rejected, 100);
}

// A coordinate that is not a number compares false: it sets no bit on its axis, so a corner that is
// not a number at all keeps its tet (the hash then looks it up, and the inside test finds nothing
// there). No box at all: every tet is rejected.
TEST(BoxSetOutcodes, NotANumberCornerKeepsItsTetAndNoBoxRejectsAll) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  testing::ScopedFpTrapsOff traps_off;  // the NaN is on purpose (an ordered comparison with it is invalid)
  BoxSetOutcodes codes;
  Aabb box;
  box.extend(Vec3(0, 0, 0));
  box.extend(Vec3(1, 1, 1));
  codes.add_box(box);
  const std::vector<Vec3> points = {Vec3(2, 2, 2), Vec3(3, 2, 2), Vec3(2, 3, 2), Vec3(2, 2, 3), Vec3(nan, nan, nan)};
  codes.assign_codes(points);
  EXPECT_TRUE(codes.misses_every_box({0, 1, 2, 3}));
  EXPECT_FALSE(codes.misses_every_box({4, 1, 2, 3}));
  codes.clear_boxes();
  codes.assign_codes(points);
  EXPECT_EQ(codes.box_count(), 0);
  EXPECT_TRUE(codes.misses_every_box({4, 1, 2, 3}));
}

}  // namespace
}  // namespace pliant
