// World: bodies addressed by handles, gravity, contact settings, and step(dt). The caller owns
// time. A step is five named stages run in order: integrate, detect, depth, respond, report.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "sim/body.h"
#include "sim/collision/contact_types.h"
#include "sim/collision/penetration_depth.h"
#include "sim/collision/spatial_hash.h"
#include "sim/contact/contact_response.h"
#include "sim/contact/contact_settings.h"
#include "sim/contact/implicit_contact_correction.h"
#include "sim/sleep/sleep_settings.h"
#include "sim/step_report.h"

namespace pliant {

class TaskExecutor;

/// A handle to a body: an index plus a generation, checked on use (STYLE.md 4).
struct BodyId {
  std::uint32_t index = ~0u;
  std::uint32_t generation = 0;
  bool operator==(const BodyId&) const = default;
};

struct WorldSettings {
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);  ///< m/s^2
  ContactSettings contact;
  bool compute_energy = true;  ///< elastic energy costs one force evaluation per body per step
  SleepSettings sleep;         ///< bodies at rest sleep (off unless enabled)
};

class World {
 public:
  explicit World(WorldSettings settings = {});
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  /// Adds a body; throws InputError if the definition is invalid (checked here, once).
  BodyId add_body(BodyDef def);
  /// Removes a body; its handle (and copies of it) become invalid.
  void remove_body(BodyId id);
  bool is_valid(BodyId id) const;
  /// The body behind a handle; throws std::out_of_range for a stale or invalid handle.
  Body& body(BodyId id);
  const Body& body(BodyId id) const;
  /// Handle of the body in slot `index` (for iterating reports, which use slot indices).
  BodyId body_id(int index) const;
  /// Body slots, null where removed; indices match VertexContact::body and reports.
  std::span<Body* const> bodies() const { return body_view_; }

  /// Excludes a pair from collision (e.g. a fixture and the tissue clamped to it).
  void disable_collision(BodyId a, BodyId b);

  /// Wakes a sleeping body now (no effect on an awake one).
  void wake(BodyId id);

  /// Sets where a kinematic body will be after the next step (its velocity follows from dt).
  void set_kinematic_pose(BodyId id, const Pose& pose);

  /// Runs the step's per-body and per-element loops through `executor` (not owned; it must outlive
  /// its use; null, the default: one thread). Every thread count gives the same bits (docs/threads.md).
  void set_executor(TaskExecutor* executor);
  /// The executor the step runs its loops through (null: one thread).
  TaskExecutor* executor() const { return executor_; }

  /// Advances the world by dt (s). Never throws on numerical trouble: a NaN or divergence sets
  /// report.fault, and the world is restored to its state before the step.
  const StepReport& step(double dt, StepProfiler* profiler = nullptr);

  WorldSettings& settings() { return settings_; }
  const WorldSettings& settings() const { return settings_; }
  double time() const { return time_; }
  long step_count() const { return step_count_; }
  const StepReport& last_report() const { return report_; }
  /// Colliding vertices with depth and contact triangle found in the last step (before response).
  const std::vector<VertexContact>& contacts() const { return contacts_; }
  /// The opt-in contact correction inside the implicit solve (ContactSettings::implicit_correction):
  /// its constraint forces of the last step.
  const ImplicitContactCorrection& implicit_contact_correction() const { return implicit_correction_; }

 private:
  // The stages of step(), in order.
  void integrate(double dt);
  void detect();
  void compute_penetration_depth();
  void respond(double dt);
  /// Opt-in, after respond: re-solves contact bodies' implicit steps with the contact surface prescribed.
  void correct_in_implicit_solve(double dt);
  void report();

  /// One body's integration (integrate's loop body); `external_forces` is its scratch.
  IntegrationResult integrate_body(Body& body, std::vector<Vec3>& external_forces, double dt);
  /// Kinetic, gravitational and elastic energy of the deformable body in slot i (report's loop body).
  EnergyReport body_energy(size_t i);

  void rebuild_body_view();
  void build_collision_filter();
  bool state_is_finite() const;

  WorldSettings settings_;
  std::vector<std::unique_ptr<Body>> slots_;
  std::vector<std::uint32_t> generations_;
  std::vector<Body*> body_view_;
  std::vector<std::pair<int, int>> disabled_pairs_;
  std::vector<std::vector<Vec3>> initial_positions_;  ///< for gravitational energy, per slot

  SpatialHash spatial_hash_;
  PenetrationDepthSolver penetration_depth_;
  std::unique_ptr<ContactResponse> contact_surface_;
  std::unique_ptr<ContactResponse> penalty_;
  ImplicitContactCorrection implicit_correction_;

  std::vector<Vec3> external_forces_;  ///< integrate scratch: gravity plus applied forces
  /// The contact-surface response's held contacts whose forces acted in this step's integration
  /// (ImplicitCorrection::stiff_partners: a body one of them pressed is left to the response).
  std::vector<VertexContact> held_in_step_;
  std::vector<CollisionBody> collision_bodies_;
  CollisionFilter filter_;
  std::vector<VertexInTet> colliding_;
  std::vector<VertexContact> contacts_;
  std::vector<std::vector<Vec3>> saved_positions_, saved_velocities_;
  std::vector<Pose> saved_poses_;
  StepReport report_;
  EnergyReport accumulated_work_;
  double time_ = 0.0;
  long step_count_ = 0;
  // Threads (set_executor): per-slot scratch so bodies integrate side by side.
  TaskExecutor* executor_ = nullptr;
  std::vector<std::vector<Vec3>> slot_external_forces_;
  std::vector<IntegrationResult> slot_results_;
};

}  // namespace pliant
