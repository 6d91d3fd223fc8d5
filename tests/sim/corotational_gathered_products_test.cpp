// Session 18: advance forms K' v and K' dv_0 of its right-hand side by gathering alone
// (stiffness_product_pair_gathered: the upper blocks and the fused sweeps' transposed lower blocks)
// instead of the upper-triangle row product, which scatters K'_ij^T p_i into the rows after i.
// References: the row product itself (stiffness_row_product over the rows ascending, the skipped
// rows left out, as apply_stiffness_pair runs it) on random patterns and blocks, and the same model
// with the gathered products off (set_gathered_stiffness_products(false), the code before), stepped
// from the same state with the same inputs. Both must agree bit for bit. Skipped without AVX2/FMA.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "sim/model/corotational_fem.h"
#include "sim/model/fused_ssor_kernels.h"
#include "sim/model/stiffness_row_kernels.h"
#include "support/beam_model_pair.h"
#include "support/random_block_pattern.h"

namespace pliant {
namespace {

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

bool kernels_available() { return stiffness_row_kernels_available() && fused_sweeps_available(); }

// Random upper-triangle patterns (the diagonal block first in each row, then j > i ascending; some
// rows with no upper block, the last row never), blocks with exact zeros, -0 and mixed magnitudes,
// vectors with zeros of both signs, and skipped rows (zero a and b, zero results, zeroed transposed
// copies, as a fixed vertex): the gathered pair equals the row product, result for result.
TEST(GatheredStiffnessProducts, EqualTheRowProductBitForBit) {
  if (!kernels_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  std::mt19937 rng(18);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, 15);
  const auto entry = [&]() { return random_block_entry(rng, pick, unit, 1e8, 1e-9); };
  int checked_rows = 0, skipped_rows = 0;
  for (int round = 0; round < 200; ++round) {
    const size_t n = 1 + static_cast<size_t>(round % 37);
    auto [offsets, cols] = random_upper_block_pattern(n, rng, pick);
    std::vector<double> blocks(9 * cols.size());
    for (double& e : blocks) e = entry();
    std::vector<char> skip(n, 0);
    std::vector<double> a(3 * n), b(3 * n);
    for (size_t i = 0; i < n; ++i) {
      skip[i] = pick(rng) < 3 ? 1 : 0;
      for (size_t k = 0; k < 3; ++k) {
        a[3 * i + k] = skip[i] != 0 ? (pick(rng) < 8 ? 0.0 : -0.0) : entry();
        b[3 * i + k] = skip[i] != 0 ? (pick(rng) < 8 ? -0.0 : 0.0) : entry();
      }
      skipped_rows += skip[i];
    }
    // Reference: apply_stiffness_pair's loop (skipped rows zero, not multiplied).
    std::vector<double> ya_ref(3 * n, 0.0), yb_ref(3 * n, 0.0);
    for (size_t i = 0; i < n; ++i) {
      if (skip[i] != 0) {  // set to zero, not multiplied
        std::fill(&ya_ref[3 * i], &ya_ref[3 * i] + 3, 0.0);
        std::fill(&yb_ref[3 * i], &yb_ref[3 * i] + 3, 0.0);
        continue;
      }
      double r[3];
      const auto first = static_cast<size_t>(offsets[i]), last = static_cast<size_t>(offsets[i + 1]);
      stiffness_row_product(blocks.data(), cols.data(), first, last, i, a.data(), ya_ref.data(), r);
      std::copy(r, r + 3, &ya_ref[3 * i]);
      stiffness_row_product(blocks.data(), cols.data(), first, last, i, b.data(), yb_ref.data(), r);
      std::copy(r, r + 3, &yb_ref[3 * i]);
      ++checked_rows;
    }
    const LowerTrianglePattern lower = lower_triangle_pattern(offsets.data(), cols.data(), n);
    std::vector<double> transposed(9 * lower.rows.size() + 4);
    transpose_lower_blocks(blocks.data(), lower.upper_blocks.data(), lower.rows.data(), skip.data(),
                           lower.rows.size(), transposed.data());
    std::vector<double> ya(3 * n, 7.0), yb(3 * n, 7.0);  // every entry written
    const StiffnessPairSystem sys{blocks.data(),       lower.column_entries.data(), offsets.data(),
                                  transposed.data(),   lower.row_entries.data(),    lower.offsets.data(),
                                  skip.data(),         n};
    stiffness_product_pair_gathered(sys, a.data(), b.data(), ya.data(), yb.data());
    ASSERT_TRUE(same_bits(ya, ya_ref)) << "K' a differs in round " << round;
    ASSERT_TRUE(same_bits(yb, yb_ref)) << "K' b differs in round " << round;
  }
  EXPECT_GT(checked_rows, 2000);
  EXPECT_GT(skipped_rows, 500);
}

/// `gathered` with the gathered products (the default), `scattered` with them off.
struct Pair : BeamModelPair {
  CorotationalFem& gathered = first;
  CorotationalFem& scattered = second;
  Pair() { scattered.set_gathered_stiffness_products(false); }

  /// One step of both (BeamModelPair::advance_both); returns whether the gathered model gathered
  /// its products.
  bool step(double dt, std::span<const Vec3> constraint_normals = {},
            std::span<const double> constraint_velocities = {}) {
    advance_both(dt, constraint_normals, constraint_velocities);
    EXPECT_FALSE(scattered.last_products_gathered());
    return gathered.last_products_gathered();
  }

  void expect_same(int step) const {
    ASSERT_TRUE(same_positions()) << "positions differ at step " << step;
    ASSERT_TRUE(same_velocities()) << "velocities differ at step " << step;
  }
};

// Steps that sum some K' rows again and steps that sum none (only the written transposed blocks
// refreshed), a constrained step (no SSOR sweeps), a change of h, a vertex fixed while it moves (the
// products fall back to the row product for that step: its zeroed transposed blocks would drop its
// K'^T v), fixed and freed again: positions and velocities equal the row product's after every step.
TEST(GatheredStiffnessProducts, StepsEqualTheRowProductsBitForBit) {
  if (!kernels_available()) GTEST_SKIP() << "no AVX2/FMA on this CPU";
  Pair p;
  ASSERT_TRUE(p.gathered.fused_sweeps());
  const double h = 5e-3;
  int gathered_steps = 0;
  const auto steps = [&](int first, int last) {
    for (int s = first; s < last; ++s) {
      gathered_steps += p.step(h) ? 1 : 0;
      p.expect_same(s);
    }
  };
  steps(0, 10);
  EXPECT_EQ(gathered_steps, 10);
  const std::vector<Vec3> free_normals(p.n, Vec3::Zero());
  const std::vector<double> no_velocities(p.n, 0.0);
  EXPECT_TRUE(p.step(h, free_normals, no_velocities));
  p.expect_same(10);
  steps(11, 20);
  EXPECT_TRUE(p.step(4e-3));
  p.expect_same(20);
  steps(21, 25);

  // A moving vertex near the clamp fixed with its velocity kept: this step's K' v needs its row.
  size_t newly_fixed = 0;
  for (size_t i = 0; i < p.n; ++i) {
    if (p.a.fixed[i] == 0 && p.a.mesh->rest_positions()[i].x() < -0.44 && p.a.v[i].norm() > 0.0) {
      newly_fixed = i;
      break;
    }
  }
  ASSERT_GT(newly_fixed, 0u);
  p.a.fixed[newly_fixed] = 1;
  EXPECT_FALSE(p.step(h)) << "a fixed row with a nonzero velocity must take the row product";
  p.expect_same(25);
  steps(26, 30);  // its velocity is zero now: gathered again
  p.a.fixed[newly_fixed] = 0;
  steps(30, 40);
  EXPECT_EQ(gathered_steps, 10 + 9 + 4 + 4 + 10);
}

}  // namespace
}  // namespace pliant
