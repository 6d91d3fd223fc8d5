// Session 18: the exact SSOR sweep's forward products by gathering (sim/model/exact_sweep_kernels.h)
// against the scatter loop they replace (corotational_fem.cpp's SsorSweeps::forward and
// lower_product_norm_sq with fused_scatter_row, written out here with the same Eigen expressions), on
// random upper-triangle patterns with fixed rows, blocks with exact zeros, -0 and mixed magnitudes:
// every result bit for bit. Skipped without AVX2/FMA.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "sim/math_types.h"
#include "sim/model/exact_sweep_kernels.h"
#include "sim/model/fused_ssor_kernels.h"
#include "support/random_block_pattern.h"

namespace pliant {
namespace {

bool same_bits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

TEST(ExactSweepKernels, GatheredForwardSweepAndResidualRowsEqualTheScatterBitForBit) {
  if (!exact_sweep_kernels_available() || !fused_sweeps_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  std::mt19937 rng(1818);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, 15);
  const auto entry = [&]() { return random_block_entry(rng, pick, unit, 1e6, 1e-7); };
  const auto matrix = [&]() {
    Mat3 M;
    for (int k = 0; k < 9; ++k) M.data()[k] = entry();
    return M;
  };
  int rows_checked = 0, fixed_rows = 0;
  for (int round = 0; round < 300; ++round) {
    const size_t n = 1 + static_cast<size_t>(round % 41);
    auto [offsets, cols] = random_upper_block_pattern(n, rng, pick);
    std::vector<double> blocks(9 * cols.size());
    for (double& e : blocks) e = entry();
    std::vector<char> fixed(n);
    std::vector<Mat3> D(n), D_inverse(n);
    std::vector<Vec3> r(n), x(n);
    for (size_t i = 0; i < n; ++i) {
      fixed[i] = pick(rng) < 3 ? 1 : 0;
      fixed_rows += fixed[i];
      D[i] = matrix();
      D_inverse[i] = matrix();
      r[i] = Vec3(entry(), entry(), entry());
      x[i] = fixed[i] != 0 ? Vec3::Zero() : Vec3(entry(), entry(), entry());  // the residual is zero there
    }
    const double s = 1e-3 * (1.0 + unit(rng));

    // Reference: the scatter loops of SsorSweeps (forward with r in and out; lower_product_norm_sq).
    std::vector<Vec3> r_ref = r, acc(n, Vec3::Zero()), w_ref(n, Vec3::Zero());
    for (size_t i = 0; i < n; ++i) {
      if (fixed[i] != 0) continue;
      const Vec3 y = D_inverse[i] * (r_ref[i] - acc[i]);
      r_ref[i] = y;
      fused_scatter_row(blocks.data(), cols.data(), static_cast<size_t>(offsets[i]) + 1,
                        static_cast<size_t>(offsets[i + 1]), s * y.x(), s * y.y(), s * y.z(), acc.data()->data());
    }
    std::fill(acc.begin(), acc.end(), Vec3::Zero());
    double sum_ref = 0.0;
    for (size_t i = 0; i < n; ++i) {
      if (fixed[i] != 0) continue;
      w_ref[i] = D[i] * x[i] + acc[i];
      sum_ref += w_ref[i].squaredNorm();
      fused_scatter_row(blocks.data(), cols.data(), static_cast<size_t>(offsets[i]) + 1,
                        static_cast<size_t>(offsets[i + 1]), s * x[i].x(), s * x[i].y(), s * x[i].z(),
                        acc.data()->data());
    }

    const LowerTrianglePattern lower = lower_triangle_pattern(offsets.data(), cols.data(), n);
    std::vector<double> transposed(9 * lower.rows.size() + 4);
    transpose_lower_blocks(blocks.data(), lower.upper_blocks.data(), lower.rows.data(), fixed.data(),
                           lower.rows.size(), transposed.data());
    const GatheredSweepSystem sys{transposed.data(), lower.row_entries.data(), lower.offsets.data(),
                                  D.data()->data(),  D_inverse.data()->data(), fixed.data(), s, n};
    std::vector<Vec3> r_gathered = r, scratch(n, Vec3::Constant(7.0)), w(n, Vec3::Zero());
    exact_forward_sweep_gathered(sys, r_gathered.data()->data(), scratch.data()->data());
    ASSERT_TRUE(same_bits(r_gathered, r_ref)) << "forward sweep differs in round " << round;
    std::fill(scratch.begin(), scratch.end(), Vec3::Constant(7.0));
    exact_lower_product_rows_gathered(sys, x.data()->data(), scratch.data()->data(), w.data()->data());
    ASSERT_TRUE(same_bits(w, w_ref)) << "residual rows differ in round " << round;
    double sum = 0.0;
    for (size_t i = 0; i < n; ++i) {
      if (fixed[i] == 0) sum += w[i].squaredNorm();
    }
    ASSERT_EQ(std::memcmp(&sum, &sum_ref, sizeof(double)), 0) << round;
    rows_checked += static_cast<int>(n);
  }
  EXPECT_GT(rows_checked, 5000);
  EXPECT_GT(fixed_rows, 1000);
}

}  // namespace
}  // namespace pliant
