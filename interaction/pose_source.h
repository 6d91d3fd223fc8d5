// Where instrument commands come from each tick (issue 6, item 4): a script, a recorded stream,
// or a live device stream. One source per instrument.
#pragma once

#include <string>

#include "interaction/instrument.h"

namespace pliant {

/// Gives the commanded pose of one instrument at a time, told the last measured force.
class PoseSource {
 public:
  virtual ~PoseSource() = default;
  /// Name of the instrument this source drives.
  virtual const std::string& instrument() const = 0;
  /// Command for simulated time t (s). Times must not decrease between calls. `fb` is the last
  /// measured state of the instrument (used by "press until force").
  virtual InstrumentCommand sample(double t, const InstrumentFeedback& fb) = 0;
  /// True when the source has nothing more to say after time t (script ended, file played out).
  virtual bool finished(double t) const = 0;
};

}  // namespace pliant
