#include "interaction/fixed_rate_loop.h"

#include <cmath>

namespace pliant {

LoopSettings parse_loop_settings(const JsonReader& j) {
  j.expect_keys({"rate_hz", "budget_s", "deterministic", "governor"});
  LoopSettings s;
  s.rate_hz = j.positive_number_or("rate_hz", s.rate_hz);
  if (s.rate_hz > 1e6) j.at("rate_hz").fail(InputErrorKind::bad_value, "expected at most 1e6 Hz");
  s.budget = j.positive_number_or("budget_s", 0.0);
  s.deterministic = j.boolean_or("deterministic", false);
  if (auto g = j.find("governor")) s.governor = parse_governor_settings(*g);
  return s;
}

FixedRateLoop::FixedRateLoop(Clock& clock, const LoopSettings& settings) : clock_(clock), settings_(settings) {}

void FixedRateLoop::set_governor(AccuracyGovernor* governor, AccuracyCallback apply) {
  governor_ = governor;
  apply_ = std::move(apply);
  if (governor_ != nullptr && apply_) apply_(governor_->level());
}

LoopStats FixedRateLoop::run(long max_ticks, const TickFunction& tick) {
  const double period = settings_.period();
  const double budget = settings_.budget_or_period();
  if (!started_) {
    origin_ = clock_.now();
    started_ = true;
  }
  for (long i = 0; i < max_ticks; ++i) {
    // Re-synchronise after a stall: jump to the latest slot that is already due, skipping the
    // ones in between instead of running them back to back.
    if (!settings_.deterministic) {
      const double now = clock_.now();
      const auto due = static_cast<long>(std::floor((now - origin_) / period));
      if (due > next_slot_) {
        counters_.skipped_ticks += due - next_slot_;
        ++counters_.resyncs;
        next_slot_ = due;
      }
    }
    const double scheduled = origin_ + static_cast<double>(next_slot_) * period;
    clock_.sleep_until(scheduled);

    TickInfo info;
    info.index = counters_.ticks;
    info.slot = next_slot_;
    info.sim_time = static_cast<double>(info.index) * period;
    info.scheduled_time = scheduled;
    info.period = period;
    const double start = clock_.now();
    const bool go_on = tick(info);
    const double step_time = clock_.now() - start;

    step_times_.add(step_time);
    if (step_time > budget) ++counters_.deadline_misses;
    if (!settings_.deterministic && governor_ != nullptr && governor_->observe(step_time, budget) && apply_) {
      apply_(governor_->level());
    }
    ++counters_.ticks;
    ++next_slot_;
    if (!go_on) break;
  }
  return stats();
}

LoopStats FixedRateLoop::stats() const {
  LoopStats s = counters_;
  s.step_time = step_times_.summary();
  if (governor_ != nullptr) {
    s.final_accuracy = governor_->level();
    s.accuracy_lowered = governor_->lowered_count();
    s.accuracy_raised = governor_->raised_count();
  }
  return s;
}

}  // namespace pliant
