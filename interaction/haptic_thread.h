// HapticThread (issue 6, item 6): the 1 kHz haptic loop on its own std::thread, driven by a Clock.
// Each tick: read the device position, predict the force with the HapticForceModel (refreshed by
// the physics thread after every step), filter it (clamp, rate limit, NaN -> zero + fault) and
// hand it to the output callback. tick() runs one tick synchronously, for deterministic tests.
//
// API:
//   HapticForceModel model;                       // physics thread: model.update(t, x, f)
//   HapticThread haptics(clock, model, limits, [&]{ return device_position(); },
//                        [&](double t, const Vec3& f) { sink.write(t, "probe", f, Vec3::Zero()); });
//   haptics.start(); ... haptics.stop();
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <thread>

#include "interaction/clock.h"
#include "interaction/haptic_force_model.h"
#include "interaction/haptic_output_filter.h"

namespace pliant {

/// Counters of a haptic run.
struct HapticStats {
  long ticks = 0;
  long faults = 0;        ///< non-finite predictions replaced by zero
  long limited = 0;       ///< ticks clamped or rate-limited
  long skipped_ticks = 0; ///< ticks dropped after a stall
};

class HapticThread {
 public:
  using PositionFunction = std::function<Vec3()>;
  using OutputFunction = std::function<void(double t, const Vec3& force)>;

  /// The clock must be safe to call from another thread (SteadyClock is; VirtualClock is not:
  /// use tick() with it). `model` must outlive the thread.
  HapticThread(Clock& clock, const HapticForceModel& model, const HapticLimits& limits,
               PositionFunction position, OutputFunction output);
  ~HapticThread();
  HapticThread(const HapticThread&) = delete;
  HapticThread& operator=(const HapticThread&) = delete;

  /// Starts the thread (ticks at limits.rate_hz on the clock).
  void start();
  /// Stops and joins it (also done by the destructor).
  void stop();
  bool running() const { return running_.load(); }

  /// One tick at clock time t (s): returns the force sent.
  Vec3 tick(double t);
  HapticStats stats() const;
  /// Last force sent (N).
  Vec3 last_force() const;

 private:
  void loop();

  Clock& clock_;
  const HapticForceModel& model_;
  HapticLimits limits_;
  PositionFunction position_;
  OutputFunction output_;
  mutable std::mutex mutex_;  ///< guards filter_ and stats_
  HapticOutputFilter filter_;
  HapticStats stats_;
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_requested_{false};
  std::thread thread_;
};

}  // namespace pliant
