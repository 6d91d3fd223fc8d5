// A StepProfiler backed by a Clock: sim stays clock-free, the caller times the named stages.
#pragma once

#include <array>

#include "interaction/clock.h"
#include "sim/step_report.h"

namespace pliant {

class ClockStageProfiler final : public StepProfiler {
 public:
  explicit ClockStageProfiler(const Clock& clock) : clock_(clock) {}
  void begin(StepStage stage) override { start_[static_cast<size_t>(stage)] = clock_.now(); }
  void end(StepStage stage) override {
    const auto i = static_cast<size_t>(stage);
    seconds_[i] = clock_.now() - start_[i];
  }
  /// Seconds the stage took in the last step.
  double seconds(StepStage stage) const { return seconds_[static_cast<size_t>(stage)]; }
  /// Sum over all stages of the last step.
  double total() const {
    double sum = 0.0;
    for (double s : seconds_) sum += s;
    return sum;
  }

 private:
  const Clock& clock_;
  std::array<double, kStepStageCount> start_{};
  std::array<double, kStepStageCount> seconds_{};
};

}  // namespace pliant
