// K' reuse between steps (session 5): a tet keeps the K' blocks of the rotation they were built
// from while its current rotation stays within a tolerance theta of it. Reference: the exact path
// (tolerance 0: K' from the rotations at x_n, Mueller & Gross), stepped from the same state.
// Bound: with A = (1 + h alpha) M + h (beta + h) K' and the stale K~' = K' + dK, both the system
// and the right-hand side's -h (beta + h) K' v carry dK, so A~ (dv~ - dv) = -h (beta + h) dK v+;
// a rotation error theta moves each R K R^T by at most ~2 theta |K_e|, and |A~^-1 h (beta + h) K~'|
// <= 1, so |v~+ - v+| <= ~2 theta |v+| (the test allows 4 theta).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/model/corotational_fem.h"
#include "support/clamped_beam.h"
#include "support/inline_two_thread_executor.h"
#include "support/vec_compare.h"

namespace pliant {
namespace {

ModelSettings precise() {
  ModelSettings s;
  s.accuracy.max_solver_iterations = 5000;
  s.accuracy.solver_tolerance = 1e-12;
  return s;
}

// Each step of the reusing model against the exact step from the same (x, v): the velocity differs
// by at most 4 theta |v+|, part of the rows are reused and part summed again.
void expect_steps_within_bound(double theta) {
  TipPushedBeam beam;
  CorotationalFem reuse(beam.mesh, beam.material, precise());
  CorotationalFem exact(beam.mesh, beam.material, precise());
  reuse.set_stiffness_rotation_tolerance(theta);
  exact.set_stiffness_rotation_tolerance(0.0);
  const auto n = static_cast<size_t>(beam.mesh->vertex_count());
  size_t partial_steps = 0;
  double worst = 0.0;
  for (int step = 0; step < 60; ++step) {
    std::vector<Vec3> xe = beam.x, ve = beam.v;
    exact.advance(xe, ve, beam.input());
    EXPECT_EQ(exact.reassembled_rows(), n);
    reuse.advance(beam.x, beam.v, beam.input());
    const size_t rows = reuse.reassembled_rows();
    if (step > 0 && rows > 0 && rows < n) ++partial_steps;
    std::vector<Vec3> dv(n);
    for (size_t i = 0; i < n; ++i) dv[i] = beam.v[i] - ve[i];
    const double ratio = field_norm(dv) / field_norm(ve);
    worst = std::max(worst, ratio);
    ASSERT_LE(ratio, 4.0 * theta) << "step " << step << ", rows summed again " << rows;
  }
  // The K' reuse was exercised: most steps summed only some rows.
  EXPECT_GT(partial_steps, 30u) << "theta " << theta;
  std::printf("theta %g: worst |v~ - v| / |v| %.3g, steps with partial reassembly %zu of 59\n", theta, worst,
              partial_steps);
}

TEST(CorotationalStiffnessReuse, StepsStayWithinTheRotationBoundOfTheExactStep) {
  expect_steps_within_bound(kDefaultStiffnessRotationTolerance);
  expect_steps_within_bound(1e-2);
}

// Switching a reusing model to tolerance 0 gives the exact path again: every row summed each step,
// the same steps as a model that never reused anything (to the warm starts' 1e-10).
TEST(CorotationalStiffnessReuse, SwitchingToZeroToleranceGivesTheExactPath) {
  TipPushedBeam a, b;
  CorotationalFem switched(a.mesh, a.material, precise());
  CorotationalFem exact(b.mesh, b.material, precise());
  exact.set_stiffness_rotation_tolerance(0.0);
  for (int step = 0; step < 10; ++step) exact.advance(b.x, b.v, b.input());
  for (int step = 0; step < 10; ++step) switched.advance(a.x, a.v, a.input());
  // Continue both from the exact trajectory's state; the reusing one switched to 0.
  std::copy(b.x.begin(), b.x.end(), a.x.begin());
  std::copy(b.v.begin(), b.v.end(), a.v.begin());
  switched.set_stiffness_rotation_tolerance(0.0);
  for (int step = 0; step < 10; ++step) {
    exact.advance(b.x, b.v, b.input());
    switched.advance(a.x, a.v, a.input());
    EXPECT_EQ(switched.reassembled_rows(), a.x.size());
  }
  // Warm starts (rotations, dv) differ, so compare at the solver's and extraction's tolerance.
  EXPECT_LT(max_difference(a.x, b.x), 1e-10);
}

// A still body reuses every block: after the first step nothing is summed again, and the step
// equals the exact one (the rotations it would rebuild from are the ones it has).
TEST(CorotationalStiffnessReuse, StillBodySumsNoRowAgain) {
  TipPushedBeam beam;
  std::fill(beam.external.begin(), beam.external.end(), Vec3::Zero());
  CorotationalFem model(beam.mesh, beam.material, precise());
  model.advance(beam.x, beam.v, beam.input());
  EXPECT_EQ(model.reassembled_rows(), static_cast<size_t>(beam.mesh->vertex_count()));
  model.advance(beam.x, beam.v, beam.input());
  EXPECT_EQ(model.reassembled_rows(), 0u);
  EXPECT_LT(field_norm(beam.v), 1e-12);
}

// Session 12: the serial reuse step sums again only the blocks a moved tet adds to, and leaves the
// rest of a dirty row. Reference: the threaded reuse step, which sums each dirty row whole (the
// code before session 12) from the same gradients; the two must agree bit for bit, step by step,
// while most steps reuse part of the rows (the threaded paths are bit-identical to the serial ones,
// docs/threads.md).
TEST(CorotationalStiffnessReuse, MovedTetsBlocksAloneEqualWholeDirtyRowsBitForBit) {
  TipPushedBeam a, b;
  CorotationalFem blocks_only(a.mesh, a.material, ModelSettings{});
  CorotationalFem whole_rows(b.mesh, b.material, ModelSettings{});
  InlineTwoThreadExecutor executor;
  whole_rows.set_executor(&executor);
  const auto n = static_cast<size_t>(a.mesh->vertex_count());
  size_t partial_steps = 0;
  for (int step = 0; step < 60; ++step) {
    blocks_only.advance(a.x, a.v, a.input());
    whole_rows.advance(b.x, b.v, b.input());
    ASSERT_EQ(blocks_only.reassembled_rows(), whole_rows.reassembled_rows()) << "step " << step;
    if (step > 0 && blocks_only.reassembled_rows() > 0 && blocks_only.reassembled_rows() < n) ++partial_steps;
    ASSERT_EQ(0, std::memcmp(a.x.data(), b.x.data(), n * sizeof(Vec3))) << "positions differ at step " << step;
    ASSERT_EQ(0, std::memcmp(a.v.data(), b.v.data(), n * sizeof(Vec3))) << "velocities differ at step " << step;
  }
  EXPECT_GT(partial_steps, 30u);
}

// Session 14: when every tet moved, the serial reuse step sets and clears no block flags (it sums the
// rows whole without them), and the next partial step must still find block_dirty all clear and flag
// exactly its own tets' blocks. Steps that turn the whole body rigidly by 0.02 rad (every tet's
// rotation leaves the 1e-3 rad tolerance) alternate with ordinary tip-pushed steps (part of the tets
// move). Reference: the threaded reuse step, which sums each dirty row whole, bit for bit.
TEST(CorotationalStiffnessReuse, EveryTetMovedStepsAndPartialStepsEqualWholeDirtyRowsBitForBit) {
  TipPushedBeam a, b;
  CorotationalFem blocks_only(a.mesh, a.material, ModelSettings{});
  CorotationalFem whole_rows(b.mesh, b.material, ModelSettings{});
  InlineTwoThreadExecutor executor;
  whole_rows.set_executor(&executor);
  const auto n = static_cast<size_t>(a.mesh->vertex_count());
  const Mat3 turn = Eigen::AngleAxisd(0.02, Vec3(0.3, 0.4, 1.0).normalized()).toRotationMatrix();
  size_t partial_steps = 0;
  for (int step = 0; step < 40; ++step) {
    if (step % 4 == 1) {
      for (ClampedBeam* beam : {static_cast<ClampedBeam*>(&a), static_cast<ClampedBeam*>(&b)}) {
        for (size_t i = 0; i < n; ++i) {
          beam->x[i] = turn * beam->x[i];
          beam->v[i] = turn * beam->v[i];
        }
      }
    }
    blocks_only.advance(a.x, a.v, a.input());
    whole_rows.advance(b.x, b.v, b.input());
    ASSERT_EQ(blocks_only.reassembled_rows(), whole_rows.reassembled_rows()) << "step " << step;
    if (step % 4 == 1) {
      EXPECT_EQ(blocks_only.reassembled_rows(), n) << "step " << step;
    }
    if (step > 0 && blocks_only.reassembled_rows() > 0 && blocks_only.reassembled_rows() < n) ++partial_steps;
    ASSERT_EQ(0, std::memcmp(a.x.data(), b.x.data(), n * sizeof(Vec3))) << "positions differ at step " << step;
    ASSERT_EQ(0, std::memcmp(a.v.data(), b.v.data(), n * sizeof(Vec3))) << "velocities differ at step " << step;
  }
  EXPECT_GT(partial_steps, 10u);
}

}  // namespace
}  // namespace pliant
