// PrimeModulus (sim/collision/prime_modulus.h) against the % operator it replaces in the spatial
// hash: the same remainder for every key tried, so the hash's buckets are the same.
#include "sim/collision/prime_modulus.h"

#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "sim/collision/spatial_hash.h"

namespace pliant {
namespace {

std::vector<std::uint64_t> edge_keys(std::uint64_t d) {
  const std::uint64_t max = std::numeric_limits<std::uint64_t>::max();
  std::vector<std::uint64_t> keys = {0, 1, 2, d - 1, d, d + 1, 2 * d - 1, 2 * d, max, max - 1, max - d, max / d * d,
                                     max / d * d - 1, std::uint64_t{1} << 63, (std::uint64_t{1} << 63) - 1,
                                     std::uint64_t{1} << 32, (std::uint64_t{1} << 32) - 1};
  for (std::uint64_t m = 1; m < 1000; m = 3 * m + 1) {  // multiples of d and their neighbours
    if (m > max / d) break;
    keys.push_back(m * d);
    keys.push_back(m * d - 1);
    keys.push_back(m * d + 1);
  }
  return keys;
}

TEST(PrimeModulus, EqualsTheRemainderOperatorOnRandomAndEdgeKeys) {
  // Table sizes the hash uses (next primes above 3x a vertex count), and divisors up to 2^64 - 59,
  // the largest 64-bit prime, where the method's bound (128 >= 64 + log2 d bits) is tight.
  std::vector<std::uint64_t> divisors = {2, 3, 5, 7, 3001, 48247, 1000003, 4294967291ull, 4294967311ull,
                                         (std::uint64_t{1} << 61) - 1, 18446744073709551557ull};
  for (std::uint64_t n : {10ull, 100ull, 1000ull, 16078ull, 48234ull, 300000ull}) {
    divisors.push_back(SpatialHash::next_prime(3 * n + 1));
  }
  std::mt19937_64 random(20261122);
  for (const std::uint64_t d : divisors) {
    const PrimeModulus modulus(d);
    ASSERT_EQ(modulus.divisor(), d);
    for (const std::uint64_t x : edge_keys(d)) ASSERT_EQ(modulus.of(x), x % d) << "x " << x << " d " << d;
    for (int i = 0; i < 100000; ++i) {
      const std::uint64_t x = random();
      ASSERT_EQ(modulus.of(x), x % d) << "x " << x << " d " << d;
      const std::uint64_t small = x >> (i % 64);  // keys of every magnitude
      ASSERT_EQ(modulus.of(small), small % d) << "x " << small << " d " << d;
    }
  }
}

TEST(PrimeModulus, GivesTheSpatialHashsBucketsOfEveryCellAround) {
  // The buckets pass 1 and pass 2 use: cell keys of a block of cells around the origin and far out
  // (negative coordinates wrap mod 2^64), reduced as hash_cell reduces them.
  for (const std::uint64_t n : {SpatialHash::next_prime(3001), SpatialHash::next_prime(48234)}) {
    const PrimeModulus modulus(n);
    for (const int offset : {0, -1000000, 1000000000, -1000000000}) {
      for (int i = -12; i <= 12; ++i) {
        for (int j = -12; j <= 12; ++j) {
          for (int k = -12; k <= 12; ++k) {
            const std::uint64_t key = SpatialHash::cell_key(offset + i, j - offset, k);
            ASSERT_EQ(modulus.of(key), SpatialHash::hash_cell(offset + i, j - offset, k, n));
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace pliant
