// SceneRunner: one physics tick of a scene with its instruments, shared by `pliant run`,
// `pliant bench`, experiments and tests. Each tick: every pose source is sampled for the end of
// the step (told its instrument's last force), the instruments are moved, the world steps, and
// the instruments' forces are read back. A step that meets a fault is retried as two half steps;
// if that fails too the runner stops with the fault (the world keeps its last good state).
#pragma once

#include <string>
#include <vector>

#include "interaction/scene/scene.h"
#include "interaction/scene/stage_profiler.h"

namespace pliant {

/// Force and torque on one instrument after a tick.
struct InstrumentReading {
  Vec3 force = Vec3::Zero();   ///< N, tissue on instrument
  Vec3 torque = Vec3::Zero();  ///< N m, about the instrument origin
  Vec3 position = Vec3::Zero();  ///< m, instrument origin
};

class SceneRunner {
 public:
  explicit SceneRunner(const Scene& scene);

  /// Runs one tick of dt = scene.time_step. Returns false if the step failed even when halved
  /// (see fault()); the world then holds its last good state.
  bool tick(StepProfiler* profiler = nullptr);

  World& world() { return *instance_.world; }
  const World& world() const { return *instance_.world; }
  const Scene& scene() const { return scene_; }
  const SceneInstance& instance() const { return instance_; }
  const StepReport& report() const { return report_; }
  const std::vector<InstrumentReading>& readings() const { return readings_; }
  double time() const { return instance_.world->time(); }
  /// Steps that had to be retried at half dt.
  long retried_steps() const { return retried_; }
  const std::string& fault() const { return fault_; }

 private:
  void command_instruments(double t_end);

  Scene scene_;
  SceneInstance instance_;
  StepReport report_;
  std::vector<InstrumentReading> readings_;
  long retried_ = 0;
  std::string fault_;
};

}  // namespace pliant
