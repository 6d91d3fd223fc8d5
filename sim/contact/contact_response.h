// Stages 3-5 behind one interface: the contact-surface method and the penalty baseline differ only
// here; detection and penetration depth are shared (issue 5, item 7).
#pragma once

#include <span>

#include "sim/body.h"
#include "sim/collision/contact_types.h"
#include "sim/contact/contact_settings.h"
#include "sim/parallel/task_executor.h"
#include "sim/step_report.h"

namespace pliant {

class ContactResponse {
 public:
  virtual ~ContactResponse() = default;
  /// Resolves `contacts` by changing positions and velocities of the deformable bodies, and fills
  /// the respond fields of `report` (reactions, pair forces, residual overlap, pressure imbalance).
  /// `bodies` is indexed by body slot; null for empty slots.
  virtual void respond(std::span<Body* const> bodies, std::span<const VertexContact> contacts, double dt,
                       const ContactSettings& settings, StepReport& report) = 0;
  /// Warm start: adds to `forces` (N, one per vertex of `body`) the contact forces this response
  /// holds from its last step, to act during the next integration, and forgets them (each held
  /// force acts in one integration only). The world calls it for every integrated body.
  virtual void take_held_forces(const Body& body, std::span<Vec3> forces) {
    (void)body;
    (void)forces;
  }
  /// True if contacts of the last step still hold a force, so the next response must run even when
  /// detection finds no overlap (a held force that keeps a dent exactly closed leaves none).
  virtual bool has_held_contacts() const { return false; }
  /// Keeps the held forces as they are before a step (the world calls it with its own state save).
  virtual void save_held_forces() {}
  /// Restores the held forces kept by save_held_forces(): a step that faulted and was undone
  /// neither consumed the held forces nor holds its own (the retried step takes the same ones).
  virtual void restore_held_forces() {}
  /// The contacts of the last step that still hold a force (body indices are slots); empty if none.
  virtual std::span<const VertexContact> held_contacts() const { return {}; }
  /// The bodies' velocities at the step's start (per slot; kept by the world for its own restore),
  /// for responses that book the integration's energy flow (ContactSettings::
  /// limit_friction_move_energy_flow). Not owned; valid through the step.
  virtual void set_step_start_velocities(const std::vector<std::vector<Vec3>>* velocities) { (void)velocities; }
  /// Threads the response may run its per-body work on (not owned; null: one). Default: unused.
  virtual void set_executor(TaskExecutor* executor) { (void)executor; }
};

}  // namespace pliant
