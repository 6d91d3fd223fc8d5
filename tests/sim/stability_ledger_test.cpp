// Where the energy of the matrix's stiff-support cases enters (docs/stability.md, "Session 8",
// M7): the per-stage ledger (stability_ledger.h) on the nominal tissue block (E 1e4 Pa) resting
// on a lower block of E 1e10 Pa, i.e. stiffness ratio 1e-6 with both blocks able to carry their
// weight. References: the ledger reproduces the World's own run (positions compared); stage 5
// without friction only projects normal relative velocities and moves no position, so it cannot
// add energy (bounded by the harness's floor); with friction it moves each vertex a friction
// impulse slows by dt dv, alone, which on the stiff block stores k u^2 / 2 >> m dv^2 / 2.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

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

// M10 (session 9): the 1000 kg block on 1e9 Pa blocks is pumped through the lower block by the
// search (M1, from step 1); then detection finds no contact, yet lingering held contacts, whose
// vertices move on along the minus normal of the triangles they entered through (read as approach),
// kept their held forces and friction cones: stage 5 fed the lower block 2-5e4 J per step.
// Reference: in a step where detection finds nothing, stage 5 has only the held contacts of the
// step before to answer; a vertex a cell or more from its held point touches nothing there, so
// with ContactSettings::release_distant_held_contacts those steps' stage 5 adds (nearly) nothing,
// and on a resting pair (nothing lingers a cell away) the release changes nothing at all.
Case heavy_block_through_stiff_support() {
  Case c{.name = "surface 1000 kg on 1e9 Pa", .method = ContactMethod::contact_surface};
  c.upper_mass = 1000.0;
  c.young_mean = 1e9;
  return c;
}

struct NoContactStages {
  double velocity = 0.0;  ///< J, stage 5 over both bodies in steps where detection found nothing
  int steps = 0;          ///< such steps
  int with_held = 0;      ///< of which the response still held contacts for the next step
};

NoContactStages stage5_without_detected_contacts(const Case& c) {
  NoContactStages out;
  take_stage_ledger(c, [&](int, const World& world, const ContactSurfaceResponse& response, const StepStages& s) {
    if (!world.contacts().empty()) return;
    out.velocity += s[0].velocity + s[1].velocity;
    ++out.steps;
    if (response.has_held_contacts()) ++out.with_held;
  });
  return out;
}

TEST(StabilityLedger, HeldContactsOfVerticesThatWentThroughAreReleased) {
  const Case plain = heavy_block_through_stiff_support();
  Case released = plain;
  released.contact_tweak = [](ContactSettings& s) { s.release_distant_held_contacts = true; };
  const double floor = energy_floor(plain);
  const NoContactStages before = stage5_without_detected_contacts(plain);
  const NoContactStages after = stage5_without_detected_contacts(released);
  std::printf("steps without a detected contact: %d -> %d, of which holding: %d -> %d, stage 5 there: %.3g -> %.3g J\n",
              before.steps, after.steps, before.with_held, after.with_held, before.velocity, after.velocity);
  // Session 8's finding, measured here: without the release the steps with no detected contact
  // keep held contacts and stage 5 adds energy in them.
  ASSERT_GT(before.steps, 50);
  EXPECT_GT(before.with_held, before.steps / 2);
  EXPECT_GT(before.velocity, 1e4 * floor);
  EXPECT_GT(after.steps, 50);
  EXPECT_LT(after.with_held, before.with_held / 4);
  EXPECT_LT(after.velocity, 1e-2 * before.velocity);
}

TEST(StabilityLedger, ReleaseOfDistantHeldContactsLeavesARestingPairAlone) {
  Case c{.name = "surface nominal", .method = ContactMethod::contact_surface};
  const StageLedger plain = take_stage_ledger(c);
  c.contact_tweak = [](ContactSettings& s) { s.release_distant_held_contacts = true; };
  const StageLedger released = take_stage_ledger(c);
  for (size_t k = 0; k < 2; ++k) {
    double diff = 0.0;
    for (size_t v = 0; v < plain.final_positions[k].size(); ++v) {
      diff = std::max(diff, (plain.final_positions[k][v] - released.final_positions[k][v]).norm());
    }
    EXPECT_EQ(diff, 0.0) << "body " << k;
  }
}

// The goal, not met: tissue resting on a stiff support stays within the energy budget. Measured
// (session 8): max E / budget 1.38e4 (excess 26x the scale), 101 with friction off.
TEST(StabilityLedger, DISABLED_TissueRestsOnAStiffSupport) { expect_stable(tissue_on_stiff_support()); }

}  // namespace
}  // namespace pliant::stability
