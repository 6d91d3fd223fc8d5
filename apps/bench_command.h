// `pliant bench [--json FILE] [--csv FILE] [--steps N]`: one table of sizes and per-stage step
// times for every shipped scene (assets/scenes/*.json and assets/scenes/paper/*.json), timed with
// ClockStageProfiler on a SteadyClock. Stages that have nothing to do are shown apart: response
// time in steps without contacts, and each scene that uses friction again with friction off
// (docs/bench.md).
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace pliant {

struct BenchOptions {
  std::vector<std::string> scenes;     ///< scene files; empty: every shipped scene
  long steps = 100;                    ///< steps per scene (after warm_up_steps)
  long warm_up_steps = 5;              ///< untimed steps first (caches, solver warm start)
  std::optional<std::string> contact;  ///< "surface" | "penalty" | "none": override the scenes'
  std::string json;                    ///< write the table as JSON here (empty: do not)
  std::string csv;                     ///< write the table as CSV here (empty: do not)
  bool friction_variants = true;       ///< add a friction-off row for scenes with friction
};

/// Runs the benchmark and prints the table to `log`. Returns 0, or 1 if a scene's step failed
/// (its row is still written, marked). Bad input throws InputError.
int run_bench(const BenchOptions& options, std::ostream& log);

}  // namespace pliant
