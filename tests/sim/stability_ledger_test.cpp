// Where the energy of the matrix's stiff-support cases enters (docs/stability.md, "Session 8",
// M7): the per-stage ledger (stability_ledger.h) on the nominal tissue block (E 1e4 Pa) resting
// on a lower block of E 1e10 Pa, i.e. stiffness ratio 1e-6 with both blocks able to carry their
// weight. References: the ledger reproduces the World's own run (positions compared); stage 5
// without friction only projects normal relative velocities and moves no position, so it cannot
// add energy (bounded by the harness's floor); with friction it moves each vertex a friction
// impulse slows by dt dv, alone, which on the stiff block stores k u^2 / 2 >> m dv^2 / 2.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/stability_harness.h"
#include "sim/stability_ledger.h"

namespace pliant::stability {
namespace {

// The nominal tissue (1e4 Pa) on a 1e10 Pa lower block: ratio 1e-6 about the geometric mean 1e7.
Case tissue_on_stiff_support() {
  Case c{.name = "surface tissue on a 1e10 Pa block", .method = ContactMethod::contact_surface};
  c.stiffness_ratio = 1e-6;
  c.young_mean = 1e7;
  return c;
}

// The energy scale's floor of the harness (J): 1e-3 sum m g thickness.
double energy_floor(const Case& c) {
  World world(world_settings(c));
  return kEnergyFloorFraction * build_scene(c, world).scale;
}

TEST(StabilityLedger, ReproducesTheWorldsRun) {
  Case c{.name = "surface nominal", .method = ContactMethod::contact_surface};
  c.duration = 0.1;  // 100 steps
  const StageLedger ledger = take_stage_ledger(c);
  World world(world_settings(c));
  const Scene scene = build_scene(c, world);
  for (int i = 0; i < ledger.steps; ++i) ASSERT_TRUE(world.step(c.dt).all_finite) << i;
  const std::array<BodyId, 2> ids = {scene.lower, scene.upper};
  for (size_t k = 0; k < 2; ++k) {
    const auto& x = world.body(ids[k]).positions;
    ASSERT_EQ(x.size(), ledger.final_positions[k].size());
    double diff = 0.0;
    for (size_t v = 0; v < x.size(); ++v) diff = std::max(diff, (x[v] - ledger.final_positions[k][v]).norm());
    EXPECT_EQ(diff, 0.0) << "body " << k;
  }
}

// Measured (session 8, defaults): friction on, stage 5 adds +107 J to the stiff block over the 300 steps
// (the integration takes -105 J back out; the search adds +0.80 J); friction off, stage 5 adds
// +6.4e-6 J to the stiff block and -2.1e-5 J to the tissue, and the search's +0.079 J is what is
// left (the case then fails at 101x instead of 1.38e4x: M1 on the stiff side, CFL c_p dt / h ~280).
TEST(StabilityLedger, FrictionsMoveOnAStiffSupportIsWhereTheEnergyEnters) {
  const Case on = tissue_on_stiff_support();
  const double floor = energy_floor(on);
  const StageLedger with_friction = take_stage_ledger(on);
  Case off = on;
  off.contact_tweak = [](ContactSettings& s) { s.friction = false; };
  const StageLedger without = take_stage_ledger(off);
  EXPECT_LE(without.body[0].velocity + without.body[1].velocity, floor);
  EXPECT_GT(with_friction.body[0].velocity, 1e3 * floor);  // on the stiff block
  EXPECT_GT(with_friction.body[0].velocity, 10.0 * with_friction.body[0].search);
  EXPECT_LT(without.max_total, with_friction.max_total);
}

// ContactSettings::anchored_friction_compliance (opt-in, M7): the stiff block's vertices (omega dt
// >> 1, fixed base) answer a friction impulse with their quasi-static compliance 1 / (k dt^2), so
// their moves store at most the kinetic energy the impulses remove. Measured (session 8): stage 5
// on the stiff block +107 J -> +6.5e-6 J, the case 1.38e4x -> 101x (what is left is the search's
// M1 on the stiff side, +0.068 J).
TEST(StabilityLedger, AnchoredFrictionComplianceTakesTheStiffSupportsShareOut) {
  Case on = tissue_on_stiff_support();
  on.contact_tweak = [](ContactSettings& s) { s.anchored_friction_compliance = true; };
  const double floor = energy_floor(on);
  const StageLedger compliant = take_stage_ledger(on);
  const StageLedger plain = take_stage_ledger(tissue_on_stiff_support());
  EXPECT_LE(compliant.body[0].velocity, floor);
  EXPECT_LT(compliant.max_total, 1e-2 * plain.max_total);
}

// The goal, not met: tissue resting on a stiff support stays within the energy budget. Measured
// (session 8): max E / budget 1.38e4 (excess 26x the scale), 101 with friction off.
TEST(StabilityLedger, DISABLED_TissueRestsOnAStiffSupport) { expect_stable(tissue_on_stiff_support()); }

}  // namespace
}  // namespace pliant::stability
