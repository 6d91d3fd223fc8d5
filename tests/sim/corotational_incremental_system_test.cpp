// Session 17: advance updates the SSOR's per-step data (D_i = (1 + h alpha) m_i I + h (beta + h) K'_ii,
// D_i^-1, the fused sweeps' transposed lower blocks) only where K' changed since the last advance.
// Reference: the same model with the update off (set_incremental_system(false): everything rebuilt
// every step, the code before), stepped from the same state with the same inputs. The two must agree
// bit for bit, positions, velocities and D_i, over steps that sum some K' rows again, steps that sum
// none, steps whose h, masses or fixed flags changed (which must rebuild everything), after a step
// solved without the SSOR sweeps, and after a local query that rewrote K' blocks outside the reuse
// step.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "sim/model/corotational_fem.h"
#include "support/beam_model_pair.h"
#include "support/inline_two_thread_executor.h"

namespace pliant {
namespace {

bool same_bits(std::span<const Mat3> a, std::span<const Mat3> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Mat3)) == 0;
}

/// `incremental` with the update on (the default), `full` with it off.
struct Pair : BeamModelPair {
  CorotationalFem& incremental = first;
  CorotationalFem& full = second;
  Pair() { full.set_incremental_system(false); }

  /// One step of both (BeamModelPair::advance_both); returns the rows of D the incremental model
  /// computed.
  size_t step(double dt, std::span<const Vec3> constraint_normals = {},
              std::span<const double> constraint_velocities = {}) {
    advance_both(dt, constraint_normals, constraint_velocities);
    EXPECT_EQ(full.rebuilt_system_rows(), n);
    EXPECT_EQ(incremental.reassembled_rows(), full.reassembled_rows());
    return incremental.rebuilt_system_rows();
  }

  void expect_same(int step) const {
    ASSERT_TRUE(same_positions()) << "positions differ at step " << step;
    ASSERT_TRUE(same_velocities()) << "velocities differ at step " << step;
    ASSERT_TRUE(same_bits(incremental.diagonal_system_blocks(), full.diagonal_system_blocks()))
        << "D differs at step " << step;
  }
};

TEST(CorotationalIncrementalSystem, EqualsTheFullRebuildBitForBit) {
  Pair p;
  const double h = 5e-3;
  size_t partial = 0, none = 0;
  const auto steps = [&](int first, int last) {
    for (int s = first; s < last; ++s) {
      const size_t rows = p.step(h);
      if (p.incremental.reassembled_rows() == 0) {
        ++none;
        EXPECT_EQ(rows, 0u) << "step " << s;
      }
      if (s > 0 && rows > 0 && rows < p.n) ++partial;
      p.expect_same(s);
    }
  };
  // The swing starts: until most tets have rotated past the reuse tolerance, steps compute some
  // groups of D only.
  steps(0, 8);
  // A step with (inactive) contact constraints solves by filtered block-Jacobi, not the SSOR sweeps,
  // while K' rows change: the transposed lower blocks it did not refresh are rebuilt whole next.
  const std::vector<Vec3> free_normals(p.n, Vec3::Zero());
  const std::vector<double> no_velocities(p.n, 0.0);
  p.step(h, free_normals, no_velocities);
  p.expect_same(8);
  steps(9, 30);
  EXPECT_GE(partial, 10u);

  // Back at rest under a load a thousand times smaller: the rotations stay within the reuse
  // tolerance, so after the first step no K' row is summed again and no row of D is computed, and
  // what changes below is seen by every row (a stale D_i or transposed block anywhere shows).
  for (auto* beam : {&p.a, &p.b}) {
    for (auto& f : beam->external) f *= 1e-3;
    beam->x = beam->mesh->rest_positions();
    std::fill(beam->v.begin(), beam->v.end(), Vec3::Zero());
  }
  none = 0;
  steps(30, 36);
  EXPECT_GE(none, 5u);

  // A different h (alpha, beta and K' unchanged): every row again, then back.
  EXPECT_EQ(p.step(4e-3), p.n);
  p.expect_same(36);
  EXPECT_EQ(p.step(h), p.n);
  p.expect_same(37);
  steps(38, 40);

  // One free vertex's mass changed: every row again.
  const size_t heavy = p.n - 1;
  ASSERT_EQ(p.a.fixed[heavy], 0);
  p.a.masses[heavy] *= 1.5;
  EXPECT_EQ(p.step(h), p.n);
  p.expect_same(40);
  steps(41, 43);

  // A vertex next to the clamp fixed too (its row decoupled, its lower blocks zeroed), and, between
  // the steps, a full linearisation with K' (update_rotations) and a local force query at one moved
  // vertex, which rewrite K' blocks outside the reuse step: every row again.
  size_t newly_fixed = 0;
  for (size_t i = 0; i < p.n; ++i) {
    if (p.a.fixed[i] == 0 && p.a.mesh->rest_positions()[i].x() < -0.44) {
      newly_fixed = i;
      break;
    }
  }
  ASSERT_GT(newly_fixed, 0u);
  p.a.fixed[newly_fixed] = 1;
  p.a.v[newly_fixed].setZero();
  p.b.v[newly_fixed].setZero();
  for (auto* q : {&p.incremental, &p.full}) {
    auto& beam = q == &p.incremental ? p.a : p.b;
    q->update_rotations(beam.x);
    std::vector<Vec3> moved = beam.x, f(p.n);
    moved[heavy] += Vec3(1e-4, 0.0, 0.0);
    q->internal_forces(moved, f);
    beam.x = moved;
  }
  EXPECT_EQ(p.step(h), p.n);
  p.expect_same(43);
  steps(44, 45);
  // Free again, with no K' row changed: its lower blocks, zero while it was fixed, are K'^T again.
  p.a.fixed[newly_fixed] = 0;
  EXPECT_EQ(p.step(h), p.n);
  p.expect_same(45);
  steps(46, 50);
  EXPECT_GE(none, 10u);
}

// The threaded reuse step sums dirty rows whole: it records all their blocks as written.
TEST(CorotationalIncrementalSystem, ThreadedReuseStepEqualsTheFullRebuildBitForBit) {
  Pair p;
  InlineTwoThreadExecutor executor;
  p.incremental.set_executor(&executor);
  p.full.set_executor(&executor);
  size_t partial = 0;
  for (int s = 0; s < 40; ++s) {
    const size_t rows = p.step(5e-3);
    if (s > 0 && rows < p.n) ++partial;
    p.expect_same(s);
  }
  EXPECT_GE(partial, 10u);
}

}  // namespace
}  // namespace pliant
