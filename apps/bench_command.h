// `pliant bench [--json FILE] [--csv FILE] [--steps N]`: one table of sizes and per-stage step
// times for every shipped scene (assets/scenes/*.json and assets/scenes/paper/*.json), timed with
// ClockStageProfiler on a SteadyClock. Stages that have nothing to do are shown apart: response
// time in steps without contacts, and each scene that uses friction again with friction off
// (docs/bench.md). `--window K`: the same per-stage profile per window of K steps, against
// simulated time, with the number of awake bodies (issue 8 item 6). `--haptic`: the haptic thread beside the physics loop (run_haptic_bench).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "interaction/haptic_output_filter.h"
#include "interaction/step_time_stats.h"

namespace pliant {

struct BenchOptions {
  std::vector<std::string> scenes;     ///< scene files; empty: every shipped scene
  long steps = 100;                    ///< steps per scene (after warm_up_steps)
  long warm_up_steps = 5;              ///< untimed steps first (caches, solver warm start)
  std::optional<std::string> contact;  ///< "surface" | "penalty" | "none": override the scenes'
  std::string json;                    ///< write the table as JSON here (empty: do not)
  std::string csv;                     ///< write the table as CSV here (empty: do not)
  bool friction_variants = true;       ///< add a friction-off row for scenes with friction
  bool cpu_time = false;               ///< time stages in thread CPU time, not wall time (shared machine)
  /// Steps per window of the over-time profile (0: none): a sub-row per window with the stage
  /// p50s, awake bodies and colliding vertices, so a settling scene shows its cost falling.
  long window_steps = 0;
  bool haptic = false;                 ///< the haptic benchmark instead (run_haptic_bench)
  double seconds = 10.0;               ///< haptic benchmark: wall-clock seconds per scene
  bool realtime_priority = true;       ///< haptic benchmark: ask SCHED_FIFO for the haptic thread
  std::optional<int> haptic_threads;   ///< haptic benchmark: override the scenes' "haptics" "threads"
  std::optional<int> threads;          ///< override the scenes' "threads" (>= 1; docs/threads.md)
  /// Under `valgrind --tool=callgrind --instr-atstart=no`: instrument the timed steps only
  /// (apps/callgrind_window.h), so a piled scene's steps get a firm instruction count.
  bool callgrind_timed = false;
};

/// Runs the benchmark and prints the table to `log`. Returns 0, or 1 if a scene's step failed
/// (its row is still written, marked). Bad input throws InputError.
int run_bench(const BenchOptions& options, std::ostream& log);

/// `pliant bench --haptic [--seconds S] [scenes]`: for each scene with instruments (default
/// assets/scenes/probe.json and probe_5k.json), physics steps back to back at the scene's fixed
/// accuracy for S wall-clock seconds while the 1 kHz haptic thread (SceneHaptics) runs beside it.
/// Reports physics step p50/p99 and steps over the loop budget, haptic period jitter, lateness
/// and deadline misses (haptic_thread.h defines them). Returns 0, or 1 if a step failed.
int run_haptic_bench(const BenchOptions& options, std::ostream& log);

/// {"p50", "p99", "max"} in ms of a set of durations (s), or null without samples.
nlohmann::json percentiles_ms_json(const StepTimeStats& stats);

}  // namespace pliant
