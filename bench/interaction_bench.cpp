// Interaction costs, against issue 6's targets (physics step p99 <= 1 ms on the ~1,000-vertex probe
// scene; 1 kHz haptic ticks with p99 jitter <= 0.1 ms and no misses):
//   - one haptic tick (predict + filter) and one model refresh (secant fit);
//   - one physics step of the shipped probe scene (assets/scenes/probe.json, 1,014-vertex tissue),
//     timed per step in thread CPU time (the machine is shared, so wall time includes other
//     processes) over the press and hold: 300 warm-up steps, then 1000 timed steps (t = 0.3-1.3 s,
//     the probe in contact throughout). Counters: step p50/p99/max (ms), the same as
//     `pliant bench --cpu-time assets/scenes/probe.json --steps 1000 --warm-up 300`. Variants: the
//     scene as shipped (held contact forces off) and with held_force_fraction 1 (what the Hertz and
//     grasper tests use, docs/interaction.md), and probe_coarse;
//   - the haptic thread beside the probe scene's physics for 2 s of wall time (SCHED_FIFO asked):
//     tick period jitter p50/p99/max, lateness p99 (ms) and deadline misses, as
//     `pliant bench --haptic` measures them over 10 s (5 repetitions here make 10 s).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "interaction/clock.h"
#include "interaction/haptic_thread.h"
#include "interaction/scene/scene_haptics.h"
#include "interaction/scene/scene_runner.h"
#include "interaction/step_time_stats.h"

namespace pliant {
namespace {

void BM_HapticTick(benchmark::State& state) {
  HapticForceModel model;
  for (int i = 0; i < 4; ++i) {
    const Vec3 x(1e-4 * (i == 1), 1e-4 * (i == 2), -1e-4 * i);
    model.update(i * 1e-3, x, Vec3(0.1, 0.2, 1.0) - 200.0 * x);
  }
  VirtualClock clock;
  Vec3 device(0, 0, -3e-4);
  HapticThread haptics(clock, model, HapticLimits{}, [&] { return device; }, [](double, const Vec3&) {});
  double t = 0.0;
  for (auto _ : state) benchmark::DoNotOptimize(haptics.tick(t += 1e-3));
}
BENCHMARK(BM_HapticTick);

void BM_HapticModelUpdate(benchmark::State& state) {
  HapticForceModel model;
  long i = 0;
  for (auto _ : state) {
    const Vec3 x(1e-5 * std::sin(0.1 * i), 1e-5 * std::cos(0.13 * i), -1e-4 - 1e-5 * std::sin(0.07 * i));
    model.update(1e-3 * i++, x, Vec3(0, 0, 1.0) - 200.0 * x);
  }
  benchmark::DoNotOptimize(model.snapshot());
}
BENCHMARK(BM_HapticModelUpdate);

const char* const kScenes[] = {"probe.json", "probe_coarse.json"};

// assets/scenes: $PLIANT_SCENES, else beside the source file, else two folders above the executable
// (build/bench/interaction_bench; __FILE__ may be relative under ccache's base directory).
std::filesystem::path scenes_folder() {
  if (const char* env = std::getenv("PLIANT_SCENES")) return env;
  const auto from_source = std::filesystem::path(__FILE__).parent_path().parent_path() / "assets/scenes";
  if (std::filesystem::exists(from_source / kScenes[0])) return from_source;
  return std::filesystem::read_symlink("/proc/self/exe").parent_path().parent_path().parent_path() / "assets/scenes";
}

Scene bench_scene(int which, double held_force_fraction) {
  Scene scene = load_scene((scenes_folder() / kScenes[which]).string());
  scene.world.contact.held_force_fraction = held_force_fraction;
  return scene;
}

// Arguments: scene (0 probe, 1 probe_coarse), held contact force fraction in percent.
void BM_ProbeSceneStep(benchmark::State& state) {
  const Scene scene = bench_scene(static_cast<int>(state.range(0)), 0.01 * static_cast<double>(state.range(1)));
  SceneRunner runner(scene);
  for (int i = 0; i < 300; ++i) {
    if (!runner.tick()) state.SkipWithError(runner.fault().c_str());
  }
  ThreadCpuClock cpu;
  StepTimeStats steps;
  steps.reserve(1000);
  long colliding = 0;
  for (auto _ : state) {
    const double start = cpu.now();
    if (!runner.tick()) state.SkipWithError(runner.fault().c_str());
    steps.add(cpu.now() - start);
    colliding += runner.report().colliding_vertices;
  }
  const Percentiles p = steps.summary();
  state.counters["step_p50_ms"] = p.p50 * 1e3;
  state.counters["step_p99_ms"] = p.p99 * 1e3;
  state.counters["step_max_ms"] = p.max * 1e3;
  state.counters["colliding_mean"] = static_cast<double>(colliding) / static_cast<double>(std::max(1L, p.count));
  state.counters["force_z_N"] = runner.readings().empty() ? 0.0 : runner.readings()[0].force.z();
}
BENCHMARK(BM_ProbeSceneStep)->Args({0, 0})->Args({0, 100})->Args({1, 0})->Iterations(1000)->Unit(benchmark::kMillisecond);

// Physics back to back on the probe scene for 2 s of wall time, the 1 kHz haptic thread beside it.
void BM_HapticJitterBesideProbeScene(benchmark::State& state) {
  const Scene scene = bench_scene(0, 0.0);
  SceneRunner runner(scene);
  for (int i = 0; i < 300; ++i) runner.tick();
  SteadyClock clock;
  const double seconds = 2.0;
  HapticTiming timing;
  long ticks = 0;
  for (auto _ : state) {
    SceneHaptics haptics(clock, runner, HapticSettings{}, seconds, /*realtime_priority=*/true);
    const double t_start = clock.now();
    haptics.start();
    while (clock.now() - t_start < seconds && runner.tick()) haptics.refresh(runner, clock.now());
    haptics.stop();
    timing = haptics.timing();
    ticks = haptics.stats().ticks;
  }
  state.counters["ticks"] = static_cast<double>(ticks);
  state.counters["jitter_p50_ms"] = timing.period_jitter.p50 * 1e3;
  state.counters["jitter_p99_ms"] = timing.period_jitter.p99 * 1e3;
  state.counters["jitter_max_ms"] = timing.period_jitter.max * 1e3;
  state.counters["late_p99_ms"] = timing.lateness.p99 * 1e3;
  state.counters["misses"] = static_cast<double>(timing.deadline_misses);
  state.counters["sched_fifo"] = timing.realtime_priority ? 1.0 : 0.0;
}
BENCHMARK(BM_HapticJitterBesideProbeScene)->Iterations(1)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace pliant
