// AccuracyGovernor (issue 6, item 5; DESIGN.md "time, budgets and haptics"): keeps each tick
// within its budget by lowering accuracy, and raises it again when there is headroom.
//
// Knobs: ContactSettings::binary_search_iterations and ModelAccuracy::max_solver_iterations,
// each between a floor (from the scene) and its starting value (the ceiling).
// Policy, with hysteresis so it does not oscillate:
//   - a tick slower than lower_above * budget for lower_after_ticks ticks in a row lowers one
//     notch: solver iterations first (x 3/4, at least -1, not below the floor; usually the larger
//     cost), then binary-search iterations (-1, not below the floor);
//   - a tick faster than raise_below * budget for raise_after_ticks ticks in a row raises one
//     notch, in the reverse order (binary search first, then solver x 4/3, at least +1);
//   - any other tick resets both counters. raise_below < lower_above leaves a dead band.
// In deterministic mode the loop does not consult the governor: accuracy stays fixed.
#pragma once

#include "interaction/json_reader.h"
#include "sim/world.h"

namespace pliant {

/// The accuracy the governor controls.
struct AccuracyLevel {
  int binary_search_iterations = 4;  ///< ContactSettings::binary_search_iterations
  int max_solver_iterations = 20;    ///< ModelAccuracy::max_solver_iterations
  bool operator==(const AccuracyLevel&) const = default;
};

/// Floors and thresholds; fractions are of the tick budget.
struct GovernorSettings {
  int min_binary_search_iterations = 1;  ///< floor
  int min_solver_iterations = 2;         ///< floor
  double lower_above = 0.9;              ///< lower when step time > lower_above * budget
  double raise_below = 0.5;              ///< raise when step time < raise_below * budget
  int lower_after_ticks = 1;             ///< consecutive slow ticks before lowering
  int raise_after_ticks = 50;            ///< consecutive fast ticks before raising
};

/// Reads {"min_binary_search_iterations", "min_solver_iterations", "lower_above", "raise_below",
/// "lower_after_ticks", "raise_after_ticks"} (all optional).
GovernorSettings parse_governor_settings(const JsonReader& j);

class AccuracyGovernor {
 public:
  /// `ceiling` is the starting accuracy (from the scene); floors come from `settings` and are
  /// limited to the ceiling.
  AccuracyGovernor(const AccuracyLevel& ceiling, const GovernorSettings& settings);

  /// Feeds one tick's step time (s) against its budget (s); returns true if the level changed.
  bool observe(double step_time, double budget);

  const AccuracyLevel& level() const { return level_; }
  const AccuracyLevel& ceiling() const { return ceiling_; }
  const AccuracyLevel& floor() const { return floor_; }
  long lowered_count() const { return lowered_; }
  long raised_count() const { return raised_; }

 private:
  bool lower();
  bool raise();

  AccuracyLevel ceiling_;
  AccuracyLevel floor_;
  AccuracyLevel level_;
  GovernorSettings settings_;
  int slow_ticks_ = 0;
  int fast_ticks_ = 0;
  long lowered_ = 0;
  long raised_ = 0;
};

/// The accuracy a world runs at now: contact binary-search iterations and the largest model
/// solver-iteration cap over deformable bodies (20 if there are none).
AccuracyLevel current_accuracy(const World& world);
/// Applies a level to a world: contact settings and every deformable body's model accuracy.
void apply_accuracy(World& world, const AccuracyLevel& level);

}  // namespace pliant
