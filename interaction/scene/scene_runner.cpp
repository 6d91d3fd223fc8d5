#include "interaction/scene/scene_runner.h"

namespace pliant {

SceneRunner::SceneRunner(const Scene& scene) : scene_(scene), instance_(instantiate_scene(scene_)) {
  readings_.resize(instance_.instruments.size());
  for (size_t i = 0; i < readings_.size(); ++i) readings_[i].position = instance_.instruments[i].pose().translation;
}

void SceneRunner::command_instruments(double t_end) {
  for (size_t i = 0; i < instance_.instruments.size(); ++i) {
    InstrumentFeedback feedback{time(), readings_[i].force, readings_[i].torque};
    const InstrumentCommand cmd = instance_.pose_sources[i]->sample(t_end, feedback);
    instance_.instruments[i].apply(*instance_.world, cmd);
  }
}

bool SceneRunner::tick(StepProfiler* profiler) {
  World& world = *instance_.world;
  const double dt = scene_.time_step;
  command_instruments(time() + dt);
  report_ = world.step(dt, profiler);
  if (report_.fault != StepFault::none) {
    // The world restored its last good state: try the same interval as two half steps.
    ++retried_;
    const std::string first_fault = report_.fault_message;
    command_instruments(time() + 0.5 * dt);
    report_ = world.step(0.5 * dt, profiler);
    if (report_.fault == StepFault::none) {
      command_instruments(time() + 0.5 * dt);
      report_ = world.step(0.5 * dt, profiler);
    }
    if (report_.fault != StepFault::none) {
      fault_ = "step at t = " + std::to_string(time()) + " s failed: " + first_fault + "; at half dt: " +
               report_.fault_message;
      return false;
    }
  }
  for (size_t i = 0; i < instance_.instruments.size(); ++i) {
    readings_[i].force = instance_.instruments[i].force(report_);
    readings_[i].torque = instance_.instruments[i].torque(report_);
    readings_[i].position = instance_.instruments[i].pose().translation;
  }
  return true;
}

}  // namespace pliant
