// Per-stage energy ledger of the resting churn (docs/contact-surface.md, "Resting churn", session 7;
// issues #5 and #8): two free 30 mm blocks stacked on a kinematic floor, as in
// contact_resting_churn_test.cpp. The world runs with contact method `none` and the test applies
// the contact-surface response itself (held forces through the bodies' applied forces, an observer
// after its stages), which is the World's step bit for bit (same late kinetic energy). The energy
// (kinetic + elastic (read-only query) + gravitational) of each block is taken at the step's start,
// after the integration, after the search (stages 3/4), after the finishing projection and after
// stage 5, beside the held forces' work in the integration.
// Reference: momentum: internal forces move no centre of mass, so the integration changes a block's
// centre-of-mass energy E_c = (1/2) M v_c^2 + M g z_c only through the held forces' resultant F:
// dE_c = F . dx_c - dt^2 |F + M g|^2 / (2 M) (implicit Euler: x_c' = x_c + dt v_c', M (v_c' - v_c) =
// dt (F + M g)); positive dE_c is the held forces pushing the rigid (bounce) mode.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "sim/contact/contact_surface_response.h"
#include "sim/world.h"
#include "support/block_stack.h"

namespace pliant {
namespace {

constexpr double kG = 9.81;  // m/s^2, WorldSettings' default gravity

/// Sums over the late steps (the last 2/7 of 0.7 s), both blocks (J).
struct ChurnLedger {
  double integrate = 0.0;    ///< change of total energy in the integration
  double held_work = 0.0;    ///< the held forces' work in the integration (sum f . dx over vertices)
  double search = 0.0;       ///< stages 3/4: the binary search's displacement
  double projection = 0.0;   ///< the finishing projection
  double velocity = 0.0;     ///< stage 5 (velocity update, take-back)
  double rigid_integrate = 0.0;  ///< change of the centre-of-mass energies in the integration
  double rigid_closed_form = 0.0;  ///< the same from the held resultant (reference above)
  double kinetic_late_max = 0.0;
  double rest_floor = 0.0;  ///< (1/2) M (g dt)^2 over both blocks
  int steps = 0;            ///< late steps summed
};

struct Energy {
  double kinetic = 0.0, elastic = 0.0, gravitational = 0.0;
  double total() const { return kinetic + elastic + gravitational; }
};

// The stack with friction coefficient `mu` (0: friction off) and held fraction `held_fraction`.
ChurnLedger take_ledger(double dt, bool release, double mu = 0.0, double held_fraction = 1.0) {
  WorldSettings settings;
  settings.contact.method = ContactMethod::none;  // the test applies the response itself
  World world(settings);
  ContactSettings contact;
  contact.held_force_fraction = held_fraction;
  contact.friction = mu > 0.0;
  contact.finishing_projection = true;
  contact.held_force_release = release;
  const std::vector<BodyId> ids = add_block_stack(world, 2, mu);
  ChurnLedger out;
  for (BodyId id : ids) out.rest_floor += 0.5 * world.body(id).total_mass() * (kG * dt) * (kG * dt);
  const Vec3 gravity = world.settings().gravity;

  auto energy = [&]() {
    Energy e;
    for (BodyId id : ids) {
      Body& b = world.body(id);
      for (size_t v = 0; v < b.positions.size(); ++v) {
        e.kinetic += 0.5 * b.masses[v] * b.velocities[v].squaredNorm();
        e.gravitational -= b.masses[v] * gravity.dot(b.positions[v]);
      }
      e.elastic += b.model->elastic_energy(b.positions);
    }
    return e;
  };
  // Centre-of-mass energy of each block (J): (1/2) M v_c^2 - M g . x_c.
  auto centre_energy = [&](const Body& b) {
    Vec3 momentum = Vec3::Zero(), moment = Vec3::Zero();
    for (size_t v = 0; v < b.positions.size(); ++v) {
      momentum += b.masses[v] * b.velocities[v];
      moment += b.masses[v] * b.positions[v];
    }
    return 0.5 * momentum.squaredNorm() / b.total_mass() - gravity.dot(moment);
  };

  ContactSurfaceResponse response;
  Energy after_search, after_projection;
  response.observer = [&](ContactStage stage) {
    if (stage == ContactStage::search) after_search = after_projection = energy();
    if (stage == ContactStage::projection) after_projection = energy();
  };
  const int steps = static_cast<int>(std::lround(0.7 / dt));
  std::vector<std::vector<Vec3>> held(ids.size()), start_positions(ids.size());
  std::vector<double> start_centre(ids.size());
  for (int i = 1; i <= steps; ++i) {
    const Energy start = energy();
    for (size_t k = 0; k < ids.size(); ++k) {
      Body& b = world.body(ids[k]);
      std::fill(b.applied_forces.begin(), b.applied_forces.end(), Vec3::Zero());
      response.take_held_forces(b, b.applied_forces);
      held[k] = b.applied_forces;
      start_positions[k] = b.positions;
      start_centre[k] = centre_energy(b);
    }
    const StepReport& r = world.step(dt);
    EXPECT_TRUE(r.all_finite) << i;
    const Energy after_integrate = energy();
    after_search = after_projection = after_integrate;
    double held_work = 0.0, rigid = 0.0, rigid_closed = 0.0;
    for (size_t k = 0; k < ids.size(); ++k) {
      const Body& b = world.body(ids[k]);
      Vec3 resultant = Vec3::Zero(), centre_move = Vec3::Zero();
      for (size_t v = 0; v < b.positions.size(); ++v) {
        const Vec3 dx = b.positions[v] - start_positions[k][v];
        held_work += held[k][v].dot(dx);
        resultant += held[k][v];
        centre_move += b.masses[v] * dx;
      }
      const double mass = b.total_mass();
      centre_move /= mass;
      rigid += centre_energy(b) - start_centre[k];
      rigid_closed += resultant.dot(centre_move) - dt * dt * (resultant + mass * gravity).squaredNorm() / (2.0 * mass);
    }
    if (!world.contacts().empty() || response.has_held_contacts()) {
      StepReport response_report;
      response.respond(world.bodies(), world.contacts(), dt, contact, response_report);
    }
    const Energy end = energy();
    if (i <= steps * 5 / 7) continue;
    ++out.steps;
    out.integrate += after_integrate.total() - start.total();
    out.held_work += held_work;
    out.search += after_search.total() - after_integrate.total();
    out.projection += after_projection.total() - after_search.total();
    out.velocity += end.total() - after_projection.total();
    out.rigid_integrate += rigid;
    out.rigid_closed_form += rigid_closed;
    out.kinetic_late_max = std::max(out.kinetic_late_max, end.kinetic);
  }
  std::printf("dt %.1f ms, mu %.1f, held %.2f, release %s: late KE max %.2e J (floor %.2e); per late step (J): integrate %+.2e "
              "(held work %+.2e, centres %+.2e, closed form %+.2e), search %+.2e, projection %+.2e, stage 5 "
              "%+.2e\n",
              dt * 1e3, mu, held_fraction, release ? "on" : "off", out.kinetic_late_max, out.rest_floor, out.integrate / out.steps,
              out.held_work / out.steps, out.rigid_integrate / out.steps, out.rigid_closed_form / out.steps,
              out.search / out.steps, out.projection / out.steps, out.velocity / out.steps);
  return out;
}

// The centres' energy moves in the integration only by the held forces (reference above).
void expect_consistent(const ChurnLedger& l) {
  EXPECT_NEAR(l.rigid_integrate, l.rigid_closed_form, 1e-3 * std::abs(l.rigid_closed_form) + 1e-12);
}

// At dt 1 ms the stack churns (late KE 4.9e-4 J against the floor 2.6e-6 J). Measured per late
// step: integrate -6.2e-4 J (held work -1.7e-5), search +2.6e-4, projection +3.8e-4, stage 5
// -1.9e-5; the centres' energy +7.8e-6 in the integration. The displacement is what stores energy
// (the dents) and the integration releases it; stage 5 never adds. The held forces' total work is
// negative (they hold the dents), but on the centres of mass it is positive: the one-step-late
// contact force pushes the blocks apart after they have started to separate (the bounce mode). At
// 0.5 ms the stack rests and the held forces take energy out of the centres (-3.3e-8 J per step).
TEST(ContactChurnLedger, HeldForcesPushTheCentresApartAtOneMillisecondNotAtHalf) {
  const ChurnLedger churn = take_ledger(1e-3, false);
  expect_consistent(churn);
  EXPECT_GT(churn.kinetic_late_max, 10.0 * churn.rest_floor);
  EXPECT_GT(churn.search + churn.projection, 0.0);
  EXPECT_LT(churn.integrate, 0.0);
  EXPECT_LT(churn.velocity, 0.0);
  EXPECT_LT(churn.held_work, 0.0);
  EXPECT_GT(churn.rigid_integrate, 0.0);

  const ChurnLedger rest = take_ledger(5e-4, false);
  expect_consistent(rest);
  EXPECT_LT(rest.kinetic_late_max, rest.rest_floor);
  EXPECT_LT(rest.rigid_integrate, 0.0);
}

// ContactSettings::held_force_release: a pair whose centres separate along its held force
// releases the impulse the separation carries before the integration. The held forces then take
// energy out of the centres at 1 ms too (the release's mechanism, asserted), and the stack still
// churns, above the rest floor: what is left is the dents' elastic energy that the displacement
// stores and the integration releases every step (the contact stays closed). Whether the late KE
// falls is not asserted on one run (session 8): the late KE at 1 ms is chaotic in sub-micron
// shifts of the start (contact_churn_ensemble_long_test.cpp), and one run each way measured
// 4.09e-5 -> 2.20e-5 J (session-5 search), 4.9e-4 -> 2.7e-5 J (session 6's linearised search),
// 3.44e-5 -> 3.83e-5 J (session 8's default); over 16 shifts it falls (geometric mean 7.84e-5 ->
// 4.14e-5 J, ContactChurnEnsemble.LongHeldForceReleaseLowersTheFrictionlessChurn).
TEST(ContactChurnLedger, ReleasingSeparatingPairsStopsThePushButTheStackStillChurns) {
  const ChurnLedger on = take_ledger(1e-3, true);
  expect_consistent(on);
  EXPECT_LT(on.rigid_integrate, 0.0);
  EXPECT_GT(on.kinetic_late_max, on.rest_floor);  // not resting: the churn test stays disabled
  const ChurnLedger half = take_ledger(5e-4, true);
  EXPECT_LT(half.kinetic_late_max, half.rest_floor);
}

// With friction (mu 0.5, the membrane stack's and the fruit dish's case) stage 5 is no longer a
// sink (session 9): its friction moves (dt dv, docs/stability.md M6a) store elastic energy at rest,
// +1.2e-4 J per late step at full held strength and +9.5e-5 J at 0.8, which the integration takes out
// again (-1.5e-4 / -2.1e-4 J). The stage-5 sign holds at both fractions; what tells the resting
// stack (0.8: late KE 2.2e-6 J, below the floor 2.6e-6 J) from the churning one (1: 1.4e-5 J) is
// the held fraction (ContactChurnMechanism, contact_churn_mechanism_long_test.cpp, over 8 starts).
TEST(ContactChurnLedger, FrictionMovesStoreEnergyInStage5AtRest) {
  for (double fraction : {1.0, 0.8}) {
    const ChurnLedger l = take_ledger(1e-3, false, 0.5, fraction);
    expect_consistent(l);
    EXPECT_GT(l.velocity, 0.0) << fraction;
    EXPECT_LT(l.integrate, 0.0) << fraction;
  }
}

}  // namespace
}  // namespace pliant
