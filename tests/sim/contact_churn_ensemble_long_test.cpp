// The resting churn over an ensemble of starts (session 8, docs/contact-surface.md "Linearised
// search on again"). The late kinetic energy of two stacked free blocks at dt 1 ms is chaotic:
// moving the top block by 0.1-10 um before the run spreads the session-5 search's over
// 3.2e-5..7.6e-3 J. One run therefore cannot rank two searches (session 7 did, and turned the
// linearised search off on one sample: 4.93e-4 against 4.09e-5 J). Reference: the session-5
// search (ContactSettings::linearised_search false, bit for bit the previous default) over the
// same 16 shifts; the default search must not churn more, as a geometric mean (the late KE spans
// decades) within the ensemble's spread.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iterator>

#include "support/block_stack.h"

namespace pliant {
namespace {

constexpr double kShifts_m[] = {0.0, 1e-7, 2e-7, 3e-7, 5e-7, 7e-7, 1e-6, 1.5e-6,
                                2e-6, 3e-6, 5e-6, 7e-6, 1e-5, 1.5e-5, 2e-5, 3e-5};

// Geometric mean of the late KE (J) over the shifts, with the linearised search on or off and
// ContactSettings::held_force_release as given.
// With `limit`, ContactSettings::limit_friction_move on.
double churn_geometric_mean(double mu, double dt, bool fixed_base, bool linearised, bool release = false,
                            bool limit = false) {
  double log_sum = 0.0;
  for (double shift : kShifts_m) {
    auto adjust = [&](ContactSettings& c) {
      c.linearised_search = linearised;
      c.held_force_release = release;
      c.limit_friction_move = c.limit_friction_move || limit;
    };
    const ChurnRun r = run_block_stack(2, mu, dt, fixed_base, adjust, shift);
    log_sum += std::log(r.kinetic_late_max);
  }
  return std::exp(log_sum / static_cast<double>(std::size(kShifts_m)));
}

// Bound 1.5x: measured (session 8) 0.35x (mu 0: 7.8e-5 against 2.2e-4 J), 0.96x (mu 0.5: 1.47e-5
// against 1.53e-5), 1.14x (fixed base at 0.5 ms: 1.63e-4 against 1.43e-4); single shifts move a
// geometric mean of 16 by up to ~1.4x (one 7.6e-3 J outlier among 3e-5 J runs), hence 1.5.
TEST(ContactChurnEnsemble, LongDefaultSearchChurnsNoMoreThanTheSession5Search) {
  struct Case {
    const char* name;
    double mu, dt;
    bool fixed_base;
  };
  for (const Case& c : {Case{"two free blocks, mu 0, 1 ms", 0.0, 1e-3, false},
                        Case{"two free blocks, mu 0.5, 1 ms", 0.5, 1e-3, false},
                        Case{"block on a fixed-base block, 0.5 ms", 0.0, 5e-4, true}}) {
    ASSERT_TRUE(ContactSettings{}.linearised_search);
    const double linearised = churn_geometric_mean(c.mu, c.dt, c.fixed_base, true);
    const double session5 = churn_geometric_mean(c.mu, c.dt, c.fixed_base, false);
    std::printf("%s: late KE geometric mean %.3g J (default) vs %.3g J (session-5 search)\n", c.name, linearised,
                session5);
    EXPECT_LE(linearised, 1.5 * session5) << c.name;
  }
}

// ContactSettings::held_force_release (opt-in) lowers the frictionless stack's churn over the
// ensemble (measured 4.14e-5 against 7.84e-5 J; one run each way can show either order, see
// contact_churn_ledger_test.cpp); with mu 0.5 it raises it (2.88e-5 against 1.47e-5 J, session 7's
// finding on one run, here over 16), which is why it stays opt-in.
TEST(ContactChurnEnsemble, LongHeldForceReleaseLowersTheFrictionlessChurn) {
  EXPECT_LT(churn_geometric_mean(0.0, 1e-3, false, true, true), churn_geometric_mean(0.0, 1e-3, false, true, false));
}

// Session 10: ContactSettings::limit_friction_move (the friction-move limit counted beyond the
// stuck contacts' pre-stress, docs/stability.md) on resting stacks, where every contact sticks.
// Reference: the same 16 shifts without the limit. Bound 1.5x, as above (an ensemble's spread).
TEST(ContactChurnEnsemble, LongFrictionMoveLimitChurnsNoMoreThanTheFullMove) {
  struct Case {
    const char* name;
    double mu, dt;
    bool fixed_base;
  };
  for (const Case& c : {Case{"two free blocks, mu 0.5, 1 ms", 0.5, 1e-3, false},
                        Case{"block on a fixed-base block, mu 0.5, 0.5 ms", 0.5, 5e-4, true}}) {
    const double limited = churn_geometric_mean(c.mu, c.dt, c.fixed_base, true, false, true);
    const double full = churn_geometric_mean(c.mu, c.dt, c.fixed_base, true, false, false);
    std::printf("%s: late KE geometric mean %.3g J (limit) vs %.3g J (full move)\n", c.name, limited, full);
    EXPECT_LE(limited, 1.5 * full) << c.name;
  }
}

}  // namespace
}  // namespace pliant
