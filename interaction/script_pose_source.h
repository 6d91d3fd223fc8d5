// A PoseSource playing one instrument's keyframes of a ToolScript (issue 6, item 3).
// Segments run in order; each starts where the previous one actually ended (a press-until-force
// ends where the force was reached), so the source is stateful and t must not decrease.
#pragma once

#include <memory>

#include "interaction/pose_source.h"
#include "interaction/tool_script.h"

namespace pliant {

class ScriptPoseSource final : public PoseSource {
 public:
  /// `initial` is the instrument's pose and jaw opening at t = 0.
  ScriptPoseSource(const ToolScript& script, std::string instrument, const InstrumentCommand& initial);

  const std::string& instrument() const override { return instrument_; }
  InstrumentCommand sample(double t, const InstrumentFeedback& fb) override;
  bool finished(double t) const override;

  /// Keyframes this source plays.
  const std::vector<ScriptKeyframe>& keyframes() const { return keyframes_; }
  /// Time (s) at which a press-until-force segment detected its force, or -1 if none yet.
  double force_reached_time() const { return force_reached_time_; }

 private:
  struct PressState {
    int phase = 0;                  ///< 0 accelerating/cruising, 1 decelerating, 2 stopped
    double decel_start = 0.0;       ///< s, segment-local time deceleration began
    double decel_distance0 = 0.0;   ///< m, distance at decel start
    double decel_speed0 = 0.0;      ///< m/s, speed at decel start
  };
  void begin_segment(size_t index);
  InstrumentCommand evaluate(size_t index, double t, const InstrumentFeedback* fb);
  double press_distance(const ScriptKeyframe& k, double tau, double duration, const InstrumentFeedback* fb);

  std::string instrument_;
  std::vector<ScriptKeyframe> keyframes_;
  size_t segment_ = 0;               ///< index of the current segment
  double segment_start_time_ = 0.0;  ///< s
  InstrumentCommand segment_start_;  ///< command at the start of the current segment
  InstrumentCommand last_;           ///< last command returned
  PressState press_;
  double force_reached_time_ = -1.0;
  double last_t_ = -1e300;
};

}  // namespace pliant
