// Where does the contact response create energy? (issue 8 finding F1, docs/stability.md.)
// An energy ledger per stage of one step, on the stability matrix's resting block: the world runs
// with contact method `none` (integrate, detect, depth), and the test applies the contact-surface
// response itself with an observer after each of its stages, so the energy (kinetic + elastic +
// gravitational) is known after integrate, after the displacement of the search, and after the
// velocity update. Integrate (implicit Euler with Rayleigh damping) and an inelastic velocity update
// can only remove energy; the ledger says which stage adds it and on which vertices.
#include <cstdio>

#include "sim/contact/contact_surface_response.h"
#include "sim/stability_harness.h"

namespace pliant::stability {
namespace {

/// Kinetic + elastic + gravitational energy of the deformable bodies (J), gravity relative to x0.
struct Energy {
  double kinetic = 0.0, elastic = 0.0, gravitational = 0.0;
  double total() const { return kinetic + elastic + gravitational; }
};

Energy energy_of(World& world, const std::vector<std::vector<Vec3>>& x0) {
  Energy e;
  const auto bodies = world.bodies();
  for (size_t i = 0; i < bodies.size(); ++i) {
    Body* b = bodies[i];
    if (b == nullptr || b->is_kinematic()) continue;
    for (size_t v = 0; v < b->positions.size(); ++v) {
      e.kinetic += 0.5 * b->masses[v] * b->velocities[v].squaredNorm();
      e.gravitational -= b->masses[v] * world.settings().gravity.dot(b->positions[v] - x0[i][v]);
    }
    e.elastic += b->model->elastic_energy(b->positions);
  }
  return e;
}

/// The ledger of a run: energy added (sum of positive changes) and net change per stage (J).
struct Ledger {
  double integrate_added = 0.0, search_added = 0.0, velocity_added = 0.0;
  double integrate_net = 0.0, search_net = 0.0, velocity_net = 0.0;
  // Search stage split by which vertices are displaced (energy change with only those displaced).
  double search_upper = 0.0, search_lower = 0.0, search_colliding = 0.0, search_triangle = 0.0;
  double search_elastic = 0.0, search_gravitational = 0.0;
  double max_total = 0.0;  ///< J, max over steps of the energy at the end of the step
  double scale = 0.0;      ///< J, the scene's energy scale
};

Ledger run_ledger(const Case& c, int steps, bool print, bool warm_start = false) {
  WorldSettings settings = world_settings(c);
  settings.contact.method = ContactMethod::none;
  World world(settings);
  const Scene scene = build_scene(c, world);
  std::vector<std::vector<Vec3>> x0;
  for (Body* b : world.bodies()) x0.push_back(b->positions);

  ContactSettings contact = world_settings(c).contact;
  contact.held_force_fraction = warm_start ? kHeldForceFraction : 0.0;
  ContactSurfaceResponse response;
  Ledger ledger;
  ledger.scale = scene.scale;
  Energy after_integrate, after_search, after_velocity;
  std::vector<std::vector<Vec3>> before;  // positions before the response
  std::vector<char> colliding_lower, colliding_upper;
  response.observer = [&](ContactStage stage) {
    if (stage == ContactStage::search) {
      after_search = energy_of(world, x0);
      // Attribution: the search's energy change with only a subset of the vertices displaced.
      const auto bodies = world.bodies();
      std::vector<std::vector<Vec3>> after;
      for (Body* b : bodies) after.push_back(b->positions);
      auto with_only = [&](auto keep) {
        for (size_t i = 0; i < bodies.size(); ++i) {
          for (size_t v = 0; v < after[i].size(); ++v) {
            bodies[i]->positions[v] = keep(i, v) ? after[i][v] : before[i][v];
          }
        }
        const double e = energy_of(world, x0).total() - after_integrate.total();
        for (size_t i = 0; i < bodies.size(); ++i) bodies[i]->positions = after[i];
        return e;
      };
      const size_t lower = scene.lower.index, upper = scene.upper.index;
      auto colliding = [&](size_t i, size_t v) {
        return (i == lower ? colliding_lower : colliding_upper)[v] != 0;
      };
      ledger.search_upper += with_only([&](size_t i, size_t) { return i == upper; });
      ledger.search_lower += with_only([&](size_t i, size_t) { return i == lower; });
      ledger.search_colliding += with_only([&](size_t i, size_t v) { return colliding(i, v); });
      ledger.search_triangle += with_only([&](size_t i, size_t v) { return !colliding(i, v); });
      ledger.search_elastic += after_search.elastic - after_integrate.elastic;
      ledger.search_gravitational += after_search.gravitational - after_integrate.gravitational;
    } else if (stage == ContactStage::velocity_update) {
      after_velocity = energy_of(world, x0);
    }
  };

  Energy end = energy_of(world, x0);
  for (int i = 0; i < steps; ++i) {
    for (Body* b : world.bodies()) {
      std::fill(b->applied_forces.begin(), b->applied_forces.end(), Vec3::Zero());
      if (!b->is_kinematic()) response.take_held_forces(*b, b->applied_forces);
    }
    const StepReport r = world.step(c.dt);
    EXPECT_TRUE(r.all_finite);
    after_integrate = energy_of(world, x0);
    after_search = after_velocity = after_integrate;
    before.clear();
    for (Body* b : world.bodies()) before.push_back(b->positions);
    colliding_lower.assign(world.body(scene.lower).positions.size(), 0);
    colliding_upper.assign(world.body(scene.upper).positions.size(), 0);
    for (const VertexContact& vc : world.contacts()) {
      (static_cast<uint32_t>(vc.body) == scene.lower.index
           ? colliding_lower
           : colliding_upper)[static_cast<size_t>(vc.vertex)] = 1;
    }
    if (!world.contacts().empty()) {
      StepReport rr;
      response.respond(world.bodies(), world.contacts(), c.dt, contact, rr);
    }
    const Energy next = energy_of(world, x0);
    const double d_int = after_integrate.total() - end.total();
    const double d_search = after_search.total() - after_integrate.total();
    const double d_vel = next.total() - after_search.total();
    ledger.integrate_added += std::max(0.0, d_int);
    ledger.search_added += std::max(0.0, d_search);
    ledger.velocity_added += std::max(0.0, d_vel);
    ledger.integrate_net += d_int;
    ledger.search_net += d_search;
    ledger.velocity_net += d_vel;
    ledger.max_total = std::max(ledger.max_total, next.total());
    if (print && i % 50 == 0) {
      double pen = 0.0;
      for (const VertexContact& vc : world.contacts()) pen = std::max(pen, vc.penetration_depth);
      std::printf("%3d max depth %.2e m  KE %.2e EL %.3e GR %.3e J\n", i, pen, next.kinetic, next.elastic,
                  next.gravitational);
      std::printf(
          "%3d nc=%3zu E=%.3e | int %+.2e (KE %+.2e EL %+.2e GR %+.2e) | search %+.2e (EL %+.2e GR %+.2e) | "
          "vel %+.2e\n",
          i, world.contacts().size(), next.total(), d_int, after_integrate.kinetic - end.kinetic,
          after_integrate.elastic - end.elastic, after_integrate.gravitational - end.gravitational, d_search,
          after_search.elastic - after_integrate.elastic,
          after_search.gravitational - after_integrate.gravitational, d_vel);
    }
    end = next;
  }
  if (print) {
    std::printf(
        "%s, held forces %s: max E %.3e J (scale %.3e J)\n  added: integrate %.3e, search %.3e, velocity "
        "%.3e\n"
        "  net: integrate %.3e, search %.3e (elastic %.3e, gravity %.3e), velocity %.3e\n"
        "  search with only: upper %.3e, lower %.3e, colliding %.3e, triangle-only %.3e\n",
        c.name.c_str(), warm_start ? "on" : "off", ledger.max_total, ledger.scale, ledger.integrate_added,
        ledger.search_added, ledger.velocity_added, ledger.integrate_net, ledger.search_net,
        ledger.search_elastic, ledger.search_gravitational, ledger.velocity_net, ledger.search_upper,
        ledger.search_lower, ledger.search_colliding, ledger.search_triangle);
  }
  return ledger;
}

// F1 (docs/stability.md): with the paper's response alone, the search's displacement stores
// energy every step that the next integration releases (the dent springs back, re-creating the
// overlap), so the resting pair carries far more elastic energy than gravity released. Holding the
// contact forces through the integration (ContactSettings::held_force_fraction) stops the cycle.
void expect_held_forces_stop_the_pumping(const Case& c, bool within_budget) {
  const Ledger paper = run_ledger(c, 300, true, false);
  const Ledger held = run_ledger(c, 300, true, true);
  const double floor = kEnergyFloorFraction * paper.scale;
  // Before: the energy exceeds what gravity released by more than the stability check allows.
  EXPECT_GT(paper.max_total, (1.0 + kEnergyTolerance) * floor) << c.name;
  // The search stage is the source: integrate and the velocity update remove energy on balance.
  EXPECT_GT(paper.search_net, 0.0) << c.name;
  EXPECT_LT(paper.integrate_net, 0.0) << c.name;
  EXPECT_LE(paper.velocity_net, 0.1 * paper.search_net) << c.name;
  // After: the search stores a tenth of the energy or less, and the surplus falls 20-fold or more
  // (at nu 0.45 into the stability check's budget; at ratio 1e3 measured 98.9 -> 1.5 mJ).
  EXPECT_LT(held.search_added, 0.1 * paper.search_added) << c.name;
  EXPECT_LT(held.max_total, 0.05 * paper.max_total) << c.name;
  if (within_budget) {
    EXPECT_LE(held.max_total, (1.0 + kEnergyTolerance) * floor) << c.name;
  }
}

TEST(ContactEnergyLedger, HeldForcesStopThePumpingAtPoisson045) {
  Case c{.name = "poisson 0.45"};
  c.poisson = 0.45;
  expect_held_forces_stop_the_pumping(c, true);
}

TEST(ContactEnergyLedger, HeldForcesStopThePumpingAtStiffnessRatio1e3) {
  Case c{.name = "stiffness ratio 1e3"};
  c.stiffness_ratio = 1e3;
  expect_held_forces_stop_the_pumping(c, false);
}

}  // namespace
}  // namespace pliant::stability
