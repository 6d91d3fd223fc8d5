// Resting churn (docs/contact-surface.md, "Resting churn", issues #5 and #8): bodies
// resting on bodies must come to rest. Reference: a body at rest under gravity gains g dt of speed
// per step, which the contact's velocity update takes away again, so after settling its kinetic
// energy stays below (1/2) M (g dt)^2, one step's gravity on the resting mass; a stage that injects
// energy makes it grow past that instead. Its stored vertex speeds stay within what its positions
// do plus one step's gravity (a velocity the next step's response takes away again is churn).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "sim/world.h"
#include "support/block_stack.h"

namespace pliant {
namespace {

constexpr double kG = 9.81;  // m/s^2, WorldSettings' default gravity

// `blocks` free 30 mm stiff blocks (2x2x2 cells) stacked on a kinematic floor, 0.7 s of steps dt;
// with `fixed_base` the lowest block's bottom vertices are fixed (a deformable support without
// rigid modes, like tissue fixed at its base).
ChurnRun run_stack(int blocks, double mu, double dt, bool fixed_base = false) {
  auto adjust = [](ContactSettings& contact) {
    // Opt-in, for measuring (session 6): PLIANT_CHURN_IMPLICIT_CORRECTION=1 (or "all") turns the
    // implicit contact correction on for every body, =2 (or "stiff_partners") only where the partner
    // is immovable, =3 (or "coupled") with free-free contacts coupled (session 7).
    if (const char* env = std::getenv("PLIANT_CHURN_IMPLICIT_CORRECTION"); env != nullptr) {
      const std::string scope = env;
      if (scope == "1" || scope == "all") contact.implicit_correction = ImplicitCorrection::all;
      if (scope == "2" || scope == "stiff_partners") contact.implicit_correction = ImplicitCorrection::stiff_partners;
      if (scope == "3" || scope == "coupled") contact.implicit_correction = ImplicitCorrection::coupled;
    }
    // Opt-in, for measuring (session 7): PLIANT_CHURN_HELD_RELEASE=1 turns
    // ContactSettings::held_force_release on.
    if (const char* env = std::getenv("PLIANT_CHURN_HELD_RELEASE"); env != nullptr && std::string(env) == "1") {
      contact.held_force_release = true;
    }
    // Opt-in, for measuring (session 8): PLIANT_CHURN_LINEARISED=1 turns
    // ContactSettings::linearised_search on, =0 off (unset: the library default).
    if (const char* env = std::getenv("PLIANT_CHURN_LINEARISED"); env != nullptr) {
      contact.linearised_search = std::string(env) == "1";
    }
  };
  // Opt-in, for measuring (session 8): PLIANT_CHURN_SHIFT=metres moves the top block along x before
  // the run. The late KE at 1 ms is chaotic: shifts of 0.1-10 um spread it over two decades, so
  // searches are compared over an ensemble of shifts (contact_churn_ensemble_long_test.cpp).
  const char* shift = std::getenv("PLIANT_CHURN_SHIFT");
  return run_block_stack(blocks, mu, dt, fixed_base, adjust, shift != nullptr ? std::atof(shift) : 0.0);
}

void expect_rest(const ChurnRun& r, double dt) {
  EXPECT_LT(r.kinetic_late_max, r.rest_floor);
  EXPECT_LE(r.stored_speed_max, r.positional_speed_max + kG * dt);
}

// One free block with friction (mu 0.5) on a kinematic floor, dt 1 ms: it rests (measured: KE
// 4.8e-7 J against the floor 1.3e-6 J; stored speed 10.1 mm/s, positional 10.3 mm/s).
TEST(ContactRestingChurn, OneBlockOnAFloorWithFrictionRests) { expect_rest(run_stack(1, 0.5, 1e-3), 1e-3); }

// Two free blocks stacked, at half the step (c_p dt / h = 1.2): they rest, without and with
// friction (measured: KE 9.7e-8 J and 2.0e-7 J against the floor 6.5e-7 J).
TEST(ContactRestingChurn, TwoBlocksStackedRestAtHalfTheStep) {
  expect_rest(run_stack(2, 0.0, 5e-4), 5e-4);
  const ChurnRun with_friction = run_stack(2, 0.5, 5e-4);
  EXPECT_LT(with_friction.kinetic_late_max, with_friction.rest_floor);
}

// KNOWN FAILURE (session 5): at dt 1 ms (c_p dt / h = 2.4) the stack churns: late KE 4.1e-5 J
// (16x the floor 2.6e-6 J), positional speed 152 mm/s against stored 87 mm/s (the positions move
// more than the velocities: the stage-3/4 displacement, not stage 5, moves them). With mu 0.5:
// KE 1.4e-5 J, 53 vs 46 mm/s. See docs/contact-surface.md, "Resting churn".
// Session 7 (main 79f0aaa): KE 4.93e-4 J (mu 0) and 1.39e-5 J (mu 0.5); the per-stage ledger
// (contact_churn_ledger_test.cpp) shows the late held forces pushing the blocks' centres apart;
// with ContactSettings::held_force_release (PLIANT_CHURN_HELD_RELEASE=1): 3.29e-5 J and 3.28e-5 J.
// Session 8 (the linearised search with an exact first query, the default again): 3.44e-5 J (mu 0)
// and 1.22e-5 J (mu 0.5); one start of a chaotic run (contact_churn_ensemble_long_test.cpp).
TEST(ContactRestingChurn, DISABLED_TwoBlocksStackedRestAtOneMillisecond) {
  expect_rest(run_stack(2, 0.0, 1e-3), 1e-3);
  const ChurnRun with_friction = run_stack(2, 0.5, 1e-3);
  EXPECT_LT(with_friction.kinetic_late_max, with_friction.rest_floor);
}

// KNOWN FAILURE (session 5): a free block on a block whose bottom is fixed (a support without
// rigid modes, so its side of the take-back is the vertex-mass one) churns far more: late KE
// 6.5e-3 J at dt 1 ms (floor 2.6e-6 J, stored / positional 1068 / 1370 mm/s) and 1.0e-4 J at
// 0.5 ms (floor 6.5e-7 J), where the free stack rests. Session 7 (main 79f0aaa): 1.94e-4 J at 0.5 ms.
// Session 8 default: 5.89e-4 J at this start; 5.5e-5..5.9e-4 over 16 shifted starts (the session-5
// search 3.4e-5..4.8e-4).
TEST(ContactRestingChurn, DISABLED_BlockOnAFixedBaseBlockRestsAtHalfTheStep) {
  expect_rest(run_stack(2, 0.0, 5e-4, true), 5e-4);
}

}  // namespace
}  // namespace pliant
