#include "apps/run_command.h"

#include <atomic>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "apps/frame_output.h"
#include "interaction/accuracy_governor.h"
#include "interaction/clock.h"
#include "interaction/fixed_rate_loop.h"
#include "interaction/scene/scene_haptics.h"
#include "interaction/scene/scene_runner.h"
#include "interaction/step_time_stats.h"
#include "sim/input_error.h"
#include "sim/io/atomic_file.h"

namespace pliant {
namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_signal(int) { g_interrupted.store(true); }

// A CSV file written under "<name>.partial" and renamed when closed, so an output is never seen
// half-written.
class CsvOutput {
 public:
  CsvOutput(const std::filesystem::path& path, const std::string& header) : path_(path), partial_(path) {
    partial_ += ".partial";
    out_.open(partial_, std::ios::trunc);
    if (!out_) throw InputError(InputErrorKind::io, partial_.string(), "cannot write");
    out_ << std::setprecision(9) << header << '\n';
  }
  std::ofstream& stream() { return out_; }
  void close() {
    if (!out_.is_open()) return;
    out_.close();
    std::filesystem::rename(partial_, path_);
  }
  ~CsvOutput() { close(); }

 private:
  std::filesystem::path path_, partial_;
  std::ofstream out_;
};

nlohmann::json percentiles_ms(const StepTimeStats& stats) {
  if (stats.count() == 0) return nullptr;
  const Percentiles p = stats.summary();
  return {{"p50", p.p50 * 1e3}, {"p99", p.p99 * 1e3}, {"max", p.max * 1e3}};
}

nlohmann::json vec_json(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

nlohmann::json ms_json(const Percentiles& p) {
  if (p.count == 0) return nullptr;
  return {{"p50", p.p50 * 1e3}, {"p99", p.p99 * 1e3}, {"max", p.max * 1e3}};
}

}  // namespace

nlohmann::json haptic_summary_json(const HapticTiming& timing, const HapticStats& stats) {
  return {{"rate_hz", timing.period > 0.0 ? 1.0 / timing.period : 0.0},
          {"ticks", stats.ticks},
          {"period_jitter_ms", ms_json(timing.period_jitter)},
          {"lateness_ms", ms_json(timing.lateness)},
          {"tick_duration_ms", ms_json(timing.tick_duration)},
          {"late_ticks", timing.late_ticks},
          {"skipped_ticks", timing.skipped_ticks},
          {"deadline_misses", timing.deadline_misses},
          {"faults", stats.faults},
          {"limited_ticks", stats.limited},
          {"realtime_priority", timing.realtime_priority},
          {"ticks_by_thread", timing.ticks_by_thread}};
}

int run_scene(const RunOptions& options, std::ostream& log) {
  Scene scene = load_scene(options.scene);
  if (options.contact) scene.world.contact.method = contact_method_from_string(*options.contact);
  if (options.threads) scene.threads = *options.threads;
  if (options.binary_search_iterations) scene.world.contact.binary_search_iterations = *options.binary_search_iterations;
  if (options.finishing_projection) scene.world.contact.finishing_projection = *options.finishing_projection;
  if (options.frames) scene.output.frames = true;
  if (options.no_frames) scene.output.frames = false;
  if (options.vtu) scene.output.vtu = true;
  const double dt = scene.time_step;
  long steps = static_cast<long>(std::llround(scene.duration / dt));
  if (options.duration) steps = static_cast<long>(std::llround(*options.duration / dt));
  if (options.steps) steps = *options.steps;
  if (steps < 1) throw InputError(InputErrorKind::bad_value, "--steps/--duration", "must give at least one step");

  SceneRunner runner(scene);
  World& world = runner.world();

  const std::filesystem::path out = options.out;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw InputError(InputErrorKind::io, out.string(), "cannot create output folder: " + ec.message());

  CsvOutput steps_csv(out / "steps.csv",
                      "step,time,dt,colliding_vertices,max_penetration_before,max_residual_overlap,"
                      "pressure_imbalance_mean,pressure_imbalance_max,total_contact_force,"
                      "binary_search_iterations,solver_iterations,substeps,kinetic_energy,elastic_energy,"
                      "gravitational_energy,work_by_kinematic,total_energy,step_ms,integrate_ms,detect_ms,"
                      "depth_ms,respond_ms,report_ms,all_finite");
  CsvOutput forces_csv(out / "tool_forces.csv", "time,instrument,fx,fy,fz,tx,ty,tz,x,y,z");
  FrameOutput frames(scene, out, options.quiet ? nullptr : &log);

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  g_interrupted.store(false);

  SteadyClock clock;
  ClockStageProfiler profiler(clock);
  StepTimeStats step_times, response_times;
  double max_penetration = 0.0, max_residual = 0.0;
  int colliding_max = 0;
  bool all_finite = true;
  long steps_done = 0;
  const long frame_every = std::max(1L, static_cast<long>(std::llround(1.0 / (scene.output.frame_rate * dt))));
  if (frames.enabled()) frames.write(world, runner.report(), 0);

  // One tick: step, record, maybe a frame. Returns false to stop.
  auto tick = [&]() -> bool {
    if (g_interrupted.load()) return false;
    if (!runner.tick(&profiler)) return false;
    const StepReport& r = runner.report();
    ++steps_done;
    step_times.add(profiler.total());
    response_times.add(profiler.seconds(StepStage::respond));
    max_penetration = std::max(max_penetration, r.max_penetration_before);
    max_residual = std::max(max_residual, r.max_residual_overlap);
    colliding_max = std::max(colliding_max, r.colliding_vertices);
    all_finite = all_finite && r.all_finite;
    auto& s = steps_csv.stream();
    s << r.step_index << ',' << r.time << ',' << r.dt << ',' << r.colliding_vertices << ','
      << r.max_penetration_before << ',' << r.max_residual_overlap << ',' << r.pressure_imbalance_mean << ','
      << r.pressure_imbalance_max << ',' << r.total_contact_force << ',' << r.binary_search_iterations << ','
      << r.solver_iterations_max << ',' << r.substeps_max << ',' << r.energy.kinetic << ',' << r.energy.elastic
      << ',' << r.energy.gravitational << ',' << r.energy.work_by_kinematic << ',' << r.energy.total() << ','
      << profiler.total() * 1e3 << ',' << profiler.seconds(StepStage::integrate) * 1e3 << ','
      << profiler.seconds(StepStage::detect) * 1e3 << ',' << profiler.seconds(StepStage::depth) * 1e3 << ','
      << profiler.seconds(StepStage::respond) * 1e3 << ',' << profiler.seconds(StepStage::report) * 1e3 << ','
      << (r.all_finite ? 1 : 0) << '\n';
    const auto& instruments = runner.instance().instruments;
    for (size_t i = 0; i < instruments.size(); ++i) {
      const auto& reading = runner.readings()[i];
      forces_csv.stream() << r.time << ',' << instruments[i].name() << ',' << reading.force.x() << ','
                          << reading.force.y() << ',' << reading.force.z() << ',' << reading.torque.x() << ','
                          << reading.torque.y() << ',' << reading.torque.z() << ',' << reading.position.x() << ','
                          << reading.position.y() << ',' << reading.position.z() << '\n';
    }
    if (frames.enabled() && steps_done % frame_every == 0) frames.write(world, r, steps_done / frame_every);
    return true;
  };

  long deadline_misses = 0;
  nlohmann::json loop_json = nullptr;
  nlohmann::json haptic_json = nullptr;
  if (options.realtime) {
    LoopSettings loop_settings = scene.loop;
    FixedRateLoop loop(clock, loop_settings);
    AccuracyGovernor governor(current_accuracy(world), loop_settings.governor);
    if (!loop_settings.deterministic) {
      loop.set_governor(&governor, [&](const AccuracyLevel& level) { apply_accuracy(world, level); });
    }
    // With instruments, the haptic thread runs beside the physics loop (scene_haptics.h); each
    // physics step refreshes its models.
    std::unique_ptr<SceneHaptics> haptics;
    if (options.haptics && scene.haptics.enabled && !runner.instance().instruments.empty()) {
      const double expected = static_cast<double>(steps) * std::max(dt, loop_settings.period()) * 4.0 + 1.0;
      haptics = std::make_unique<SceneHaptics>(clock, runner, scene.haptics, expected, options.realtime_priority);
      haptics->start();
    }
    // ticks.csv: one row per tick run, for load tests and replays of a session's timing
    // (scripts/load_test.sh): the slot on the period grid, when it was due by the loop's clock,
    // its step time, whether it missed the budget, and the accuracy it ran at.
    CsvOutput ticks_csv(out / "ticks.csv",
                        "slot,scheduled_s,step_ms,deadline_miss,binary_search_iterations,solver_iterations");
    const double budget = loop_settings.budget_or_period();
    const LoopStats stats = loop.run(steps, [&](const TickInfo& info) {
      const AccuracyLevel level = current_accuracy(world);
      const double start = clock.now();
      const bool go_on = tick();
      if (go_on && haptics) haptics->refresh(runner, clock.now());
      const double took = clock.now() - start;
      ticks_csv.stream() << info.slot << ',' << info.scheduled_time << ',' << took * 1e3 << ','
                         << (took > budget ? 1 : 0) << ',' << level.binary_search_iterations << ','
                         << level.max_solver_iterations << '\n';
      return go_on;
    });
    ticks_csv.close();
    if (haptics) {
      haptics->stop();
      std::vector<std::string> names;
      for (const Instrument& i : runner.instance().instruments) names.push_back(i.name());
      const std::vector<HapticRecord> records = haptics->records();
      write_file_atomically((out / "haptic_forces.csv").string(), haptic_forces_csv(records, names));
      haptic_json = haptic_summary_json(haptics->timing(), haptics->stats());
    }
    deadline_misses = stats.deadline_misses;
    loop_json = {{"rate_hz", loop_settings.rate_hz},
                 {"budget_ms", loop_settings.budget_or_period() * 1e3},
                 {"ticks", stats.ticks},
                 {"skipped_ticks", stats.skipped_ticks},
                 {"deadline_misses", stats.deadline_misses},
                 {"governor_lowered", governor.lowered_count()},
                 {"governor_raised", governor.raised_count()}};
  } else {
    for (long i = 0; i < steps; ++i) {
      if (!tick()) break;
    }
  }
  const bool interrupted = g_interrupted.load();
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  steps_csv.close();
  forces_csv.close();
  frames.finish();

  // summary.json: the DESIGN.md contract.
  long vertices = 0, tets = 0, triangles = 0;
  for (const Body* body : world.bodies()) {
    if (body == nullptr) continue;
    vertices += body->mesh->vertex_count();
    tets += body->mesh->tet_count();
    triangles += body->mesh->surface_triangle_count();
  }
  nlohmann::json tool_forces = nlohmann::json::object();
  const auto& instruments = runner.instance().instruments;
  for (size_t i = 0; i < instruments.size(); ++i) {
    const auto& reading = runner.readings()[i];
    tool_forces[instruments[i].name()] = {{"force", vec_json(reading.force)},
                                          {"magnitude", reading.force.norm()},
                                          {"torque", vec_json(reading.torque)}};
  }
  const StepReport& last = runner.report();
  nlohmann::json summary = {
      {"scene", scene.file},
      {"name", scene.name},
      {"steps", steps_done},
      {"steps_requested", steps},
      {"dt", dt},
      {"simulated_time", world.time()},
      {"contact_method", to_string(scene.world.contact.method)},
      {"binary_search_iterations", scene.world.contact.binary_search_iterations},
      {"finishing_projection", scene.world.contact.finishing_projection},
      {"vertices", vertices},
      {"tets", tets},
      {"surface_triangles", triangles},
      {"step_ms", percentiles_ms(step_times)},
      {"response_ms", percentiles_ms(response_times)},
      {"max_penetration_before", max_penetration},
      {"max_residual_overlap", max_residual},
      {"colliding_vertices_max", colliding_max},
      {"final_tool_force", tool_forces},
      {"deadline_misses", options.realtime ? nlohmann::json(deadline_misses) : nlohmann::json(nullptr)},
      {"realtime_loop", loop_json},
      {"haptics", haptic_json},
      {"final_energy",
       {{"kinetic", last.energy.kinetic},
        {"elastic", last.energy.elastic},
        {"gravitational", last.energy.gravitational},
        {"work_by_kinematic", last.energy.work_by_kinematic}}},
      {"retried_steps", runner.retried_steps()},
      {"frames_written", frames.written()},
      {"frames_dropped", frames.dropped()},
      {"all_finite", all_finite && runner.fault().empty()},
      {"interrupted", interrupted},
      {"fault", runner.fault().empty() ? nlohmann::json(nullptr) : nlohmann::json(runner.fault())},
  };
  write_file_atomically((out / "summary.json").string(), summary.dump(2) + "\n");

  if (!options.quiet) {
    std::ostringstream line;
    line << std::setprecision(4) << "pliant run: " << scene.name << ": " << steps_done << " steps of " << dt * 1e3
         << " ms (" << to_string(scene.world.contact.method) << " contact), step p50 "
         << (step_times.count() ? step_times.summary().p50 * 1e3 : 0.0) << " ms, max penetration "
         << max_penetration * 1e3 << " mm, residual overlap " << max_residual * 1e3 << " mm";
    for (size_t i = 0; i < instruments.size(); ++i) {
      line << ", " << instruments[i].name() << " force " << runner.readings()[i].force.norm() << " N";
    }
    if (!haptic_json.is_null() && !haptic_json["period_jitter_ms"].is_null()) {
      line << "\npliant run: haptics " << haptic_json["ticks"].get<long>() << " ticks, period jitter p99 "
           << haptic_json["period_jitter_ms"]["p99"].get<double>() << " ms, deadline misses "
           << haptic_json["deadline_misses"].get<long>();
    }
    log << line.str() << "\n" << "pliant run: wrote " << out.string() << "/{summary.json,steps.csv,tool_forces.csv"
        << (options.realtime ? ",ticks.csv" : "") << (haptic_json.is_null() ? "" : ",haptic_forces.csv") << (frames.written() > 0 ? ",frames/" : "") << "}\n";
  }
  if (!runner.fault().empty()) {
    log << "pliant run: " << runner.fault() << "\n";
    return 1;
  }
  if (interrupted) {
    log << "pliant run: interrupted; outputs flushed\n";
    return 130;
  }
  return 0;
}

}  // namespace pliant
