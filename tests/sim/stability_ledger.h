// Per-stage energy ledger of one stability case (docs/stability.md, "Session 8"): where the energy
// of a failing contact-surface case enters. The world runs with contact method `none` and the
// ledger applies the contact-surface response itself, as tests/sim/contact_churn_ledger_test.cpp
// does (held forces through the bodies' applied forces, the response's observer after the search),
// which reproduces the World's own step (checked by stability_ledger_test.cpp). Each body's energy
// (kinetic + elastic from the model's read-only query + gravitational relative to the start) is
// taken at the step's start, after the integration, after the search (stages 3-4, with the finishing
// projection when on) and after stage 5 (velocity update and friction). Block cases only: an
// instrument's work is not booked here.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <vector>

#include "sim/contact/contact_surface_response.h"
#include "sim/stability_harness.h"

namespace pliant::stability {

/// One body's energy change per stage, summed over the run (J).
struct StageSums {
  double integrate = 0.0;  ///< the implicit step (with the held forces as external forces)
  double search = 0.0;     ///< stages 3-4: displacement to the contact surface (and the projection)
  double velocity = 0.0;   ///< stage 5: normal velocity update, friction impulses and moves
};

/// What the ledger measured over a case's run; index 0 is the lower block, 1 the upper.
struct StageLedger {
  std::array<StageSums, 2> body;
  double max_total = 0.0;    ///< J, max over steps of both bodies' energy after the step
  double final_total = 0.0;  ///< J, both bodies' energy after the last step
  int steps = 0;
  std::array<std::vector<Vec3>, 2> final_positions;  ///< m, each body's vertices after the run
};

/// One step's energy change per stage and body (J), index 0 the lower block, 1 the upper.
using StepStages = std::array<StageSums, 2>;
/// Called after each step with the step index, the world, the response (its held contacts are
/// those it will hold into the next step) and the step's per-stage energy changes.
using StepObserver = std::function<void(int, const World&, const ContactSurfaceResponse&, const StepStages&)>;

/// Runs case `c` (Partner::block) with the contact-surface response applied by hand and books each
/// stage's energy change per body; `after_step` (optional) sees every step.
inline StageLedger take_stage_ledger(const Case& c, const StepObserver& after_step = {}) {
  WorldSettings ws = world_settings(c);
  const ContactSettings contact = ws.contact;
  ws.contact.method = ContactMethod::none;  // the ledger applies the response itself
  World world(ws);
  const Scene scene = build_scene(c, world);
  const std::array<BodyId, 2> ids = {scene.lower, scene.upper};
  const Vec3 gravity = world.settings().gravity;
  std::array<std::vector<Vec3>, 2> start;
  for (size_t k = 0; k < 2; ++k) start[k] = world.body(ids[k]).positions;
  auto energy = [&](size_t k) {
    Body& b = world.body(ids[k]);
    double e = b.model->elastic_energy(b.positions);
    for (size_t v = 0; v < b.positions.size(); ++v) {
      e += 0.5 * b.masses[v] * b.velocities[v].squaredNorm();
      e -= b.masses[v] * gravity.dot(b.positions[v] - start[k][v]);
    }
    return e;
  };
  ContactSurfaceResponse response;
  std::array<double, 2> after_search{};
  response.observer = [&](ContactStage stage) {
    if (stage == ContactStage::velocity_update) return;
    for (size_t k = 0; k < 2; ++k) after_search[k] = energy(k);  // search, then the projection
  };
  StageLedger out;
  out.steps = std::clamp(static_cast<int>(std::lround(c.duration / c.dt)), kMinSteps, kMaxSteps);
  for (int i = 0; i < out.steps; ++i) {
    std::array<double, 2> before{}, integrated{};
    for (size_t k = 0; k < 2; ++k) {
      before[k] = energy(k);
      Body& b = world.body(ids[k]);
      std::fill(b.applied_forces.begin(), b.applied_forces.end(), Vec3::Zero());
      response.take_held_forces(b, b.applied_forces);
    }
    world.step(c.dt);
    for (size_t k = 0; k < 2; ++k) after_search[k] = integrated[k] = energy(k);
    if (!world.contacts().empty() || response.has_held_contacts()) {
      StepReport report;
      response.respond(world.bodies(), world.contacts(), c.dt, contact, report);
    }
    double total = 0.0;
    StepStages stages;
    for (size_t k = 0; k < 2; ++k) {
      const double end = energy(k);
      stages[k] = {integrated[k] - before[k], after_search[k] - integrated[k], end - after_search[k]};
      out.body[k].integrate += stages[k].integrate;
      out.body[k].search += stages[k].search;
      out.body[k].velocity += stages[k].velocity;
      total += end;
    }
    if (after_step) after_step(i, world, response, stages);
    out.max_total = std::max(out.max_total, total);
    out.final_total = total;
  }
  for (size_t k = 0; k < 2; ++k) out.final_positions[k] = world.body(ids[k]).positions;
  return out;
}

}  // namespace pliant::stability
