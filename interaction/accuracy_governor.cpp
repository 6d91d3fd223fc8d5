#include "interaction/accuracy_governor.h"

#include <algorithm>

namespace pliant {

GovernorSettings parse_governor_settings(const JsonReader& j) {
  j.expect_keys({"min_binary_search_iterations", "min_solver_iterations", "lower_above", "raise_below",
                 "lower_after_ticks", "raise_after_ticks"});
  GovernorSettings s;
  s.min_binary_search_iterations = j.integer_or("min_binary_search_iterations", s.min_binary_search_iterations);
  if (s.min_binary_search_iterations < 0) {
    j.at("min_binary_search_iterations").fail(InputErrorKind::bad_value, "must be >= 0");
  }
  s.min_solver_iterations = j.integer_or("min_solver_iterations", s.min_solver_iterations);
  if (s.min_solver_iterations < 1) j.at("min_solver_iterations").fail(InputErrorKind::bad_value, "must be >= 1");
  s.lower_above = j.positive_number_or("lower_above", s.lower_above);
  s.raise_below = j.positive_number_or("raise_below", s.raise_below);
  if (!(s.raise_below < s.lower_above)) {
    j.fail(InputErrorKind::bad_value, "raise_below must be smaller than lower_above (hysteresis)");
  }
  s.lower_after_ticks = j.integer_or("lower_after_ticks", s.lower_after_ticks);
  if (s.lower_after_ticks < 1) j.at("lower_after_ticks").fail(InputErrorKind::bad_value, "must be >= 1");
  s.raise_after_ticks = j.integer_or("raise_after_ticks", s.raise_after_ticks);
  if (s.raise_after_ticks < 1) j.at("raise_after_ticks").fail(InputErrorKind::bad_value, "must be >= 1");
  return s;
}

AccuracyGovernor::AccuracyGovernor(const AccuracyLevel& ceiling, const GovernorSettings& settings)
    : ceiling_(ceiling), level_(ceiling), settings_(settings) {
  floor_.binary_search_iterations = std::min(settings.min_binary_search_iterations, ceiling.binary_search_iterations);
  floor_.max_solver_iterations = std::min(settings.min_solver_iterations, ceiling.max_solver_iterations);
}

bool AccuracyGovernor::observe(double step_time, double budget) {
  if (step_time > settings_.lower_above * budget) {
    fast_ticks_ = 0;
    if (++slow_ticks_ >= settings_.lower_after_ticks) {
      slow_ticks_ = 0;
      return lower();
    }
  } else if (step_time < settings_.raise_below * budget) {
    slow_ticks_ = 0;
    if (++fast_ticks_ >= settings_.raise_after_ticks) {
      fast_ticks_ = 0;
      return raise();
    }
  } else {
    slow_ticks_ = 0;
    fast_ticks_ = 0;
  }
  return false;
}

bool AccuracyGovernor::lower() {
  // Solver iterations first (usually the larger cost), then the contact binary search.
  int& solver = level_.max_solver_iterations;
  if (solver > floor_.max_solver_iterations) {
    solver = std::max(floor_.max_solver_iterations, std::min(solver - 1, solver * 3 / 4));
    ++lowered_;
    return true;
  }
  if (level_.binary_search_iterations > floor_.binary_search_iterations) {
    --level_.binary_search_iterations;
    ++lowered_;
    return true;
  }
  return false;
}

bool AccuracyGovernor::raise() {
  // Reverse order: the contact binary search first, then the solver.
  if (level_.binary_search_iterations < ceiling_.binary_search_iterations) {
    ++level_.binary_search_iterations;
    ++raised_;
    return true;
  }
  int& solver = level_.max_solver_iterations;
  if (solver < ceiling_.max_solver_iterations) {
    solver = std::min(ceiling_.max_solver_iterations, std::max(solver + 1, solver * 4 / 3));
    ++raised_;
    return true;
  }
  return false;
}

AccuracyLevel current_accuracy(const World& world) {
  AccuracyLevel level;
  level.binary_search_iterations = world.settings().contact.binary_search_iterations;
  int solver = 0;
  for (const Body* body : world.bodies()) {
    if (body != nullptr && body->model) solver = std::max(solver, body->model->accuracy().max_solver_iterations);
  }
  level.max_solver_iterations = solver > 0 ? solver : ModelAccuracy{}.max_solver_iterations;
  return level;
}

void apply_accuracy(World& world, const AccuracyLevel& level) {
  world.settings().contact.binary_search_iterations = level.binary_search_iterations;
  for (Body* body : world.bodies()) {
    if (body == nullptr || !body->model) continue;
    ModelAccuracy a = body->model->accuracy();
    a.max_solver_iterations = level.max_solver_iterations;
    body->model->set_accuracy(a);
  }
}

}  // namespace pliant
