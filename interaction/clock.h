// Clocks: everything that is timed goes through this interface, so tests run on a virtual clock
// and a run can be replayed deterministically (DESIGN.md: time, budgets and haptics).
#pragma once

#include <chrono>
#include <cstdint>

namespace pliant {

class Clock {
 public:
  virtual ~Clock() = default;
  /// Seconds since an arbitrary epoch, monotonic.
  virtual double now() const = 0;
  /// Waits until now() >= t (returns at once if already past).
  virtual void sleep_until(double t) = 0;
};

/// CLOCK_MONOTONIC (what std::chrono::steady_clock reads on Linux); sleeps for real:
/// clock_nanosleep to the absolute deadline minus `spin_us`, then spins to the deadline.
class SteadyClock final : public Clock {
 public:
  /// `spin_us`: microseconds spun (not slept) before each deadline; 0 sleeps all the way.
  explicit SteadyClock(double spin_us = 100.0);
  double now() const override;
  void sleep_until(double t) override;

 private:
  int64_t epoch_ns_;  ///< CLOCK_MONOTONIC at construction
  int64_t spin_ns_;
};

/// CPU time of the calling thread (CLOCK_THREAD_CPUTIME_ID): for profiling on a shared machine,
/// where wall time includes the time other processes ran. Each thread sees its own time, so use
/// it from one thread. sleep_until spins (CPU time only passes while running).
class ThreadCpuClock final : public Clock {
 public:
  double now() const override;
  void sleep_until(double t) override;
};

/// A clock that moves only when told: sleep_until jumps to t, advance adds time. Deterministic.
class VirtualClock final : public Clock {
 public:
  explicit VirtualClock(double start = 0.0) : t_(start) {}
  double now() const override { return t_; }
  void sleep_until(double t) override {
    if (t > t_) t_ = t;
  }
  /// Moves time forward by dt seconds (e.g. to model the cost of a step).
  void advance(double dt) { t_ += dt; }

 private:
  double t_;
};

}  // namespace pliant
