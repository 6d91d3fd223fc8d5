// all_coordinates_finite against Eigen's allFinite on every entry (the check World::step used before
// session 18): arrays of 0..40 vectors with one NaN, +inf or -inf placed at every coordinate in turn,
// among finite values up to the largest double (whose sums would overflow) and signed zeros.
#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <vector>

#include "sim/finite_coordinates.h"
#include "support/fp_traps.h"

namespace pliant {
namespace {

bool each_entry_all_finite(const std::vector<Vec3>& v) {
  for (const Vec3& x : v) {
    if (!x.allFinite()) return false;
  }
  return true;
}

TEST(FiniteCoordinates, AnswerAsAllFiniteOnEveryEntry) {
  testing::ScopedFpTrapsOff traps_off;  // the NaNs and infinities are on purpose
  std::mt19937 rng(18);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double big = std::numeric_limits<double>::max();
  const double bad[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                        -std::numeric_limits<double>::infinity()};
  int finite_arrays = 0, bad_arrays = 0;
  for (size_t size = 0; size <= 40; ++size) {
    std::vector<Vec3> v(size);
    for (Vec3& x : v) {
      for (int k = 0; k < 3; ++k) {
        const double u = unit(rng);
        x[k] = u > 0.8 ? big : (u < -0.8 ? -big : (u > 0.7 ? -0.0 : u));
      }
    }
    ASSERT_TRUE(each_entry_all_finite(v));
    ASSERT_EQ(all_coordinates_finite(v), each_entry_all_finite(v)) << size;
    ++finite_arrays;
    for (size_t i = 0; i < size; ++i) {
      for (int k = 0; k < 3; ++k) {
        for (double b : bad) {
          const double kept = v[i][k];
          v[i][k] = b;
          ASSERT_FALSE(each_entry_all_finite(v));
          ASSERT_EQ(all_coordinates_finite(v), each_entry_all_finite(v)) << size << " " << i << " " << k;
          v[i][k] = kept;
          ++bad_arrays;
        }
      }
    }
  }
  EXPECT_EQ(finite_arrays, 41);
  EXPECT_EQ(bad_arrays, 3 * 3 * (40 * 41 / 2));
}

}  // namespace
}  // namespace pliant
