// x mod d for a divisor fixed at run time, by multiplication instead of a 64-bit division.
//
// Design note (session 10, docs/collision-detection.md). The spatial hash reduces every cell key
// modulo its prime table size once per cell look-up, and the division's latency sits in front of
// the bucket load (the piled fruit dish's detect stage is mostly such look-ups). Lemire, Kaser and Kurz, "Faster
// remainder by direct computation" (Software: Practice and Experience 49(6), 2019), section 4:
// with M = ceil(2^128 / d), x mod d = floor(((M x) mod 2^128) d / 2^128) for every 64-bit x and
// 1 < d < 2^64 (their F = 128 >= N + log2 d bits). Exact: the same remainder as x % d, not an
// approximation (tests/sim/prime_modulus_test.cpp checks it against % over random and edge keys).
#pragma once

#include <cassert>
#include <cstdint>

namespace pliant {

/// Remainders by a fixed divisor d > 1, equal to x % d for every 64-bit x.
class PrimeModulus {
 public:
  __extension__ typedef unsigned __int128 Wide;  ///< GCC/Clang 128-bit unsigned (no ISO type)

  PrimeModulus() = default;
  /// Precomputes M = ceil(2^128 / d) for the divisor d (> 1).
  explicit PrimeModulus(std::uint64_t d) : divisor_(d), magic_(~Wide{0} / d + 1) { assert(d > 1); }

  /// x mod d.
  std::uint64_t of(std::uint64_t x) const {
    const Wide fraction = magic_ * x;  // (M x) mod 2^128: the fractional part of x / d
    const auto low = static_cast<std::uint64_t>(fraction);
    const auto high = static_cast<std::uint64_t>(fraction >> 64);
    // The top 64 bits of the 192-bit product fraction * d.
    const Wide carry = (static_cast<Wide>(low) * divisor_) >> 64;
    return static_cast<std::uint64_t>((static_cast<Wide>(high) * divisor_ + carry) >> 64);
  }
  /// The divisor d.
  std::uint64_t divisor() const { return divisor_; }

 private:
  std::uint64_t divisor_ = 0;
  Wide magic_ = 0;
};

}  // namespace pliant
