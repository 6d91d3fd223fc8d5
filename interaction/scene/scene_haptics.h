// SceneHaptics (issue 6, item 6): the 1 kHz haptic thread beside a scene's physics loop.
//
// Design note. Physics runs at its own rate on the caller's thread (a step of the probe scene
// takes milliseconds); after every step the caller calls refresh(), which updates each
// instrument's HapticForceModel (F(x) = F0 - K (x - x0)) and its device track. The haptic thread
// ticks at limits.rate_hz and for each instrument sends the filtered model force at the device
// position.
// There is no device in `pliant run --realtime` or `pliant bench --haptic`: the instrument is
// driven by its pose source on the physics thread. The haptic thread's "device position" is that
// path extrapolated linearly in wall-clock time from the last two physics steps, at most one
// physics interval ahead (then held), i.e. where the instrument is heading at the speed it
// moved. At a refresh the device is exactly at x0, so the force sent there is F0 (up to the
// output filter). Torque is not modelled: the last physics torque is held.
// Every force sent is recorded (tick time, instrument, force, torque) for haptic_forces.csv.
//
// API:
//   SceneHaptics haptics(clock, runner, limits, expected_seconds);
//   haptics.start();
//   loop { runner.tick(); haptics.refresh(runner, clock.now()); }
//   haptics.stop();  haptics.records(); haptics.timing(); haptics.stats();
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "interaction/haptic_thread.h"
#include "interaction/scene/scene_runner.h"

namespace pliant {

/// One force sent to a device.
struct HapticRecord {
  double time = 0.0;            ///< s, clock time of the haptic tick
  size_t instrument = 0;        ///< index into the scene's instruments
  Vec3 force = Vec3::Zero();    ///< N, on the instrument (filtered)
  Vec3 torque = Vec3::Zero();   ///< N m, last physics torque about the instrument origin (held)
};

/// Where the device is between physics steps: the last two physics positions, extrapolated.
class DeviceTrack {
 public:
  /// A physics step left the instrument at x (m) with torque (N m) at clock time t (s).
  void push(double t, const Vec3& x, const Vec3& torque);
  /// Position (m) at clock time t: linear extrapolation from the last two pushes, at most one
  /// push interval ahead; before two pushes, the last one (or zero).
  Vec3 position_at(double t) const;
  /// Torque (N m) of the last push.
  Vec3 torque() const;

 private:
  mutable std::mutex mutex_;
  double t0_ = 0.0, t1_ = 0.0;
  Vec3 x0_ = Vec3::Zero(), x1_ = Vec3::Zero();
  Vec3 torque_ = Vec3::Zero();
  int pushes_ = 0;
};

class SceneHaptics {
 public:
  /// One channel per instrument of `runner` (its positions at construction seed the tracks), at
  /// `settings`' limits, ticked by `settings.threads` threads. `expected_seconds` preallocates
  /// records and timing samples. `realtime_priority`: ask for SCHED_FIFO on the haptic threads
  /// (reported in timing()).
  SceneHaptics(Clock& clock, const SceneRunner& runner, const HapticSettings& settings, double expected_seconds,
               bool realtime_priority);
  ~SceneHaptics();
  SceneHaptics(const SceneHaptics&) = delete;
  SceneHaptics& operator=(const SceneHaptics&) = delete;

  /// Physics thread, after every successful tick: refresh each instrument's model (simulated
  /// time, position, force) and its device track (clock time `now`).
  void refresh(const SceneRunner& runner, double now);
  void start();
  void stop();
  /// One synchronous tick at clock time t (deterministic use with a VirtualClock).
  void tick(double t);

  /// Every force sent so far (copy; safe while running).
  std::vector<HapticRecord> records() const;
  HapticTiming timing() const { return thread_->timing(); }
  HapticStats stats() const { return thread_->stats(); }
  const HapticForceModel& model(size_t instrument) const { return *models_[instrument]; }
  size_t instrument_count() const { return models_.size(); }

 private:
  Clock& clock_;
  std::vector<std::unique_ptr<HapticForceModel>> models_;
  std::vector<std::unique_ptr<DeviceTrack>> tracks_;
  mutable std::mutex records_mutex_;
  std::vector<HapticRecord> records_;
  std::unique_ptr<HapticThread> thread_;
};

/// haptic_forces.csv: "time,instrument,fx,fy,fz,tx,ty,tz" (s, N, N m), 17 significant digits.
std::string haptic_forces_csv(const std::vector<HapticRecord>& records, const std::vector<std::string>& names);

}  // namespace pliant
