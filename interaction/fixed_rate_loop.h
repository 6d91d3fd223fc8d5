// FixedRateLoop (issue 6, item 5): runs ticks at a fixed period through a Clock.
//
// Each tick: sleep until its scheduled time, call the tick function, measure how long it took
// (through the clock) against the budget, count a deadline miss if it took longer, and feed the
// governor (not in deterministic mode). After a stall (the clock is already past the next
// scheduled tick) the loop re-synchronises: the ticks whose time has passed are skipped (counted,
// not run in a burst) and the schedule resumes on the period grid.
// Deterministic mode: every tick runs (no skipping), the governor is not consulted (fixed
// accuracy), and with a VirtualClock the run is reproducible. Tick i's simulated time is always
// i * period; `scheduled_time` is the clock time it was due.
//
// API:
//   LoopSettings s = parse_loop_settings(JsonReader(scene["loop"], file, "/loop"));
//   FixedRateLoop loop(clock, s);
//   loop.set_governor(&governor, [&](const AccuracyLevel& a) { apply_accuracy(world, a); });
//   LoopStats stats = loop.run(n_ticks, [&](const TickInfo& tick) { ...; return true; });
//
// JSON "loop": {"rate_hz": 1000, "budget_s": 0.001 (default: the period), "deterministic": false,
//               "governor": {...see accuracy_governor.h}}
#pragma once

#include <functional>

#include "interaction/accuracy_governor.h"
#include "interaction/clock.h"
#include "interaction/json_reader.h"
#include "interaction/step_time_stats.h"

namespace pliant {

/// Rate, budget and governor floors of the loop.
struct LoopSettings {
  double rate_hz = 1000.0;     ///< ticks per second
  double budget = 0.0;         ///< s per tick; 0 = the period
  bool deterministic = false;  ///< fixed accuracy, no skipping
  GovernorSettings governor;
  double period() const { return 1.0 / rate_hz; }
  double budget_or_period() const { return budget > 0.0 ? budget : period(); }
};

/// Reads the scene's "loop" object (all keys optional); errors name the JSON path.
LoopSettings parse_loop_settings(const JsonReader& j);

/// What the tick function is told.
struct TickInfo {
  long index = 0;               ///< ticks run so far, not counting skipped ones (0-based)
  long slot = 0;                ///< position on the period grid (index + skipped ticks)
  double sim_time = 0.0;        ///< s, index * period
  double scheduled_time = 0.0;  ///< s, clock time the tick was due
  double period = 0.0;          ///< s
};

/// Counters and step-time statistics of a run.
struct LoopStats {
  long ticks = 0;            ///< ticks run
  long deadline_misses = 0;  ///< ticks whose step time exceeded the budget
  long skipped_ticks = 0;    ///< ticks dropped by re-synchronisation after stalls
  long resyncs = 0;          ///< stalls re-synchronised
  Percentiles step_time;     ///< s
  AccuracyLevel final_accuracy;
  long accuracy_lowered = 0;
  long accuracy_raised = 0;
};

class FixedRateLoop {
 public:
  /// Returns false to stop the loop.
  using TickFunction = std::function<bool(const TickInfo&)>;
  /// Called when the governor changes the accuracy.
  using AccuracyCallback = std::function<void(const AccuracyLevel&)>;

  FixedRateLoop(Clock& clock, const LoopSettings& settings);
  /// Attaches a governor (not owned); `apply` pushes its level into the simulation.
  void set_governor(AccuracyGovernor* governor, AccuracyCallback apply);

  /// Runs up to `max_ticks` ticks (or until the tick function returns false). Can be called again
  /// to continue; statistics accumulate.
  LoopStats run(long max_ticks, const TickFunction& tick);
  /// Statistics so far.
  LoopStats stats() const;
  /// Step times of every tick run (s).
  const StepTimeStats& step_times() const { return step_times_; }

 private:
  Clock& clock_;
  LoopSettings settings_;
  AccuracyGovernor* governor_ = nullptr;
  AccuracyCallback apply_;
  StepTimeStats step_times_;
  LoopStats counters_;
  bool started_ = false;
  double origin_ = 0.0;  ///< clock time of slot 0
  long next_slot_ = 0;
};

}  // namespace pliant
