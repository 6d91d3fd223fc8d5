// `pliant run SCENE`: runs a scene and writes DIR/summary.json, DIR/steps.csv,
// DIR/tool_forces.csv and DIR/frames/frame_NNNNNN.png (DESIGN.md command-line contract). With
// --realtime and instruments, also DIR/haptic_forces.csv from the 1 kHz haptic thread.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>

#include "interaction/haptic_thread.h"

namespace pliant {

struct RunOptions {
  std::string scene;
  std::string out = "out";
  std::optional<long> steps;
  std::optional<double> duration;       ///< s
  std::optional<std::string> contact;   ///< "surface" | "penalty" | "none"
  std::optional<int> binary_search_iterations;
  std::optional<bool> finishing_projection;
  bool frames = false;     ///< force frames on
  bool no_frames = false;  ///< force frames off
  bool vtu = false;        ///< write .vtu frames and a .pvd series
  bool realtime = false;   ///< run on the wall clock at the scene's loop rate
  bool haptics = true;     ///< with realtime and instruments: run the 1 kHz haptic thread beside physics
  bool realtime_priority = true;  ///< ask SCHED_FIFO for the haptic thread (used if granted)
  bool quiet = false;
  std::optional<int> threads;  ///< override the scene's "threads" (>= 1; docs/threads.md)
};

/// Runs the scene. Returns 0 on success, 1 on a runtime failure (a step that could not be
/// recovered), 130 when interrupted. Bad input throws InputError (exit code 2 in main).
int run_scene(const RunOptions& options, std::ostream& log);

/// summary.json's "haptics" object: tick count, period jitter / lateness / tick duration
/// percentiles (ms), late and skipped ticks, deadline misses, faults, limited ticks, priority.
nlohmann::json haptic_summary_json(const HapticTiming& timing, const HapticStats& stats);

}  // namespace pliant
