#include "sim/world.h"

#include <cmath>
#include <stdexcept>

#include "sim/contact/contact_surface_response.h"
#include "sim/contact/penalty_response.h"
#include "sim/finite_coordinates.h"
#include "sim/input_error.h"
#include "sim/parallel/task_executor.h"
#include "sim/sleep/sleeping.h"

namespace pliant {

const char* to_string(StepStage stage) {
  switch (stage) {
    case StepStage::integrate: return "integrate";
    case StepStage::detect: return "detect";
    case StepStage::depth: return "depth";
    case StepStage::respond: return "respond";
    case StepStage::report: return "report";
  }
  return "unknown";
}

const char* to_string(ContactMethod method) {
  switch (method) {
    case ContactMethod::contact_surface: return "surface";
    case ContactMethod::penalty: return "penalty";
    case ContactMethod::none: return "none";
  }
  return "unknown";
}

namespace {

// Whether every awake body's positions are finite (a body that integrated to NaN or infinity has
// non-finite positions, since x_{n+1} = x_n + dt v_{n+1}); sleepers are skipped as in
// World::state_is_finite.
bool awake_positions_are_finite(const std::vector<Body*>& bodies) {
  for (const Body* body : bodies) {
    if (body == nullptr || body->is_sleeping()) continue;
    if (!all_coordinates_finite(body->positions)) return false;
  }
  return true;
}

// Times one stage through the caller's profiler, if any.
class StageScope {
 public:
  StageScope(StepProfiler* profiler, StepStage stage) : profiler_(profiler), stage_(stage) {
    if (profiler_ != nullptr) profiler_->begin(stage_);
  }
  ~StageScope() {
    if (profiler_ != nullptr) profiler_->end(stage_);
  }
  StageScope(const StageScope&) = delete;
  StageScope& operator=(const StageScope&) = delete;

 private:
  StepProfiler* profiler_;
  StepStage stage_;
};

void place_rest_mesh(const TetMesh& mesh, const Pose& pose, std::vector<Vec3>& x) {
  const auto& rest = mesh.rest_positions();
  x.resize(rest.size());
  for (size_t i = 0; i < rest.size(); ++i) x[i] = pose.apply(rest[i]);
}

void check_material(const Material& m, const std::string& where) {
  auto positive = [&](double value, const char* name) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      throw InputError(InputErrorKind::bad_value, where,
                       std::string(name) + ": expected a positive number, got " + std::to_string(value));
    }
  };
  positive(m.young_modulus, "young_modulus");
  positive(m.density, "density");
  if (!(m.poisson_ratio >= 0.0 && m.poisson_ratio < 0.5)) {
    throw InputError(InputErrorKind::bad_value, where,
                     "poisson_ratio: expected a number in [0, 0.5), got " + std::to_string(m.poisson_ratio));
  }
  if (!(m.mass_damping >= 0.0) || !(m.stiffness_damping >= 0.0) || !(m.friction >= 0.0)) {
    throw InputError(InputErrorKind::bad_value, where, "damping and friction must be non-negative");
  }
}

}  // namespace

World::World(WorldSettings settings)
    : settings_(settings),
      contact_surface_(std::make_unique<ContactSurfaceResponse>()),
      penalty_(std::make_unique<PenaltyResponse>()) {}

World::~World() = default;

BodyId World::add_body(BodyDef def) {
  const std::string where = def.name.empty() ? std::string("body") : "body '" + def.name + "'";
  if (!def.mesh) throw InputError(InputErrorKind::bad_value, where, "has no mesh");
  check_material(def.material, where);
  auto body = std::make_unique<Body>();
  body->name = def.name;
  body->mesh = def.mesh;
  body->material = def.material;
  body->motion = def.motion;
  body->instrument = def.motion == BodyMotion::kinematic && def.instrument;
  body->pose = def.pose;
  body->target_pose = def.pose;
  body->self_collision = def.self_collision;
  body->collision_group = def.collision_group;
  body->collision_mask = def.collision_mask;
  const auto n = static_cast<size_t>(def.mesh->vertex_count());
  place_rest_mesh(*def.mesh, def.pose, body->positions);
  body->velocities.assign(n, body->is_kinematic() ? Vec3::Zero() : def.initial_velocity);
  body->masses = def.mesh->lumped_masses(def.material.density);
  body->fixed.assign(n, 0);
  body->applied_forces.assign(n, Vec3::Zero());
  for (int v : def.fixed_vertices) {
    if (v < 0 || static_cast<size_t>(v) >= n) {
      throw InputError(InputErrorKind::index_out_of_range, where,
                       "fixed vertex " + std::to_string(v) + " is out of range");
    }
    body->fixed[static_cast<size_t>(v)] = 1;
    body->velocities[static_cast<size_t>(v)].setZero();
  }
  if (!body->is_kinematic()) {
    body->model = make_deformation_model(def.model, def.mesh, def.material, def.model_settings);
    body->model->set_executor(executor_);
  }

  // Reuse a free slot, bumping its generation, or append.
  size_t slot = slots_.size();
  for (size_t i = 0; i < slots_.size(); ++i) {
    if (!slots_[i]) {
      slot = i;
      break;
    }
  }
  if (slot == slots_.size()) {
    slots_.emplace_back();
    generations_.push_back(0);
    initial_positions_.emplace_back();
  }
  initial_positions_[slot] = body->positions;
  slots_[slot] = std::move(body);
  rebuild_body_view();
  return BodyId{static_cast<std::uint32_t>(slot), generations_[slot]};
}

void World::remove_body(BodyId id) {
  if (!is_valid(id)) throw std::out_of_range("World::remove_body: stale or invalid body handle");
  slots_[id.index].reset();
  generations_[id.index]++;
  std::erase_if(disabled_pairs_, [&](const auto& p) {
    return p.first == static_cast<int>(id.index) || p.second == static_cast<int>(id.index);
  });
  rebuild_body_view();
}

bool World::is_valid(BodyId id) const {
  return id.index < slots_.size() && slots_[id.index] && generations_[id.index] == id.generation;
}

Body& World::body(BodyId id) {
  if (!is_valid(id)) throw std::out_of_range("World::body: stale or invalid body handle");
  return *slots_[id.index];
}

const Body& World::body(BodyId id) const {
  if (!is_valid(id)) throw std::out_of_range("World::body: stale or invalid body handle");
  return *slots_[id.index];
}

BodyId World::body_id(int index) const {
  const auto i = static_cast<size_t>(index);
  if (i >= slots_.size() || !slots_[i]) throw std::out_of_range("World::body_id: empty slot");
  return BodyId{static_cast<std::uint32_t>(index), generations_[i]};
}

void World::disable_collision(BodyId a, BodyId b) {
  if (!is_valid(a) || !is_valid(b)) throw std::out_of_range("World::disable_collision: invalid handle");
  disabled_pairs_.emplace_back(static_cast<int>(a.index), static_cast<int>(b.index));
}

void World::set_kinematic_pose(BodyId id, const Pose& pose) { body(id).target_pose = pose; }

void World::wake(BodyId id) { wake_body(body(id)); }

void World::set_executor(TaskExecutor* executor) {
  executor_ = executor;
  contact_surface_->set_executor(executor);
  for (Body* b : body_view_) {
    if (b != nullptr && b->model) b->model->set_executor(executor);
  }
}

void World::rebuild_body_view() {
  body_view_.clear();
  for (auto& slot : slots_) body_view_.push_back(slot.get());
}

const StepReport& World::step(double dt, StepProfiler* profiler) {
  {  // A fresh report that keeps its vectors' capacity: no allocation per step once they have grown.
    auto reactions = std::move(report_.reactions);
    auto pair_forces = std::move(report_.pair_forces);
    auto body_energy = std::move(report_.body_energy);
    reactions.clear();
    pair_forces.clear();
    body_energy.clear();
    report_ = StepReport{};
    report_.reactions = std::move(reactions);
    report_.pair_forces = std::move(pair_forces);
    report_.body_energy = std::move(body_energy);
  }
  report_.step_index = step_count_;
  report_.dt = dt;
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    report_.fault = StepFault::diverged;
    report_.fault_message = "step: dt must be positive and finite";
    report_.all_finite = false;
    return report_;
  }

  // Keep the last good state so a faulty step can be undone.
  saved_positions_.resize(slots_.size());
  saved_velocities_.resize(slots_.size());
  saved_poses_.resize(slots_.size());
  for (size_t i = 0; i < slots_.size(); ++i) {
    if (!slots_[i]) continue;
    // A sleeper with frozen energies needs no new copy: the report sets them only while it sleeps,
    // a body falls asleep only after the report, and every wake clears them, so it has been asleep
    // and unchanged since a step start at which it was asleep and copied (by induction, its
    // first). Nothing moves a sleeper (Body::is_immovable), as the energy cache already assumes.
    if (slots_[i]->is_sleeping() && slots_[i]->sleep.has_frozen_energy) continue;
    saved_positions_[i] = slots_[i]->positions;
    saved_velocities_[i] = slots_[i]->velocities;
    saved_poses_[i] = slots_[i]->pose;
  }
  contact_surface_->save_held_forces();
  contact_surface_->set_step_start_velocities(&saved_velocities_);

  if (!settings_.sleep.enabled) {
    for (Body* b : body_view_) {
      if (b != nullptr && b->is_sleeping()) wake_body(*b);
    }
  }
  { StageScope s(profiler, StepStage::integrate); integrate(dt); }
  // A body that integrated to NaN or infinity ends the step here: collision detection, depth and
  // response have no meaning on such a state (and must not be asked to size anything from it);
  // the report finds it non-finite and the state is restored below.
  if (awake_positions_are_finite(body_view_)) {
    { StageScope s(profiler, StepStage::detect); detect(); }
    { StageScope s(profiler, StepStage::depth); compute_penetration_depth(); }
    {  // the opt-in correction is timed with the response it completes
      StageScope s(profiler, StepStage::respond);
      if (settings_.contact.implicit_correction == ImplicitCorrection::stiff_partners) {
        const auto held = contact_surface_->held_contacts();  // before respond replaces them
        held_in_step_.assign(held.begin(), held.end());
      }
      respond(dt);
      correct_in_implicit_solve(dt);
    }
  } else {
    report_.fault_message = "non-finite state after integration (contact stages skipped); state restored";
  }
  { StageScope s(profiler, StepStage::report); report(); }

  if (!report_.all_finite) {
    // Restore the last good state; the caller decides whether to go on at a smaller dt.
    for (size_t i = 0; i < slots_.size(); ++i) {
      if (!slots_[i]) continue;
      slots_[i]->positions = saved_positions_[i];
      slots_[i]->velocities = saved_velocities_[i];
      slots_[i]->pose = saved_poses_[i];
    }
    contact_surface_->restore_held_forces();
    if (report_.fault == StepFault::none) report_.fault = StepFault::non_finite;
    if (report_.fault_message.empty()) report_.fault_message = "non-finite state after step; state restored";
    return report_;
  }
  if (settings_.sleep.enabled) {
    report_.sleeping_bodies =
        update_sleep(body_view_, dt, settings_.sleep, report_.body_energy, settings_.compute_energy);
  }
  time_ += dt;
  report_.time = time_;
  ++step_count_;
  return report_;
}

void World::integrate(double dt) {
  if (!runs_parallel(executor_)) {
    for (Body* body : body_view_) {
      if (body == nullptr) continue;
      const IntegrationResult r = integrate_body(*body, external_forces_, dt);
      report_.solver_iterations_max = std::max(report_.solver_iterations_max, r.solver_iterations);
      report_.solver_converged = report_.solver_converged && r.converged;
      report_.substeps_max = std::max(report_.substeps_max, r.substeps);
    }
    return;
  }
  // Threads: each body advances on its own (its model, its scratch, its own held-force entries),
  // one body per chunk; the results are combined afterwards in slot order (max and and: the same
  // whatever the order).
  const size_t slots = body_view_.size();
  slot_external_forces_.resize(slots);
  slot_results_.assign(slots, IntegrationResult{});
  parallel_for_chunks(executor_, slots, 1, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (body_view_[i] != nullptr) slot_results_[i] = integrate_body(*body_view_[i], slot_external_forces_[i], dt);
    }
  });
  for (const IntegrationResult& r : slot_results_) {
    report_.solver_iterations_max = std::max(report_.solver_iterations_max, r.solver_iterations);
    report_.solver_converged = report_.solver_converged && r.converged;
    report_.substeps_max = std::max(report_.substeps_max, r.substeps);
  }
}

IntegrationResult World::integrate_body(Body& b, std::vector<Vec3>& external_forces, double dt) {
  Body* body = &b;
  if (body->is_sleeping()) return {};
  if (body->is_kinematic()) {
    // Prescribed motion: jump to the target pose; velocity is the finite difference over dt.
    // A body that kept its pose this step and the last is already there at rest: skip it.
    const bool moves = body->target_pose.translation != body->pose.translation ||
                       body->target_pose.rotation.coeffs() != body->pose.rotation.coeffs();
    const bool was_moving = body->moved_this_step;
    body->moved_this_step = moves;
    if (!moves && !was_moving) return {};
    const auto& rest = body->mesh->rest_positions();
    for (size_t i = 0; i < rest.size(); ++i) {
      const Vec3 next = body->target_pose.apply(rest[i]);
      body->velocities[i] = (next - body->positions[i]) / dt;
      body->positions[i] = next;
    }
    body->pose = body->target_pose;
    return {};
  }
  external_forces.resize(body->positions.size());
  for (size_t i = 0; i < external_forces.size(); ++i) {
    external_forces[i] = body->masses[i] * settings_.gravity + body->applied_forces[i];
  }
  contact_surface_->take_held_forces(*body, external_forces);  // warm start (ContactSettings)
  IntegrationInput in{body->masses, body->fixed, external_forces, dt};
  return body->model->advance(body->positions, body->velocities, in);
}

void World::build_collision_filter() {
  filter_.assign_from_bodies(collision_bodies_);  // in place: no allocation per step
  // Two kinematic bodies never need contact; neither do excluded pairs.
  for (size_t a = 0; a < body_view_.size(); ++a) {
    for (size_t b = a + 1; b < body_view_.size(); ++b) {
      if (body_view_[a] && body_view_[b] && body_view_[a]->is_kinematic() && body_view_[b]->is_kinematic()) {
        filter_.set(static_cast<int>(a), static_cast<int>(b), false);
      }
    }
  }
  for (const auto& [a, b] : disabled_pairs_) filter_.set(a, b, false);
  // Nor do two bodies that do not move (sleeping, or kinematic and still).
  if (settings_.sleep.enabled) filter_resting_pairs(body_view_, filter_);
}

void World::detect() {
  collision_bodies_.clear();
  for (Body* body : body_view_) {
    CollisionBody cb;
    if (body != nullptr) {
      cb.mesh = body->mesh.get();
      cb.positions = body->positions;
      cb.self_collision = body->self_collision;
      cb.collision_group = body->collision_group;
      cb.collision_mask = body->collision_mask;
      if (body->is_kinematic()) cb.rigid_pose = &body->pose;  // positions = pose(rest), World::integrate
    } else {
      cb.active = false;
    }
    collision_bodies_.push_back(cb);
  }
  colliding_.clear();
  // Nothing moves this step (every body asleep or a fixture that kept its pose, no instrument):
  // filter_resting_pairs would disallow every pair and the hash would find nothing, after
  // O(bodies^2) passes over the filter (0.1-0.16 ms a step for the resting fruit dish).
  if (!settings_.sleep.enabled || !nothing_moves(body_view_)) {
    build_collision_filter();
    spatial_hash_.detect(collision_bodies_, filter_, colliding_, executor_);
  }
  // A moving body touched a sleeping one: wake it and detect again with its pairs back in.
  if (settings_.sleep.enabled) {
    note_instrument_contacts(body_view_, colliding_, contact_surface_->held_contacts());
    report_.bodies_woken = wake_touched_bodies(body_view_, colliding_, settings_.sleep);
    if (report_.bodies_woken > 0) {
      build_collision_filter();
      colliding_.clear();
      spatial_hash_.detect(collision_bodies_, filter_, colliding_, executor_);
    }
    if (settings_.sleep.rest_by_centre_when_supported) {
      note_supported_bodies(body_view_, colliding_, contact_surface_->held_contacts());
    }
  }
  report_.colliding_vertices = static_cast<int>(colliding_.size());
}

void World::compute_penetration_depth() {
  contacts_.clear();
  if (colliding_.empty()) return;
  penetration_depth_.compute(collision_bodies_, colliding_, contacts_, executor_);
  for (const auto& c : contacts_) {
    report_.max_penetration_before = std::max(report_.max_penetration_before, c.penetration_depth);
  }
}

void World::respond(double dt) {
  // Every kinematic body gets a reaction entry (zero when out of contact): the haptic force.
  for (size_t i = 0; i < body_view_.size(); ++i) {
    if (body_view_[i] && body_view_[i]->is_kinematic()) {
      report_.reactions.push_back(KinematicReaction{static_cast<int>(i), Vec3::Zero(), Vec3::Zero()});
    }
  }
  // Held contact forces that closed every overlap still need their response (lingering contacts).
  const bool held = settings_.contact.method == ContactMethod::contact_surface && contact_surface_->has_held_contacts();
  if (contacts_.empty() && !held) return;
  switch (settings_.contact.method) {
    case ContactMethod::contact_surface:
      // The opt-in correction decides which held forces the response applies.
      contact_surface_->respond(body_view_, contacts_, dt, implicit_correction_.response_settings(settings_.contact),
                                report_);
      break;
    case ContactMethod::penalty:
      penalty_->respond(body_view_, contacts_, dt, settings_.contact, report_);
      break;
    case ContactMethod::none:
      for (const auto& c : contacts_) {
        report_.max_residual_overlap = std::max(report_.max_residual_overlap, c.penetration_depth);
      }
      break;
  }
}

void World::correct_in_implicit_solve(double dt) {
  if (settings_.contact.implicit_correction == ImplicitCorrection::off ||
      settings_.contact.method != ContactMethod::contact_surface) {
    return;
  }
  if (contacts_.empty()) {
    implicit_correction_.clear();  // no body re-solved this step
    return;
  }
  implicit_correction_.correct(body_view_, contacts_, held_in_step_, saved_positions_, saved_velocities_,
                               settings_.gravity, dt, settings_.contact, report_);
}

bool World::state_is_finite() const {
  for (const Body* body : body_view_) {
    // A sleeper's state was finite when it fell asleep (update_sleep follows a finite report) and
    // nothing moves it since: checking it again would cost a pass over its vertices each step.
    if (body == nullptr || body->is_sleeping()) continue;
    // The answer of allFinite per vertex (session 18: that loop cost ~58 k instructions per probe step).
    if (!all_coordinates_finite(body->positions) || !all_coordinates_finite(body->velocities)) return false;
  }
  return true;
}

void World::report() {
  report_.all_finite = state_is_finite();
  for (const auto& r : report_.reactions) {
    if (!r.force.allFinite() || !r.torque.allFinite()) report_.all_finite = false;
  }
  if (!report_.all_finite) return;

  // Work done on the tissue by kinematic bodies over this step: -(reaction) . displacement.
  for (const auto& r : report_.reactions) {
    const Body& b = *body_view_[static_cast<size_t>(r.body)];
    const Vec3 moved = b.pose.translation - saved_poses_[static_cast<size_t>(r.body)].translation;
    accumulated_work_.work_by_kinematic += -r.force.dot(moved);
  }
  report_.body_energy.assign(slots_.size(), EnergyReport{});
  report_.energy = EnergyReport{};
  // Each body's energies on its own (threads: one body per chunk), summed afterwards in slot order.
  parallel_for_chunks(executor_, body_view_.size(), 1, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) report_.body_energy[i] = body_energy(i);
  });
  for (size_t i = 0; i < body_view_.size(); ++i) {
    const Body* body = body_view_[i];
    if (body == nullptr || body->is_kinematic()) continue;
    const EnergyReport& e = report_.body_energy[i];
    report_.energy.kinetic += e.kinetic;
    report_.energy.elastic += e.elastic;
    report_.energy.gravitational += e.gravitational;
  }
  report_.energy.work_by_kinematic = accumulated_work_.work_by_kinematic;
  report_.energy.work_by_supports = accumulated_work_.work_by_supports;
  if (!std::isfinite(report_.energy.total())) report_.all_finite = false;
}

EnergyReport World::body_energy(size_t i) {
  EnergyReport e;
  Body* body = body_view_[i];
  if (body == nullptr || body->is_kinematic()) return e;
  SleepState& sleep = body->sleep;
  if (body->is_sleeping() && sleep.has_frozen_energy && sleep.frozen_energy_gravity == settings_.gravity) {
    // Frozen state: the sums below would give these bits again (a fully asleep pile costs no pass).
    e.kinetic = sleep.frozen_kinetic_energy;
    e.gravitational = sleep.frozen_gravitational_energy;
  } else {
    for (size_t v = 0; v < body->positions.size(); ++v) {
      e.kinetic += 0.5 * body->masses[v] * body->velocities[v].squaredNorm();
      e.gravitational -= body->masses[v] * settings_.gravity.dot(body->positions[v] - initial_positions_[i][v]);
    }
    if (body->is_sleeping()) {
      sleep.has_frozen_energy = true;
      sleep.frozen_kinetic_energy = e.kinetic;
      sleep.frozen_gravitational_energy = e.gravitational;
      sleep.frozen_energy_gravity = settings_.gravity;
    }
  }
  if (body->is_sleeping() && body->sleep.has_elastic_energy) {
    e.elastic = body->sleep.elastic_energy;  // positions unchanged since it fell asleep
  } else if (settings_.compute_energy) {
    e.elastic = body->model->elastic_energy(body->positions);
  }
  return e;
}

}  // namespace pliant
