// What a haptic device is allowed to receive (issue 6, item 6; DESIGN.md): the force is clamped
// to a maximum magnitude, rate-limited (at most max_delta per tick), and never NaN: a non-finite
// input sets the output to zero at once (removing force is the safe direction) and raises a fault
// that is counted and reported.
#pragma once

#include "interaction/json_reader.h"
#include "sim/math_types.h"

namespace pliant {

/// Limits of the force sent to a device.
struct HapticLimits {
  double max_force = 10.0;      ///< N, magnitude clamp
  double max_delta = 0.05;      ///< N per tick, rate limit on |F_k - F_{k-1}|
  double rate_hz = 1000.0;      ///< ticks per second of the haptic thread
};

/// The scene's optional "haptics" object (docs/scene-format.md): whether `pliant run --realtime`
/// runs the haptic thread, the limits of the force it sends, and how many threads tick it.
struct HapticSettings {
  bool enabled = true;  ///< false: no haptic thread (as --no-haptics)
  HapticLimits limits;  ///< max_delta = max_force_rate / rate_hz
  /// Threads that wake for every tick, each on its own CPU; the first awake sends it
  /// (haptic_thread.h): a tick is missed only if every one of them is stalled.
  int threads = 1;
};

/// Threads of a haptic loop: at most this many (a tick is microseconds; more wake-ups only cost).
inline constexpr int kMaxHapticThreads = 8;

/// Reads {"enabled", "max_force" (N), "max_force_rate" (N/s), "rate_hz", "threads" (1 to
/// kMaxHapticThreads)} (all optional); the rate limit per tick is max_force_rate / rate_hz.
/// Errors name the JSON path.
HapticSettings parse_haptic_settings(const JsonReader& j);

class HapticOutputFilter {
 public:
  explicit HapticOutputFilter(const HapticLimits& limits) : limits_(limits) {}

  /// Filters one tick's desired force (N): clamp magnitude, then rate-limit towards it. A
  /// non-finite input gives zero and a fault.
  Vec3 filter(const Vec3& desired);

  const Vec3& last() const { return last_; }
  /// True if the last input was non-finite.
  bool fault() const { return fault_; }
  /// Non-finite inputs so far.
  long fault_count() const { return faults_; }
  /// Ticks on which the clamp or the rate limit changed the force.
  long limited_count() const { return limited_; }
  void reset() { last_.setZero(); fault_ = false; }

 private:
  HapticLimits limits_;
  Vec3 last_ = Vec3::Zero();
  bool fault_ = false;
  long faults_ = 0;
  long limited_ = 0;
};

}  // namespace pliant
