// Why a second thread gains little (issue #6/#8, docs/threads.md "Session 10"): the corotational
// evaluation pass alone with 1 and 2 threads, the cost of one fork-join with nothing to do, and the
// parallel regions of the probe scene's step (how many per step, how much work each, how long the
// second thread takes to join).
//
// Executors (range "executor"): 0 = none (the serial pass), 1 = the TbbTaskExecutor of `threads 2`,
// 2 = an OpenMP `parallel for` on 2 threads (GCC's libgomp: a plain fork-join whose wait is set by
// OMP_WAIT_POLICY=active|passive and GOMP_SPINCOUNT, to tell the worker's wake-up from the work).
// 3 = the parallel code paths run inline on the calling thread (their work without a second thread).
// A tracing wrapper (range "trace" 1) records per chunk which thread ran it and when; its counters:
//   caller_share  fraction of the chunks run by the calling thread (0.5 = an even split),
//   join_us       mean time from the call to the other thread's first chunk (its wake-up),
//   region_us     mean wall time of one for_each_chunk, work_us its chunks' summed run time,
//   nested, nested_us_per_step  regions inside another region (the model's loops inside World's
//                 per-body loop) per step, and their wall time per step (the step's parallel part).
// PLIANT_TRACE_REGIONS=1 makes ProbeStepRegions print one line per kind of region. On a loaded
// machine the second thread rarely gets a core; `chrt -f 10` (SCHED_FIFO, a few seconds) stands in
// for an idle one (docs/threads.md). Run from build/bench (the probe scene's path is relative):
//   chrt -f 10 ./threads_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <tuple>
#include <vector>

#include "interaction/scene/scene_runner.h"
#include "interaction/tbb_task_executor.h"
#include "sim/model/corotational_fem.h"
#include "sim/parallel/task_executor.h"
#include "tests/support/sagging_cantilever.h"

namespace pliant {
namespace {

using Clock = std::chrono::steady_clock;

double microseconds(Clock::duration d) { return std::chrono::duration<double, std::micro>(d).count(); }

/// A fork-join on OpenMP threads: the comparison for oneTBB's arena (one chunk per iteration of a
/// dynamic schedule, the caller is thread 0).
class OpenMpExecutor final : public TaskExecutor {
 public:
  explicit OpenMpExecutor(int threads) : threads_(threads) {}
  int thread_count() const override { return threads_; }
  void for_each_chunk(size_t count, size_t chunk, ChunkFunction body) override {
    const auto chunks = static_cast<long>((count + chunk - 1) / chunk);
#pragma omp parallel for num_threads(threads_) schedule(dynamic, 1)
    for (long k = 0; k < chunks; ++k) {
      const size_t begin = static_cast<size_t>(k) * chunk;
      body(begin, begin + chunk < count ? begin + chunk : count);
    }
  }

 private:
  int threads_;
};

/// Runs the chunks inline, ascending, but reports 2 threads, so the models take their parallel code
/// paths on one thread: the work of the parallel formulation without any second thread.
class InlineExecutor final : public TaskExecutor {
 public:
  int thread_count() const override { return 2; }
  void for_each_chunk(size_t count, size_t chunk, ChunkFunction body) override {
    for (size_t begin = 0; begin < count; begin += chunk) body(begin, begin + chunk < count ? begin + chunk : count);
  }
};

/// Wraps an executor and records, per chunk, whether the calling thread ran it and when.
class TracingExecutor final : public TaskExecutor {
 public:
  explicit TracingExecutor(TaskExecutor* inner) : inner_(inner) {}
  int thread_count() const override { return inner_->thread_count(); }
  void for_each_chunk(size_t count, size_t chunk, ChunkFunction body) override {
    // Regions nest (World::integrate's per-body chunks run the model's own regions): the per-chunk
    // records are local, the totals are updated under a lock, and a nested region is counted apart.
    const bool nested = active_.fetch_add(1) > 0;  // on whichever thread: the step has one top level
    const size_t chunks = (count + chunk - 1) / chunk;
    std::vector<Clock::time_point> starts(chunks);
    std::vector<Clock::duration> work(chunks);
    std::vector<char> on_caller(chunks);
    const auto caller = std::this_thread::get_id();
    const Clock::time_point t0 = Clock::now();
    auto traced = [&](size_t begin, size_t end) {
      const size_t k = begin / chunk;
      const Clock::time_point s = Clock::now();
      body(begin, end);
      work[k] = Clock::now() - s;
      starts[k] = s;
      on_caller[k] = std::this_thread::get_id() == caller ? 1 : 0;
    };
    inner_->for_each_chunk(count, chunk, ChunkFunction(traced));
    const Clock::time_point t1 = Clock::now();
    active_.fetch_sub(1);
    std::lock_guard<std::mutex> lock(mutex_);
    ++regions;
    nested_regions += nested ? 1 : 0;
    leaf_wall_us += nested ? microseconds(t1 - t0) : 0.0;
    region_us += microseconds(t1 - t0);
    Clock::time_point first_other = Clock::time_point::max();
    for (size_t k = 0; k < chunks; ++k) {
      total_chunks += 1;
      caller_chunks += on_caller[k];
      work_us += microseconds(work[k]);
      if (on_caller[k] == 0 && starts[k] < first_other) first_other = starts[k];
    }
    if (first_other != Clock::time_point::max()) {
      ++joined_regions;
      join_us += microseconds(first_other - t0);
    }
    RegionKind& kind = kinds_[{count, chunk, nested}];
    kind.regions += 1;
    kind.wall_us += microseconds(t1 - t0);
    for (size_t k = 0; k < chunks; ++k) {
      kind.work_us += microseconds(work[k]);
      kind.caller_chunks += on_caller[k];
    }
    kind.chunks += static_cast<long>(chunks);
    kind.joined += first_other != Clock::time_point::max() ? 1 : 0;
  }
  /// Prints one line per kind of region (count, chunk, nested): calls, mean wall and work, split.
  void print_kinds(long steps) const {
    for (const auto& [key, kind] : kinds_) {
      std::fprintf(stderr, "region count %zu chunk %zu %s: %.2f per step, wall %.1f us, work %.1f us, caller share %.2f, joined %.2f\n",
                   std::get<0>(key), std::get<1>(key), std::get<2>(key) ? "nested" : "outer",
                   static_cast<double>(kind.regions) / static_cast<double>(steps), kind.wall_us / static_cast<double>(kind.regions),
                   kind.work_us / static_cast<double>(kind.regions),
                   static_cast<double>(kind.caller_chunks) / static_cast<double>(kind.chunks),
                   static_cast<double>(kind.joined) / static_cast<double>(kind.regions));
    }
  }
  /// Puts the averages in the benchmark's counters.
  void report(benchmark::State& state) const {
    const double r = regions > 0 ? static_cast<double>(regions) : 1.0;
    state.counters["regions"] = static_cast<double>(regions) / static_cast<double>(state.iterations());
    state.counters["nested"] = static_cast<double>(nested_regions) / static_cast<double>(state.iterations());
    state.counters["nested_us_per_step"] = leaf_wall_us / static_cast<double>(state.iterations());
    state.counters["chunks_per_region"] = static_cast<double>(total_chunks) / r;
    state.counters["caller_share"] = total_chunks > 0 ? static_cast<double>(caller_chunks) / static_cast<double>(total_chunks) : 0.0;
    state.counters["region_us"] = region_us / r;
    state.counters["work_us"] = work_us / r;
    state.counters["joined_share"] = static_cast<double>(joined_regions) / r;
    state.counters["join_us"] = joined_regions > 0 ? join_us / static_cast<double>(joined_regions) : 0.0;
  }

  /// Forgets what was recorded so far.
  void reset() {
    regions = nested_regions = joined_regions = total_chunks = caller_chunks = 0;
    region_us = work_us = join_us = leaf_wall_us = 0.0;
    kinds_.clear();
  }

  long regions = 0, nested_regions = 0, joined_regions = 0, total_chunks = 0, caller_chunks = 0;
  double region_us = 0.0, work_us = 0.0, join_us = 0.0, leaf_wall_us = 0.0;

 private:
  struct RegionKind {
    long regions = 0, chunks = 0, caller_chunks = 0, joined = 0;
    double wall_us = 0.0, work_us = 0.0;
  };
  TaskExecutor* inner_;
  std::atomic<int> active_{0};
  std::mutex mutex_;
  std::map<std::tuple<size_t, size_t, bool>, RegionKind> kinds_;
};

std::unique_ptr<TaskExecutor> make_executor(int64_t kind) {
  if (kind == 1) return std::make_unique<TbbTaskExecutor>(2);
  if (kind == 2) return std::make_unique<OpenMpExecutor>(2);
  if (kind == 3) return std::make_unique<InlineExecutor>();
  return nullptr;
}

const char* executor_name(int64_t kind) {
  return kind == 1 ? "tbb 2" : kind == 2 ? "openmp 2" : kind == 3 ? "parallel code inline" : "serial";
}

/// The body of the pass: tests/support's sagging cantilever (E 1e5 Pa), either the size of the
/// probe's tissue (20 x 6 x 6 cells: 4,320 tets as the tissue's 12 x 12 x 5, 1,029 nodes) or
/// models_bench's beam (75 x 4 x 4 cells, 7,200 tets, 1,900 nodes).
SaggingCantilever make_cantilever(bool beam) {
  return beam ? SaggingCantilever(1.0, 0.08, 75, 4, 1e5) : SaggingCantilever(0.1, 0.03, 20, 6, 1e5);
}

// World's report stage after a step (the pass the probe's "report" time is): a full evaluation pass
// (rotations, forces, energies) at the step's result, from a restored snapshot each iteration.
// Args: mesh (0 probe-sized cantilever, 1 beam), executor, trace.
void BM_EvaluationPass(benchmark::State& state) {
  SaggingCantilever body = make_cantilever(state.range(0) == 1);
  CorotationalFem model(body.mesh, body.m, {});
  for (int s = 0; s < 20; ++s) body.step(model);
  auto executor = make_executor(state.range(1));
  TracingExecutor tracing(executor.get());
  TaskExecutor* used = executor && state.range(2) == 1 ? static_cast<TaskExecutor*>(&tracing) : executor.get();
  model.set_executor(used);
  const CorotationalFem snapshot = model;
  for (auto _ : state) {
    state.PauseTiming();
    model = snapshot;
    model.set_executor(used);
    state.ResumeTiming();
    benchmark::DoNotOptimize(model.elastic_energy(body.x));
  }
  if (used == &tracing) tracing.report(state);
  state.counters["tets"] = body.mesh->tet_count();
  state.SetLabel(std::string(state.range(0) == 1 ? "beam, " : "probe-sized, ") + executor_name(state.range(1)) +
                 (state.range(2) == 1 ? ", traced" : ""));
}
BENCHMARK(BM_EvaluationPass)
    ->ArgsProduct({{0, 1}, {0, 1, 2, 3}, {0}})
    ->Args({0, 1, 1})
    ->Args({0, 2, 1})
    ->Args({1, 1, 1})
    ->Args({1, 2, 1})
    ->Unit(benchmark::kMicrosecond);

// One fork-join with (almost) nothing to do: 34 chunks (the probe tissue's 4,320 tets in chunks of
// 128) that each write one number. The price of a parallel region, whatever its work.
void BM_EmptyRegion(benchmark::State& state) {
  auto executor = make_executor(state.range(0));
  std::vector<size_t> out(34);
  auto body = [&](size_t begin, size_t) { out[begin / 128] = begin; };
  for (auto _ : state) {
    parallel_for_chunks(executor.get(), 34 * 128, 128, body);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetLabel(executor_name(state.range(0)));
}
BENCHMARK(BM_EmptyRegion)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// The probe scene's step (assets/scenes/probe.json after 300 steps, before contact) on 2 threads
// through the tracing wrapper: parallel regions per step, their work and their wall time.
void BM_ProbeStepRegions(benchmark::State& state) {
  const auto file = std::filesystem::path(__FILE__).parent_path().parent_path() / "assets/scenes/probe.json";
  SceneRunner runner(load_scene(file.string()));
  auto executor = make_executor(state.range(0));
  TracingExecutor tracing(executor.get());
  runner.world().set_executor(&tracing);
  for (int i = 0; i < 300; ++i) runner.tick();
  tracing.reset();
  for (auto _ : state) runner.tick();
  tracing.report(state);
  if (std::getenv("PLIANT_TRACE_REGIONS") != nullptr) tracing.print_kinds(static_cast<long>(state.iterations()));
  state.SetLabel(executor_name(state.range(0)));
}
BENCHMARK(BM_ProbeStepRegions)->Arg(1)->Arg(2)->Arg(3)->Iterations(300)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace pliant
