// HapticThread (issue 6, item 6): the 1 kHz haptic loop on its own std::thread, driven by a Clock.
// Each tick, for every channel (one per instrument): read the device position, predict the force
// with that channel's HapticForceModel (refreshed by the physics thread after every step), filter
// it (clamp, rate limit, NaN -> zero + fault) and hand it to the output callback. tick() runs one
// tick synchronously, for deterministic tests.
//
// Several threads (set_thread_count): each is pinned to a CPU of its own and wakes for every slot;
// the first to take the slot's claim ticks it, the others find it taken and sleep to the next. A
// tick is then late only if every thread's CPU is stalled at once. Why: on a virtual machine the
// host wakes an idle virtual CPU, or takes a busy one away, for milliseconds at a time (session
// 20: cyclictest alone, nothing else running, saw 3-11 wake-ups >= 1 ms late in 10 s), and those
// stalls hit the two CPUs mostly at different times. The cost is each extra thread's wake-up and
// its spin before the slot (100 us per period) on the CPU it shares with the physics.
//
// Tick timing (measured only on the thread, through the clock): for slot k due at s_k = origin +
// k T, the tick starts at a_k (after the sleep) and ends at e_k.
//   - lateness     a_k - s_k;
//   - period jitter |(a_k - a_{k-1}) - T| over consecutive slots (pairs across skipped slots are
//     not periods; they are misses);
//   - deadline miss: a tick that ends after its slot is over (e_k > s_k + T), or a slot skipped
//     after a stall (the device got no new force for that period).
// Samples are kept (8 bytes each, three series); reserve_timing() preallocates so the loop does
// not allocate.
//
// API:
//   HapticForceModel model;                       // physics thread: model.update(t, x, f)
//   HapticThread haptics(clock, model, limits, [&]{ return device_position(); },
//                        [&](double t, const Vec3& f) { sink.write(t, "probe", f, Vec3::Zero()); });
//   haptics.start(); ... haptics.stop();
//   // several instruments: HapticThread(clock, {{&model_a, pos_a}, {&model_b, pos_b}}, limits,
//   //                                   [&](double t, size_t channel, const Vec3& f) { ... });
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "interaction/clock.h"
#include "interaction/haptic_force_model.h"
#include "interaction/haptic_output_filter.h"
#include "interaction/step_time_stats.h"

namespace pliant {

/// Counters of a haptic run.
struct HapticStats {
  long ticks = 0;
  long faults = 0;        ///< non-finite predictions replaced by zero (all channels)
  long limited = 0;       ///< channel ticks clamped or rate-limited
  long skipped_ticks = 0; ///< ticks dropped after a stall
};

/// Timing of the ticks run on the thread (s); see the note above for the definitions.
struct HapticTiming {
  double period = 0.0;          ///< s, 1 / rate_hz
  Percentiles lateness;         ///< s, tick start - scheduled slot time
  Percentiles period_jitter;    ///< s, |start-to-start interval - period|
  Percentiles tick_duration;    ///< s, start to end of a tick
  long late_ticks = 0;          ///< ticks that ended after their slot was over
  long skipped_ticks = 0;       ///< slots dropped after a stall
  long deadline_misses = 0;     ///< late_ticks + skipped_ticks
  bool realtime_priority = false;  ///< SCHED_FIFO was granted to every thread
  std::vector<long> ticks_by_thread;  ///< ticks each thread sent (one entry per thread)
};

class HapticThread {
 public:
  using PositionFunction = std::function<Vec3()>;
  using OutputFunction = std::function<void(double t, const Vec3& force)>;
  using ChannelOutputFunction = std::function<void(double t, size_t channel, const Vec3& force)>;

  /// One device (instrument): its model (not owned, must outlive the thread) and position source.
  struct Channel {
    const HapticForceModel* model = nullptr;
    PositionFunction position;
  };

  /// The clock must be safe to call from another thread (SteadyClock is; VirtualClock is not:
  /// use tick() with it). `model` must outlive the thread.
  HapticThread(Clock& clock, const HapticForceModel& model, const HapticLimits& limits,
               PositionFunction position, OutputFunction output);
  /// Several channels ticked together (same clock, limits per channel).
  HapticThread(Clock& clock, std::vector<Channel> channels, const HapticLimits& limits,
               ChannelOutputFunction output);
  ~HapticThread();
  HapticThread(const HapticThread&) = delete;
  HapticThread& operator=(const HapticThread&) = delete;

  /// Asks for SCHED_FIFO (priority 10) on the thread at start(); if refused, the thread runs at
  /// normal priority and timing().realtime_priority says so. Off by default.
  void set_realtime_priority(bool on) { realtime_priority_requested_ = on; }
  /// Threads that wake for every tick (before start(); 1 by default, at most kMaxHapticThreads):
  /// see the note above.
  void set_thread_count(int threads);
  /// Preallocates timing samples for this many ticks (the loop then does not allocate).
  void reserve_timing(long ticks);

  /// Starts the thread(s) (ticks at limits.rate_hz on the clock).
  void start();
  /// Stops and joins them (also done by the destructor).
  void stop();
  bool running() const { return running_.load(); }

  /// One tick at clock time t (s), all channels: returns the force sent on channel 0.
  Vec3 tick(double t);
  HapticStats stats() const;
  /// Timing of the ticks run by the thread so far (call after stop(), or accept a snapshot).
  HapticTiming timing() const;
  /// Last force sent on a channel (N).
  Vec3 last_force(size_t channel = 0) const;
  size_t channel_count() const { return channels_.size(); }

 private:
  /// Thread `index`: sleeps to each slot and claims it.
  void loop(int index);
  /// Ticks `slot` (due at `scheduled`) unless another thread has; records its timing.
  void claim_and_tick(int index, long slot, double scheduled);

  Clock& clock_;
  std::vector<Channel> channels_;
  HapticLimits limits_;
  ChannelOutputFunction output_;
  mutable std::mutex mutex_;  ///< guards filters_, stats_ and the timing samples
  std::vector<HapticOutputFilter> filters_;
  HapticStats stats_;
  StepTimeStats lateness_, period_jitter_, tick_duration_;
  long late_ticks_ = 0;
  std::vector<long> ticks_by_thread_;
  bool realtime_priority_requested_ = false;
  int thread_count_ = 1;
  std::atomic<int> realtime_priority_granted_{0};  ///< threads that got SCHED_FIFO
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_requested_{false};
  std::vector<std::thread> threads_;
  // The slot grid and the claim, shared by the threads.
  double origin_ = 0.0;            ///< clock time of slot 0
  std::mutex claim_mutex_;         ///< held while a slot is claimed and ticked
  long last_slot_ = -1;            ///< the last slot ticked (-1: none yet)
  double last_start_ = 0.0;        ///< when it started
};

}  // namespace pliant
