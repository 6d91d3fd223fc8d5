#include "interaction/haptic_output_filter.h"

namespace pliant {

HapticSettings parse_haptic_settings(const JsonReader& j) {
  j.expect_keys({"enabled", "max_force", "max_force_rate", "rate_hz", "threads"});
  HapticSettings s;
  HapticLimits& l = s.limits;
  s.enabled = j.boolean_or("enabled", s.enabled);
  l.max_force = j.positive_number_or("max_force", l.max_force);
  l.rate_hz = j.positive_number_or("rate_hz", l.rate_hz);
  // A device loop runs at 1 kHz or a few kHz; beyond 10 kHz a tick's period nears a tick's cost.
  if (l.rate_hz > 10000.0) j.at("rate_hz").fail(InputErrorKind::bad_value, "expected at most 10000 Hz");
  const double default_rate = l.max_delta * 1000.0;  // N/s: 0.05 N per tick at 1 kHz
  l.max_delta = j.positive_number_or("max_force_rate", default_rate) / l.rate_hz;
  s.threads = j.integer_or("threads", s.threads);
  if (s.threads < 1 || s.threads > kMaxHapticThreads) {
    j.at("threads").fail(InputErrorKind::bad_value, "expected 1 to " + std::to_string(kMaxHapticThreads));
  }
  return s;
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
