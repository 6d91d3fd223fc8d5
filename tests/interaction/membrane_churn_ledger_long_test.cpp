// Per-stage energy ledger of the membrane stack's bottom pair under sleepers (issue #8, session 15;
// docs/experiments.md "Session 15"). membrane_stack.json's nine membranes settle for 1.3 s with the
// contact-surface response applied by hand (as tests/sim/contact_churn_ledger_test.cpp does: the
// world runs with contact method `none`, held forces go through the bodies' applied forces); then
// membranes 2-8 are put to sleep (immovable, as the centre wake rule leaves them in the scene) and
// the clamped membrane0 and membrane1 go on alone, nothing else moving. Each step books per body
// the energy (kinetic + elastic (read-only query) + gravitational) changed by the integration (the
// held forces' work beside it), the search (stages 3/4), the finishing projection and stage 5, and
// the pair's kinetic energy and its share along z (the contact normal). Label long (~2-4 min).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "interaction/scene/scene.h"
#include "sim/contact/contact_surface_response.h"
#include "sim/world.h"

namespace pliant {
namespace {

/// What differs from the scene in one ledger run.
struct ChurnCase {
  double time_step = 0.0;        ///< s after the settling (0: the scene's 1 ms)
  double membrane0_friction = -1.0;  ///< membrane0's mu (-1: the scene's 0.5); 0 takes friction off its pair
  bool limit_friction_move = false;  ///< ContactSettings::limit_friction_move (docs/stability.md M6a)
  bool charge_returns = false;  ///< ContactSettings::limit_friction_move_charges_returns (session 15)
};

/// Sums over the booked steps (0.1 s after the sleepers freeze, for 0.5 s), per body (J).
struct PairLedger {
  double integrate[2] = {0, 0}, held_work[2] = {0, 0}, search[2] = {0, 0}, projection[2] = {0, 0},
         velocity[2] = {0, 0};
  double total_change[2] = {0, 0};  ///< the energy after the last booked step minus before the first
  double kinetic_max = 0.0, kinetic_mean = 0.0;  ///< the pair's kinetic energy after each step
  double kinetic_z_share = 0.0;  ///< mean share of it in the vertices' z velocities (the contact normal)
  double rest_floor = 0.0;       ///< (1/2) M (g dt)^2 of the pair: one step's gravity, taken back by stage 5
  int steps = 0;
};

constexpr double kSettle = 1.3;  // s, where session 14's frames show the bottom pair churning

// Settles the stack once per process and returns each body's positions and velocities at kSettle.
const std::vector<std::vector<Vec3>>& settled_state() {
  static std::vector<std::vector<Vec3>> state;
  if (!state.empty()) return state;
  Scene scene = load_scene(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/membrane_stack.json");
  WorldSettings ws = scene.world;
  ContactSettings contact = ws.contact;
  // The churning state: the stage 5 the stack churned with (the scene ships session 15's limit,
  // which keeps it from churning).
  contact.limit_friction_move = contact.limit_friction_move_charges_returns = false;
  ws.contact.method = ContactMethod::none;
  ws.sleep.enabled = false;  // all nine settle awake (the state the ledger's variants start from)
  World world(ws);
  std::vector<BodyId> ids;
  for (BodyDef& def : scene.bodies) ids.push_back(world.add_body(std::move(def)));
  ContactSurfaceResponse response;
  const int steps = static_cast<int>(std::lround(kSettle / scene.time_step));
  for (int i = 0; i < steps; ++i) {
    for (BodyId id : ids) {
      Body& b = world.body(id);
      std::fill(b.applied_forces.begin(), b.applied_forces.end(), Vec3::Zero());
      response.take_held_forces(b, b.applied_forces);
    }
    world.step(scene.time_step);
    if (world.contacts().empty() && !response.has_held_contacts()) continue;  // nothing to respond to
    StepReport r;
    response.respond(world.bodies(), world.contacts(), scene.time_step, contact, r);
  }
  for (BodyId id : ids) {
    state.push_back(world.body(id).positions);
    state.push_back(world.body(id).velocities);
  }
  return state;
}

PairLedger take_ledger(const ChurnCase& c) {
  Scene scene = load_scene(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/membrane_stack.json");
  WorldSettings ws = scene.world;
  ContactSettings contact = ws.contact;
  contact.limit_friction_move = c.limit_friction_move || c.charge_returns;
  contact.limit_friction_move_charges_returns = c.charge_returns;
  ws.contact.method = ContactMethod::none;  // the ledger applies the response itself
  ws.sleep.enabled = true;                  // keeps the hand-set sleepers asleep:
  ws.sleep.time = 1e6;                      // nobody leaves a ball this large or rests this long
  ws.sleep.wake_on_centre_motion = true;
  World world(ws);
  std::vector<BodyId> ids;
  for (BodyDef& def : scene.bodies) ids.push_back(world.add_body(std::move(def)));
  const auto& state = settled_state();
  for (size_t k = 0; k < ids.size(); ++k) {
    Body& b = world.body(ids[k]);
    b.positions = state[2 * k];
    b.velocities = state[2 * k + 1];
    if (k >= 2) {
      std::fill(b.velocities.begin(), b.velocities.end(), Vec3::Zero());
      b.sleep.sleeping = true;
    } else {
      // Not a mover: a body with no wake centre yet counts as moved and would wake the sleepers.
      b.sleep.has_wake_centre = true;
      b.sleep.wake_centre = b.positions[0];
    }
  }
  if (c.membrane0_friction >= 0.0) world.body(ids[0]).material.friction = c.membrane0_friction;
  const double dt = c.time_step > 0.0 ? c.time_step : scene.time_step;
  const Vec3 gravity = world.settings().gravity;
  auto energy = [&](size_t k) {
    Body& b = world.body(ids[k]);
    double e = b.model->elastic_energy(b.positions);
    for (size_t v = 0; v < b.positions.size(); ++v) {
      e += 0.5 * b.masses[v] * b.velocities[v].squaredNorm() - b.masses[v] * gravity.dot(b.positions[v]);
    }
    return e;
  };
  PairLedger l;
  for (size_t k = 0; k < 2; ++k) {
    l.rest_floor += 0.5 * world.body(ids[k]).total_mass() * gravity.squaredNorm() * dt * dt;
  }
  ContactSurfaceResponse response;
  double e_search[2] = {0, 0}, e_projection[2] = {0, 0};
  response.observer = [&](ContactStage stage) {
    for (size_t k = 0; k < 2; ++k) {
      if (stage == ContactStage::search) e_search[k] = e_projection[k] = energy(k);
      if (stage == ContactStage::projection) e_projection[k] = energy(k);
    }
  };
  const int warm = static_cast<int>(std::lround(0.1 / dt)), steps = warm + static_cast<int>(std::lround(0.5 / dt));
  double first[2] = {0, 0};
  std::vector<std::vector<Vec3>> held(2), start(2);
  for (int i = 0; i < steps; ++i) {
    const bool book = i >= warm;
    double e_start[2] = {0, 0}, e_integrated[2] = {0, 0};
    for (size_t k = 0; k < ids.size(); ++k) {
      Body& b = world.body(ids[k]);
      if (b.is_sleeping()) continue;
      if (k >= 2) {
        ADD_FAILURE() << "a sleeper woke at step " << i;
        return l;
      }
      std::fill(b.applied_forces.begin(), b.applied_forces.end(), Vec3::Zero());
      response.take_held_forces(b, b.applied_forces);
      held[k] = b.applied_forces;
      start[k] = b.positions;
      e_start[k] = energy(k);
      if (i == warm) first[k] = e_start[k];
    }
    const StepReport& report = world.step(dt);
    EXPECT_TRUE(report.all_finite) << i;
    for (size_t k = 0; k < 2; ++k) {
      const Body& b = world.body(ids[k]);
      e_integrated[k] = e_search[k] = e_projection[k] = energy(k);
      if (!book) continue;
      for (size_t v = 0; v < b.positions.size(); ++v) l.held_work[k] += held[k][v].dot(b.positions[v] - start[k][v]);
    }
    if (!world.contacts().empty() || response.has_held_contacts()) {
      StepReport r;
      response.respond(world.bodies(), world.contacts(), dt, contact, r);
    }
    if (!book) continue;
    double kinetic = 0.0, kinetic_z = 0.0;
    for (size_t k = 0; k < 2; ++k) {
      const Body& b = world.body(ids[k]);
      const double e_end = energy(k);
      l.integrate[k] += e_integrated[k] - e_start[k];
      l.search[k] += e_search[k] - e_integrated[k];
      l.projection[k] += e_projection[k] - e_search[k];
      l.velocity[k] += e_end - e_projection[k];
      l.total_change[k] = e_end - first[k];
      for (size_t v = 0; v < b.positions.size(); ++v) {
        kinetic += 0.5 * b.masses[v] * b.velocities[v].squaredNorm();
        kinetic_z += 0.5 * b.masses[v] * b.velocities[v].z() * b.velocities[v].z();
      }
    }
    l.kinetic_max = std::max(l.kinetic_max, kinetic);
    l.kinetic_mean += kinetic;
    l.kinetic_z_share += kinetic > 0.0 ? kinetic_z / kinetic : 1.0;
    ++l.steps;
  }
  l.kinetic_mean /= l.steps;
  l.kinetic_z_share /= l.steps;
  std::printf("dt %.1f ms, membrane0 mu %.1f: KE max %.3e mean %.3e J (floor %.2e), along z %.1f %%\n", dt * 1e3,
              world.body(ids[0]).material.friction, l.kinetic_max, l.kinetic_mean, l.rest_floor, 100.0 * l.kinetic_z_share);
  for (int k = 0; k < 2; ++k) {
    std::printf("  membrane%d J/step: integrate %+.3e (held work %+.3e) search %+.3e projection %+.3e stage 5 %+.3e\n", k,
                l.integrate[k] / l.steps, l.held_work[k] / l.steps, l.search[k] / l.steps, l.projection[k] / l.steps,
                l.velocity[k] / l.steps);
  }
  return l;
}

// The stages add up to each body's energy change (the ledger misses nothing).
void expect_closed(const PairLedger& l) {
  for (int k = 0; k < 2; ++k) {
    const double sum = l.integrate[k] + l.search[k] + l.projection[k] + l.velocity[k];
    EXPECT_NEAR(sum, l.total_change[k], 1e-9 + 1e-6 * (std::abs(l.integrate[k]) + std::abs(l.velocity[k]))) << k;
  }
}

// The churn, measured (session 15): under the sleepers the bottom pair, nothing else moving, keeps
// ~7x its rest floor of kinetic energy (2.7e-4 J), 60 % of it in the plane (in-plane vertex moves
// 6.5-8.7 mm per 0.2 s, as session 14's frames showed). The energy enters at stage 5: its friction
// moves (dt dv, docs/stability.md M6a) store +0.17 J (membrane0) and +0.31 J (membrane1) per step
// that the integration releases, 50-60x what the search and the projection store. With friction off
// between membrane0 and membrane1 (second run, same start) membrane0's stage 5 stores nothing
// (1.6e-5 J), it stops moving in the plane and the pair's kinetic energy falls 2.6x; what is left is
// membrane1's friction against the sleeper (+0.12 J per step). At dt 0.5 ms the same start churns
// 2.3x less within 0.6 s. The M6a limit leaves all of it bit for bit (last block).
TEST(MembraneChurnLedger, LongBottomPairChurnsByFrictionMovesUnderTheSleepers) {
  const PairLedger base = take_ledger({});
  expect_closed(base);
  EXPECT_GT(base.kinetic_mean, 3.0 * base.rest_floor);
  EXPECT_LT(base.kinetic_z_share, 0.7);  // in-plane motion carries most of it
  for (int k = 0; k < 2; ++k) {
    EXPECT_GT(base.velocity[k], 10.0 * (base.search[k] + base.projection[k])) << k;
    EXPECT_GT(base.search[k] + base.projection[k], 0.0) << k;
    EXPECT_LT(base.integrate[k], -0.9 * base.velocity[k]) << k;  // released again in the integration
  }
  const PairLedger frictionless_pair = take_ledger({.membrane0_friction = 0.0});
  expect_closed(frictionless_pair);
  EXPECT_LT(std::abs(frictionless_pair.velocity[0]), 1e-2 * base.velocity[0]);
  EXPECT_GT(frictionless_pair.velocity[1], 10.0 * (frictionless_pair.search[1] + frictionless_pair.projection[1]));
  EXPECT_LT(frictionless_pair.kinetic_mean, 0.6 * base.kinetic_mean);

  const PairLedger half = take_ledger({.time_step = 5e-4});
  expect_closed(half);
  EXPECT_LT(half.kinetic_mean, 0.6 * base.kinetic_mean);

  // M6a's limit does not see these moves: since session 10 it charges a friction move only beyond
  // the step's own relaxation, and stage 5 here puts back a stuck patch the integration relaxed.
  // With the limit on, the ledger is the default's bit for bit.
  const PairLedger limited = take_ledger({.limit_friction_move = true});
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(limited.velocity[k], base.velocity[k]) << k;
    EXPECT_EQ(limited.integrate[k], base.integrate[k]) << k;
  }
  EXPECT_EQ(limited.kinetic_mean, base.kinetic_mean);

  // Charging those returns (session 15's "charge_returns", what membrane_stack.json ships): stage 5
  // stores next to nothing (measured ~600x less) and the pair's kinetic energy falls towards its rest
  // floor (measured 1.2x it, from 7x).
  const PairLedger charged = take_ledger({.charge_returns = true});
  expect_closed(charged);
  for (int k = 0; k < 2; ++k) EXPECT_LT(charged.velocity[k], 1e-2 * base.velocity[k]) << k;
  EXPECT_LT(charged.kinetic_mean, 0.5 * base.kinetic_mean);
  EXPECT_LT(charged.kinetic_mean, 2.0 * charged.rest_floor);
}

/// The shipped stack with the centre wake rule (session 13's (b)) at time step `dt`, run for `seconds`.
struct StackRun {
  int asleep = 0;               ///< bodies asleep after the last step
  double kinetic_end = 0.0;     ///< J, the world's kinetic energy after the last step
  double asleep_from = -1.0;    ///< s, from when every body slept to the end (-1: never)
  double top_face_shift = 0.0;  ///< m, membrane0's largest in-plane vertex move since the start
  double pair_floor = 0.0;      ///< J, (1/2) M (g dt)^2 of membrane0 and membrane1
};

StackRun run_stack(double dt, double seconds, bool charge_returns) {
  Scene scene = load_scene(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/membrane_stack.json");
  scene.time_step = dt;
  scene.world.contact.limit_friction_move = scene.world.contact.limit_friction_move_charges_returns = charge_returns;
  scene.world.sleep.enabled = true;
  scene.world.sleep.wake_on_centre_motion = true;
  SceneInstance instance = instantiate_scene(scene);
  World& world = *instance.world;
  const std::vector<Vec3> start = world.body(instance.bodies[0]).positions;
  StackRun out;
  for (int k = 0; k < 2; ++k) {
    out.pair_floor += 0.5 * world.body(instance.bodies[static_cast<size_t>(k)]).total_mass() *
                      world.settings().gravity.squaredNorm() * dt * dt;
  }
  const int steps = static_cast<int>(std::lround(seconds / dt));
  for (int i = 0; i < steps; ++i) {
    const StepReport& r = world.step(dt);
    EXPECT_TRUE(r.all_finite) << i;
    out.asleep = r.sleeping_bodies;
    out.kinetic_end = r.energy.kinetic;
    if (r.sleeping_bodies == static_cast<int>(instance.bodies.size())) {
      if (out.asleep_from < 0.0) out.asleep_from = (i + 1) * dt;
    } else {
      out.asleep_from = -1.0;
    }
  }
  const std::vector<Vec3>& end = world.body(instance.bodies[0]).positions;
  for (size_t v = 0; v < end.size(); ++v) {
    out.top_face_shift = std::max(out.top_face_shift, std::hypot(end[v].x() - start[v].x(), end[v].y() - start[v].y()));
  }
  std::printf("dt %.1f ms, %.1f s, charge_returns %d: %d asleep, KE %.3e J (pair floor %.2e), all asleep from "
              "%.3f s, membrane0 in-plane shift %.2f mm\n",
              dt * 1e3, seconds, charge_returns ? 1 : 0, out.asleep, out.kinetic_end, out.pair_floor, out.asleep_from,
              out.top_face_shift * 1e3);
  return out;
}

// The fix measured (docs/experiments.md "Session 15"): at dt 0.5 ms the membranes' layer has
// c_p dt / h = 0.58 < 1 (M1 stores less than the kinetic energy stage 5 removes) and the shipped
// stack with the centre wake rule comes to rest: every body asleep (kinetic energy exactly 0) by
// 1.5 s (measured from 0.44 s), membrane0's clamped top face within the sleep ball (1 mm) of where
// it started in the plane (measured 0.3 mm), not frozen sheared mid-churn (session 14: 8.5-12.7 mm).
// At the scene's 1 ms (c_p dt / h = 1.16) the same start still churns at 1.5 s: the bottom pair awake,
// its kinetic energy above three times its rest floor (measured 2.9e-4 J, 7.6x).
TEST(MembraneChurnLedger, LongTheStackRestsWhenTheMembraneLayerIsBelowCfl1) {
  const StackRun half = run_stack(5e-4, 1.5, false);
  EXPECT_EQ(half.asleep, 9);
  EXPECT_EQ(half.kinetic_end, 0.0);
  EXPECT_GT(half.asleep_from, 0.0);
  EXPECT_LT(half.asleep_from, 1.0);
  EXPECT_LT(half.top_face_shift, 1e-3);

  const StackRun scene = run_stack(1e-3, 1.5, false);
  EXPECT_LT(scene.asleep, 9);
  EXPECT_GT(scene.kinetic_end, 3.0 * scene.pair_floor);

  // The shipped scene (session 15): at 1 ms with the friction-move limit charging returns the same
  // start rests too (measured: every body asleep from 0.684 s, membrane0 0.1 mm in-plane).
  const StackRun shipped = run_stack(1e-3, 1.5, true);
  EXPECT_EQ(shipped.asleep, 9);
  EXPECT_EQ(shipped.kinetic_end, 0.0);
  EXPECT_GT(shipped.asleep_from, 0.0);
  EXPECT_LT(shipped.top_face_shift, 1e-3);
}

}  // namespace
}  // namespace pliant
