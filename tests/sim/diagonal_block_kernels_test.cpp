// The implicit step's diagonal system blocks checked and inverted in AVX2 lanes (session 11,
// sim/model/diagonal_block_kernels.h) against the scalar code they replace (Eigen's determinant()
// and inverse() with CorotationalFem::advance's SSOR test, written out here): every lane performs
// Eigen's operations in Eigen's order, so every block, inverse and verdict must be the scalar's bit
// for bit. Blocks of four kinds: symmetric positive definite (the step's own), random entries over
// 24 decades (indefinite, negative determinants), singular (a zero or repeated row), fixed vertices.
// Skipped where the kernel does not run (no AVX2, or a -march=native build).
#include <gtest/gtest.h>

#include <cfenv>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "sim/model/diagonal_block_kernels.h"
#include "support/fp_traps.h"

namespace pliant {
namespace {

bool same_bits(const Mat3& a, const Mat3& b) { return std::memcmp(a.data(), b.data(), sizeof(Mat3)) == 0; }

struct RandomBlocks {
  std::mt19937_64 rng{11};
  std::uniform_real_distribution<double> unit{-1.0, 1.0};
  std::uniform_int_distribution<int> decade{-12, 12};
  std::uniform_int_distribution<int> kind{0, 9};
  double entry() { return unit(rng) * std::pow(10.0, decade(rng)); }
  Mat3 block() {
    Mat3 D;
    const int k = kind(rng);
    if (k < 5) {  // symmetric positive definite: m I + B B^T, as the step's M + h (beta + h) K'
      Mat3 B;
      for (int i = 0; i < 9; ++i) B.data()[i] = unit(rng);
      D = std::pow(10.0, decade(rng) / 4) * Mat3(B * B.transpose()) + std::abs(unit(rng)) * Mat3::Identity();
    } else if (k < 8) {  // random entries: indefinite, negative or huge determinants
      for (int i = 0; i < 9; ++i) D.data()[i] = entry();
    } else if (k == 8) {  // singular: a zero row
      for (int i = 0; i < 9; ++i) D.data()[i] = entry();
      D.row(std::uniform_int_distribution<int>(0, 2)(rng)).setZero();
    } else {  // singular: two equal rows
      for (int i = 0; i < 9; ++i) D.data()[i] = entry();
      D.row(1) = D.row(0);
    }
    return D;
  }
};

// CorotationalFem::advance's loop before session 11.
bool scalar_blocks(const std::vector<Mat3>& blocks, const std::vector<char>& fixed, std::vector<Mat3>& diagonal,
                   std::vector<Mat3>& inverses) {
  bool ssor = true;
  for (size_t i = 0; i < blocks.size(); ++i) {
    const Mat3 Di = blocks[i];
    const double det = Di.determinant();
    const bool is_fixed = fixed[i] != 0;
    ssor = ssor && (is_fixed || (det > 0.0 && Di(0, 0) > 0.0 && Di(0, 0) * Di(1, 1) > Di(0, 1) * Di(1, 0)));
    diagonal[i] = is_fixed ? Mat3::Identity() : Di;
    inverses[i] = (is_fixed || !(det > 0.0)) ? Mat3::Zero() : Mat3(Di.inverse());
  }
  return ssor;
}

TEST(DiagonalBlockKernels, InversesAndTheSsorTestEqualTheScalarCodeBitForBit) {
  if (!diagonal_block_kernels_available()) GTEST_SKIP() << "kernel off (no AVX2, or a native build)";
  RandomBlocks r;
  std::uniform_int_distribution<int> count(1, 11);
  std::bernoulli_distribution fixed_vertex(0.1), all_definite(0.5);
  int verdicts[2] = {0, 0};
  for (int s = 0; s < 30000; ++s) {
    const auto n = static_cast<size_t>(count(r.rng));
    const bool definite = all_definite(r.rng);  // half the samples: only the step's kind of block
    std::vector<Mat3> blocks(n), diagonal(n), inverses(n), expected_diagonal(n), expected_inverses(n);
    std::vector<char> fixed(n);
    for (size_t i = 0; i < n; ++i) {
      do {
        blocks[i] = r.block();
      } while (definite && !(blocks[i].determinant() > 0.0 && blocks[i](0, 0) > 0.0));
      fixed[i] = fixed_vertex(r.rng) ? 1 : 0;
    }
    // The reference with traps off, noting whether it raised (a singular block whose determinant()
    // rounds above 0 while the inverse's own determinant is 0 divides by zero in the scalar code).
    bool expected = false, scalar_raised = false;
    {
      const testing::ScopedFpTrapsOff traps_off;
      expected = scalar_blocks(blocks, fixed, expected_diagonal, expected_inverses);
      scalar_raised = std::fetestexcept(testing::kTrappedExceptions) != 0;
    }
    ++verdicts[expected ? 1 : 0];
    // In place, as advance calls it (the inverses overwrite the blocks); with the traps on unless
    // the scalar code raised too: the lanes must not raise where the scalar code does not.
    inverses = blocks;
    bool passes = false;
    if (scalar_raised) {
      const testing::ScopedFpTrapsOff traps_off;
      passes = invert_diagonal_blocks_avx2(inverses.data(), fixed.data(), n, diagonal.data(), inverses.data());
    } else {
      passes = invert_diagonal_blocks_avx2(inverses.data(), fixed.data(), n, diagonal.data(), inverses.data());
    }
    ASSERT_EQ(passes, expected) << "sample " << s;
    for (size_t i = 0; i < n; ++i) {
      ASSERT_TRUE(same_bits(diagonal[i], expected_diagonal[i])) << "sample " << s << " block " << i;
      ASSERT_TRUE(same_bits(inverses[i], expected_inverses[i]))
          << "sample " << s << " block " << i << " of " << n << "\n"
          << blocks[i] << "\n"
          << inverses[i] - expected_inverses[i];
    }
  }
  // Both verdicts occur often (the test would not see a wrong mask otherwise).
  EXPECT_GT(verdicts[0], 3000);
  EXPECT_GT(verdicts[1], 3000);
}

}  // namespace
}  // namespace pliant
