#include "interaction/haptic_output_filter.h"

namespace pliant {

HapticLimits parse_haptic_limits(const JsonReader& j) {
  j.expect_keys({"max_force", "max_delta", "rate_hz"});
  HapticLimits l;
  l.max_force = j.positive_number_or("max_force", l.max_force);
  l.max_delta = j.positive_number_or("max_delta", l.max_delta);
  l.rate_hz = j.positive_number_or("rate_hz", l.rate_hz);
  return l;
}

Vec3 HapticOutputFilter::filter(const Vec3& desired) {
  if (!desired.allFinite()) {
    // Removing force is the safe direction: zero at once, and say so.
    fault_ = true;
    ++faults_;
    last_.setZero();
    return last_;
  }
  fault_ = false;
  bool limited = false;
  Vec3 target = desired;
  const double magnitude = target.norm();
  if (magnitude > limits_.max_force) {
    target *= limits_.max_force / magnitude;
    limited = true;
  }
  const Vec3 delta = target - last_;
  const double step = delta.norm();
  if (step > limits_.max_delta) {
    target = last_ + delta * (limits_.max_delta / step);
    limited = true;
  }
  if (limited) ++limited_;
  last_ = target;
  return last_;
}

}  // namespace pliant
