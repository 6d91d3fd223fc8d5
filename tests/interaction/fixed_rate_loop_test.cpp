// Fixed-rate loop and accuracy governor on a virtual clock: ticks on the period grid, deadline
// misses counted, stalls re-synchronised without bursts, accuracy lowered under load and raised
// again when it goes, fixed in deterministic mode; step-time percentiles against a sort.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "interaction/fixed_rate_loop.h"

namespace pliant {
namespace {

using nlohmann::json;

TEST(StepTimeStats, PercentilesMatchNearestRankOfTheSortedSamples) {
  std::mt19937 rng(7);
  std::exponential_distribution<double> dist(1000.0);
  StepTimeStats stats;
  std::vector<double> all;
  for (int i = 0; i < 1001; ++i) {
    all.push_back(dist(rng));
    stats.add(all.back());
  }
  std::sort(all.begin(), all.end());
  const Percentiles p = stats.summary();
  EXPECT_EQ(p.count, 1001);
  EXPECT_EQ(p.p50, all[500]);   // ceil(0.5 * 1001) = 501st
  EXPECT_EQ(p.p99, all[990]);   // ceil(0.99 * 1001) = 991st
  EXPECT_EQ(p.max, all.back());
  EXPECT_EQ(StepTimeStats().summary().max, 0.0);
}

TEST(FixedRateLoop, TicksRunOnThePeriodGrid) {
  VirtualClock clock(5.0);
  LoopSettings s;
  s.rate_hz = 1000.0;
  FixedRateLoop loop(clock, s);
  std::vector<TickInfo> seen;
  const LoopStats stats = loop.run(100, [&](const TickInfo& tick) {
    seen.push_back(tick);
    clock.advance(2e-4);  // the step costs 0.2 ms
    return true;
  });
  ASSERT_EQ(seen.size(), 100u);
  for (size_t i = 0; i < seen.size(); ++i) {
    EXPECT_NEAR(seen[i].scheduled_time, 5.0 + 1e-3 * static_cast<double>(i), 1e-12);
    EXPECT_DOUBLE_EQ(seen[i].sim_time, 1e-3 * static_cast<double>(i));
  }
  EXPECT_EQ(stats.ticks, 100);
  EXPECT_EQ(stats.deadline_misses, 0);
  EXPECT_EQ(stats.skipped_ticks, 0);
  EXPECT_NEAR(stats.step_time.p50, 2e-4, 1e-12);
  EXPECT_NEAR(stats.step_time.max, 2e-4, 1e-12);
  // The tick function can stop the loop.
  long n = 0;
  loop.run(100, [&](const TickInfo&) { return ++n < 3; });
  EXPECT_EQ(n, 3);
}

TEST(FixedRateLoop, StallIsResynchronisedBySkippingNotBursting) {
  VirtualClock clock;
  LoopSettings s;
  s.rate_hz = 1000.0;
  FixedRateLoop loop(clock, s);
  std::vector<double> starts;
  const LoopStats stats = loop.run(20, [&](const TickInfo& tick) {
    starts.push_back(clock.now());
    clock.advance(tick.index == 5 ? 5.5e-3 : 1e-4);  // one 5.5 ms stall at tick 5
    return true;
  });
  EXPECT_EQ(stats.deadline_misses, 1);
  EXPECT_EQ(stats.resyncs, 1);
  EXPECT_EQ(stats.skipped_ticks, 4);  // slots 6..9 dropped; slot 10 (due at 10 ms) runs at 10.5 ms
  EXPECT_NEAR(starts[6], 10.5e-3, 1e-12);
  // No burst: after the late tick, the loop is back on the grid.
  EXPECT_NEAR(starts[7], 11e-3, 1e-12);
  EXPECT_NEAR(starts[8], 12e-3, 1e-12);

  // Deterministic mode runs every slot, back to back after the stall.
  VirtualClock clock2;
  s.deterministic = true;
  FixedRateLoop exact(clock2, s);
  const LoopStats stats2 = exact.run(20, [&](const TickInfo& tick) {
    clock2.advance(tick.index == 5 ? 5.5e-3 : 1e-4);
    return true;
  });
  EXPECT_EQ(stats2.skipped_ticks, 0);
  EXPECT_EQ(stats2.ticks, 20);
}

// A tick whose cost grows with the accuracy: 0.1 ms + 0.05 ms per solver iteration + 0.05 ms
// per binary-search iteration, times a load factor.
struct FakeSimulation {
  VirtualClock& clock;
  AccuracyLevel level;
  double load = 1.0;
  double cost() const {
    return load * (1e-4 + 5e-5 * level.max_solver_iterations + 5e-5 * level.binary_search_iterations);
  }
};

TEST(AccuracyGovernor, LowersUnderLoadCountsMissesAndRecovers) {
  VirtualClock clock;
  LoopSettings s;
  s.rate_hz = 1000.0;
  s.budget = 1e-3;
  AccuracyGovernor governor(AccuracyLevel{4, 20}, s.governor);
  FakeSimulation sim{clock, {}, 1.0};
  FixedRateLoop loop(clock, s);
  loop.set_governor(&governor, [&](const AccuracyLevel& a) { sim.level = a; });
  EXPECT_EQ(sim.level, (AccuracyLevel{4, 20}));
  auto tick = [&](const TickInfo&) {
    clock.advance(sim.cost());
    return true;
  };

  // Load: 1.3 ms at full accuracy. Solver iterations go 20 -> 15 -> 11 (0.85 ms < 0.9 budget).
  LoopStats stats = loop.run(500, tick);
  EXPECT_EQ(sim.level, (AccuracyLevel{4, 11}));
  EXPECT_EQ(stats.deadline_misses, 2);  // the ticks at 20 (1.3 ms) and 15 (1.05 ms) iterations
  EXPECT_EQ(stats.accuracy_lowered, 2);
  EXPECT_EQ(stats.accuracy_raised, 0);  // 0.85 ms is in the dead band: no oscillation

  // Load gone (x 0.3): after 50 fast ticks each, 11 -> 14 -> 18 -> 20 (the ceiling), then stays.
  sim.load = 0.3;
  stats = loop.run(500, tick);
  EXPECT_EQ(sim.level, (AccuracyLevel{4, 20}));
  EXPECT_EQ(stats.accuracy_raised, 3);
  EXPECT_EQ(stats.deadline_misses, 2);

  // Heavy load (x 4): down to the solver floor, then the binary search, never below the floors.
  sim.load = 4.0;
  stats = loop.run(500, tick);
  EXPECT_EQ(sim.level.max_solver_iterations, governor.floor().max_solver_iterations);
  EXPECT_EQ(sim.level.binary_search_iterations, governor.floor().binary_search_iterations);
  EXPECT_GT(stats.deadline_misses, 2);
  EXPECT_GT(stats.skipped_ticks, 0);  // 1.2 ms ticks at the floor cannot keep a 1 ms period
  EXPECT_EQ(stats.final_accuracy, sim.level);
}

TEST(AccuracyGovernor, DeterministicModeKeepsAccuracyFixedAndRepeats) {
  auto run = [](std::vector<double>& times) {
    VirtualClock clock;
    LoopSettings s;
    s.deterministic = true;
    AccuracyGovernor governor(AccuracyLevel{4, 20}, s.governor);
    FakeSimulation sim{clock, {4, 20}, 1.0};
    FixedRateLoop loop(clock, s);
    loop.set_governor(&governor, [&](const AccuracyLevel& a) { sim.level = a; });
    const LoopStats stats = loop.run(300, [&](const TickInfo& tick) {
      times.push_back(clock.now());
      clock.advance(sim.cost() * (1.0 + 0.5 * (tick.index % 7 == 0)));
      return true;
    });
    EXPECT_EQ(sim.level, (AccuracyLevel{4, 20}));
    EXPECT_EQ(stats.accuracy_lowered, 0);
    EXPECT_EQ(stats.deadline_misses, 300);
    return stats;
  };
  std::vector<double> a, b;
  const LoopStats sa = run(a), sb = run(b);
  EXPECT_EQ(a, b);
  EXPECT_EQ(sa.step_time.p99, sb.step_time.p99);
}

TEST(AccuracyGovernor, ApplyAccuracySetsTheWorldsContactIterations) {
  World world;
  apply_accuracy(world, AccuracyLevel{2, 7});
  EXPECT_EQ(world.settings().contact.binary_search_iterations, 2);
  EXPECT_EQ(current_accuracy(world).binary_search_iterations, 2);
}

TEST(LoopSettings, ParsesAndNamesBadValues) {
  const json j = json::parse(R"({"rate_hz": 500, "budget_s": 0.0015, "deterministic": true,
                                 "governor": {"min_solver_iterations": 4, "raise_after_ticks": 10}})");
  const LoopSettings s = parse_loop_settings(JsonReader(j, "scene.json", "/loop"));
  EXPECT_DOUBLE_EQ(s.period(), 2e-3);
  EXPECT_DOUBLE_EQ(s.budget_or_period(), 1.5e-3);
  EXPECT_TRUE(s.deterministic);
  EXPECT_EQ(s.governor.min_solver_iterations, 4);
  EXPECT_EQ(s.governor.raise_after_ticks, 10);
  auto error = [](const char* text) {
    const json bad = json::parse(text);
    try {
      parse_loop_settings(JsonReader(bad, "scene.json", "/loop"));
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error(R"({"rate_hz": -1})").find("/loop/rate_hz"), std::string::npos);
  EXPECT_NE(error(R"({"rate": 1})").find("/loop/rate"), std::string::npos);
  EXPECT_NE(error(R"({"governor": {"raise_below": 0.95}})").find("/loop/governor"), std::string::npos);
  EXPECT_NE(error(R"({"governor": {"min_solver_iterations": 0}})").find("/loop/governor/min_solver_iterations"),
            std::string::npos);
}

}  // namespace
}  // namespace pliant
