// ContactSettings::deformable_pair_held_force_fraction (session 9, opt-in; docs/contact-surface.md
// "Resting churn, session 9"): contacts between two movable deformable bodies hold a smaller part of
// their normal force through the next integration. References: bit-identity with the default where
// no such pair exists (a block on a kinematic floor), and statics where one does (the upper block of
// a stack presses on the lower one with its weight, as with the full held force: what is not held
// is supplied by stage 5's impulse, and the reported force is the total).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "support/block_stack.h"

namespace pliant {
namespace {

constexpr double kG = 9.81;  // m/s^2, WorldSettings' default gravity

// One free block with friction on a kinematic floor, 300 steps at 1 ms: the floor is not a
// deformable partner, so the setting changes nothing, bit for bit.
TEST(ContactDeformablePairHeld, KinematicPartnersKeepTheFullHeldForceBitForBit) {
  auto run = [](double pair_fraction, bool derived = false) {
    World world;
    world.settings().contact.finishing_projection = true;
    world.settings().contact.deformable_pair_held_force_fraction = pair_fraction;
    world.settings().contact.deformable_pair_held_force_derived = derived;
    const std::vector<BodyId> ids = add_block_stack(world, 1, 0.5);
    for (int i = 0; i < 300; ++i) EXPECT_EQ(world.step(1e-3).fault, StepFault::none);
    const Body& b = world.body(ids.front());
    std::vector<Vec3> state(b.positions.begin(), b.positions.end());
    state.insert(state.end(), b.velocities.begin(), b.velocities.end());
    return state;
  };
  const std::vector<Vec3> full = run(1.0), reduced = run(0.8), derived = run(1.0, true);
  ASSERT_EQ(full.size(), reduced.size());
  ASSERT_EQ(full.size(), derived.size());
  for (size_t i = 0; i < full.size(); ++i) EXPECT_EQ(full[i], reduced[i]) << i;
  for (size_t i = 0; i < full.size(); ++i) EXPECT_EQ(full[i], derived[i]) << i;  // session 10's "derived"
}

// Two free blocks stacked (mu 0.5, dt 0.5 ms, where both settings rest): the mean contact force the
// lower block reports from the upper one over the last 100 steps is the upper block's weight
// (within 2%), and equal and opposite on the pair.
// Session 10: the same with the derived strength (0.93 for these blocks at 0.5 ms: omega dt 0.53).
void expect_stacked_block_presses_with_its_weight(double pair_fraction, bool derived) {
  World world;
  world.settings().contact.finishing_projection = true;
  world.settings().contact.deformable_pair_held_force_fraction = pair_fraction;
  world.settings().contact.deformable_pair_held_force_derived = derived;
  const std::vector<BodyId> ids = add_block_stack(world, 2, 0.5);
  const double dt = 5e-4;
  for (int i = 0; i < 600; ++i) EXPECT_EQ(world.step(dt).fault, StepFault::none);
  Vec3 on_lower = Vec3::Zero();
  for (int i = 0; i < 100; ++i) {
    const StepReport& r = world.step(dt);
    for (const auto& pair : r.pair_forces) {
      if (pair.body_a != static_cast<int>(ids[0].index) || pair.body_b != static_cast<int>(ids[1].index)) continue;
      on_lower += pair.force_on_a / 100.0;
      EXPECT_NEAR((pair.force_on_a + pair.force_on_b).norm(), 0.0, 1e-12);
    }
  }
  const double weight = world.body(ids[1]).total_mass() * kG;
  EXPECT_NEAR(on_lower.z(), -weight, 0.02 * weight);
}

TEST(ContactDeformablePairHeld, StackedBlockPressesWithItsWeight) { expect_stacked_block_presses_with_its_weight(0.8, false); }

TEST(ContactDeformablePairHeld, StackedBlockPressesWithItsWeightDerived) {
  expect_stacked_block_presses_with_its_weight(1.0, true);
}

}  // namespace
}  // namespace pliant
