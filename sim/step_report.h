// What one World::step did: stage results, contact metrics, energies and faults (STYLE.md 6:
// trouble inside a step is a flag here, never an exception).
#pragma once

#include <string>
#include <vector>

#include "sim/math_types.h"

namespace pliant {

/// The named stages of a step, in order (DESIGN.md).
enum class StepStage { integrate, detect, depth, respond, report };
inline constexpr int kStepStageCount = 5;
const char* to_string(StepStage stage);

/// Receives stage boundaries; interaction/ supplies one backed by a clock. sim has no clock.
class StepProfiler {
 public:
  virtual ~StepProfiler() = default;
  virtual void begin(StepStage stage) = 0;
  virtual void end(StepStage stage) = 0;
};

/// Reaction force and torque on one kinematic body: the instrument's haptic force.
struct KinematicReaction {
  int body = -1;
  Vec3 force = Vec3::Zero();   ///< N, force the tissue exerts on the kinematic body
  Vec3 torque = Vec3::Zero();  ///< N m, about the body's pose origin
};

/// Total contact force between two bodies over a step.
struct PairContactForce {
  int body_a = -1;
  int body_b = -1;
  Vec3 force_on_a = Vec3::Zero();  ///< N, contact impulses on a / dt (equal and opposite to b's)
  Vec3 force_on_b = Vec3::Zero();  ///< N
  /// N, the restoring forces each body's own elasticity exerts through its displaced surface
  /// vertices (contact-surface method only). They cancel to the accuracy of the pressure balance:
  /// |elastic_on_a + elastic_on_b| / max(|.|) measures how well Newton's third law holds.
  Vec3 elastic_on_a = Vec3::Zero();
  Vec3 elastic_on_b = Vec3::Zero();
  int contacts = 0;
};

/// Energy per body and totals (J). Work terms accumulate over the run.
struct EnergyReport {
  double kinetic = 0.0;
  double elastic = 0.0;
  double gravitational = 0.0;      ///< m g h relative to the start of the run
  double work_by_kinematic = 0.0;  ///< work done on deformable bodies by kinematic bodies
  double work_by_supports = 0.0;   ///< work done by fixed vertices (zero unless they move)
  double total() const { return kinetic + elastic + gravitational; }
};

/// Faults met inside a step.
enum class StepFault { none, non_finite, diverged };

struct StepReport {
  long step_index = 0;
  double time = 0.0;  ///< simulated time after the step (s)
  double dt = 0.0;

  // integrate
  int solver_iterations_max = 0;
  bool solver_converged = true;
  int substeps_max = 1;

  // detect / depth
  int colliding_vertices = 0;
  double max_penetration_before = 0.0;  ///< m, largest penetration depth before response

  // respond
  double max_residual_overlap = 0.0;    ///< m, largest remaining penetration after response
  double pressure_imbalance_mean = 0.0; ///< mean |pM - pN| / max(pM, pN) over contact vertices
  double pressure_imbalance_max = 0.0;
  double total_contact_force = 0.0;     ///< N, sum of contact force magnitudes on deformable bodies
  int binary_search_iterations = 0;
  std::vector<KinematicReaction> reactions;
  std::vector<PairContactForce> pair_forces;

  // sleeping (sim/sleep/sleep_settings.h)
  int sleeping_bodies = 0;  ///< deformable bodies asleep after the step
  int bodies_woken = 0;     ///< sleeping bodies woken by contact in this step

  // report
  std::vector<EnergyReport> body_energy;  ///< per body slot
  EnergyReport energy;                    ///< sum over bodies
  bool all_finite = true;
  StepFault fault = StepFault::none;
  std::string fault_message;
};

}  // namespace pliant
