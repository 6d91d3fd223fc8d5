// Design note. Every row is one scene run from its start for warm_up_steps untimed steps and then
// `steps` timed ones, each stage timed by ClockStageProfiler (SteadyClock). Percentiles are
// nearest-rank (StepTimeStats). "Model only what a scene requires" is shown, not asserted: the
// response time is split into steps with and without colliding vertices, and scenes whose
// materials have friction get a second row with contact.friction off. Wall-clock numbers on a
// shared machine: read p50, not max.
#include "apps/bench_command.h"

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "apps/callgrind_window.h"
#include "apps/experiment_command.h"
#include "apps/run_command.h"
#include "interaction/clock.h"
#include "interaction/host_steal.h"
#include "interaction/scene/scene_haptics.h"
#include "interaction/scene/scene_runner.h"
#include "interaction/step_time_stats.h"
#include "sim/input_error.h"
#include "sim/io/atomic_file.h"

namespace pliant {
namespace {

// One window of the over-time profile (--window).
struct BenchWindow {
  double time_begin = 0.0, time_end = 0.0;  ///< s of simulated time
  StepTimeStats step, integrate, detect, depth, respond, report;
  long colliding_sum = 0;
  int awake_bodies = 0;  ///< deformable bodies awake after the window's last step
};

// One row of the table.
struct BenchRow {
  std::string scene;
  std::string variant;  ///< "" or "friction off"
  std::string method;
  long vertices = 0, tets = 0, surface_triangles = 0, bodies = 0;
  long steps = 0;
  StepTimeStats step, integrate, detect, depth, respond, report;
  StepTimeStats respond_with_contact, respond_without_contact;
  double colliding_mean = 0.0;
  int deformable_bodies = 0;
  std::vector<BenchWindow> windows;
  std::string fault;
};

bool uses_friction(const Scene& scene) {
  if (!scene.world.contact.friction) return false;
  for (const BodyDef& b : scene.bodies) {
    if (b.material.friction > 0.0) return true;
  }
  for (const InstrumentSpec& i : scene.instruments) {
    if (i.friction > 0.0) return true;
  }
  return false;
}

BenchRow bench_scene(const Scene& scene, const std::string& variant, const BenchOptions& options) {
  if (options.callgrind_timed && !callgrind_requests_available) {
    throw InputError(InputErrorKind::bad_value, "--callgrind-timed", "this build has no valgrind/callgrind.h (install valgrind)");
  }
  SceneRunner runner(scene);
  BenchRow row;
  row.scene = scene.name;
  row.variant = variant;
  row.method = to_string(scene.world.contact.method);
  for (const Body* body : runner.world().bodies()) {
    if (body == nullptr) continue;
    ++row.bodies;
    if (!body->is_kinematic()) ++row.deformable_bodies;
    row.vertices += body->mesh->vertex_count();
    row.tets += body->mesh->tet_count();
    row.surface_triangles += body->mesh->surface_triangle_count();
  }
  SteadyClock steady;
  ThreadCpuClock cpu;
  const Clock& clock = options.cpu_time ? static_cast<const Clock&>(cpu) : static_cast<const Clock&>(steady);
  ClockStageProfiler profiler(clock);
  long colliding_sum = 0;
  for (long i = 0; i < options.warm_up_steps + options.steps; ++i) {
    if (options.callgrind_timed && i == options.warm_up_steps) start_callgrind_instrumentation();
    if (!runner.tick(&profiler)) {
      row.fault = runner.fault();
      break;
    }
    if (i < options.warm_up_steps) continue;
    const auto sec = [&](StepStage s) { return profiler.seconds(s); };
    row.step.add(profiler.total());
    row.integrate.add(sec(StepStage::integrate));
    row.detect.add(sec(StepStage::detect));
    row.depth.add(sec(StepStage::depth));
    row.respond.add(sec(StepStage::respond));
    row.report.add(sec(StepStage::report));
    const int colliding = runner.report().colliding_vertices;
    (colliding > 0 ? row.respond_with_contact : row.respond_without_contact).add(sec(StepStage::respond));
    colliding_sum += colliding;
    ++row.steps;
    if (options.window_steps > 0) {
      if ((row.steps - 1) % options.window_steps == 0) {
        row.windows.emplace_back();
        row.windows.back().time_begin = runner.time() - scene.time_step;
      }
      BenchWindow& w = row.windows.back();
      w.time_end = runner.time();
      w.step.add(profiler.total());
      w.integrate.add(sec(StepStage::integrate));
      w.detect.add(sec(StepStage::detect));
      w.depth.add(sec(StepStage::depth));
      w.respond.add(sec(StepStage::respond));
      w.report.add(sec(StepStage::report));
      w.colliding_sum += colliding;
      w.awake_bodies = row.deformable_bodies - runner.report().sleeping_bodies;
    }
  }
  if (options.callgrind_timed) stop_callgrind_instrumentation();
  row.colliding_mean =
      row.steps > 0 ? static_cast<double>(colliding_sum) / static_cast<double>(row.steps) : 0.0;
  return row;
}

// p50 in ms, or null without samples.
nlohmann::json p50_ms(const StepTimeStats& s) {
  return s.count() ? nlohmann::json(s.percentile(0.5) * 1e3) : nullptr;
}

nlohmann::json window_json(const BenchWindow& w) {
  return {{"time_begin_s", w.time_begin},
          {"time_end_s", w.time_end},
          {"steps", w.step.count()},
          {"step_ms_p50", p50_ms(w.step)},
          {"integrate_ms_p50", p50_ms(w.integrate)},
          {"detect_ms_p50", p50_ms(w.detect)},
          {"depth_ms_p50", p50_ms(w.depth)},
          {"respond_ms_p50", p50_ms(w.respond)},
          {"report_ms_p50", p50_ms(w.report)},
          {"awake_bodies", w.awake_bodies},
          {"colliding_vertices_mean",
           w.step.count() ? static_cast<double>(w.colliding_sum) / static_cast<double>(w.step.count()) : 0.0}};
}

nlohmann::json row_json(const BenchRow& r) {
  nlohmann::json windows = nlohmann::json::array();
  for (const BenchWindow& w : r.windows) windows.push_back(window_json(w));
  return {{"scene", r.scene},
          {"variant", r.variant},
          {"method", r.method},
          {"bodies", r.bodies},
          {"vertices", r.vertices},
          {"tets", r.tets},
          {"surface_triangles", r.surface_triangles},
          {"steps", r.steps},
          {"step_ms_p50", p50_ms(r.step)},
          {"step_ms_p99", r.step.count() ? nlohmann::json(r.step.percentile(0.99) * 1e3) : nullptr},
          {"integrate_ms_p50", p50_ms(r.integrate)},
          {"detect_ms_p50", p50_ms(r.detect)},
          {"depth_ms_p50", p50_ms(r.depth)},
          {"respond_ms_p50", p50_ms(r.respond)},
          {"report_ms_p50", p50_ms(r.report)},
          {"respond_ms_p50_with_contact", p50_ms(r.respond_with_contact)},
          {"steps_with_contact", r.respond_with_contact.count()},
          {"respond_ms_p50_without_contact", p50_ms(r.respond_without_contact)},
          {"steps_without_contact", r.respond_without_contact.count()},
          {"colliding_vertices_mean", r.colliding_mean},
          {"deformable_bodies", r.deformable_bodies},
          {"windows", windows},
          {"fault", r.fault.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.fault)}};
}

std::string cell(const nlohmann::json& v) {
  if (!v.is_number()) return "-";
  std::ostringstream s;
  const double x = v.get<double>();
  s << std::fixed << std::setprecision(x < 0.1 ? 4 : (x < 10.0 ? 3 : 1)) << x;
  return s.str();
}

const char* const kColumns[] = {"step_ms_p50",
                                "step_ms_p99",
                                "integrate_ms_p50",
                                "detect_ms_p50",
                                "depth_ms_p50",
                                "respond_ms_p50",
                                "report_ms_p50",
                                "respond_ms_p50_with_contact",
                                "respond_ms_p50_without_contact"};

// The over-time profile of one row: a line per window, under the row.
void log_windows(const nlohmann::json& row, std::ostream& log) {
  log << "  " << std::left << std::setw(14) << "t (s)" << std::right;
  for (const char* h : {"step50", "integ", "detect", "depth", "respond", "report", "awake", "collide"})
    log << std::setw(9) << h;
  log << "   (per window, ms p50; awake of " << row["deformable_bodies"] << " deformable bodies at its end;"
      << " colliding vertices mean)\n";
  for (const auto& w : row["windows"]) {
    std::ostringstream t;
    t << std::fixed << std::setprecision(3) << w["time_begin_s"].get<double>() << "-"
      << w["time_end_s"].get<double>();
    log << "  " << std::left << std::setw(14) << t.str() << std::right;
    for (const char* c : {"step_ms_p50", "integrate_ms_p50", "detect_ms_p50", "depth_ms_p50", "respond_ms_p50",
                          "report_ms_p50"})
      log << std::setw(9) << cell(w[c]);
    log << std::setw(9) << w["awake_bodies"].get<int>() << std::setw(9)
        << std::llround(w["colliding_vertices_mean"].get<double>()) << "\n";
  }
  log << std::flush;
}

std::vector<std::filesystem::path> shipped_scenes() {
  namespace fs = std::filesystem;
  const fs::path folder = find_scene_folder();
  if (folder.empty()) throw InputError(InputErrorKind::io, "assets/scenes", "shipped scene folder not found");
  std::vector<fs::path> files;
  for (const fs::path& dir : {folder, folder / "paper"}) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<fs::path> here;
    for (const auto& entry : fs::directory_iterator(dir)) {
      if (entry.is_regular_file() && entry.path().extension() == ".json") here.push_back(entry.path());
    }
    std::sort(here.begin(), here.end());
    files.insert(files.end(), here.begin(), here.end());
  }
  return files;
}

}  // namespace

int run_bench(const BenchOptions& options, std::ostream& log) {
  if (options.haptic) return run_haptic_bench(options, log);
  if (options.steps < 1) throw InputError(InputErrorKind::bad_value, "--steps", "must be at least 1");
  if (options.window_steps < 0) throw InputError(InputErrorKind::bad_value, "--window", "must not be negative");
  std::vector<std::filesystem::path> files;
  for (const std::string& s : options.scenes) files.push_back(resolve_scene(s));
  if (files.empty()) files = shipped_scenes();

  nlohmann::json rows = nlohmann::json::array();
  bool failed = false;
  if (options.cpu_time && options.threads && *options.threads > 1) {
    log << "note: --cpu-time counts the stepping thread's CPU only, not the other threads' work: compare "
           "thread counts by wall time (docs/threads.md)\n";
  }
  log << std::left << std::setw(32) << "scene" << std::right << std::setw(8) << "verts" << std::setw(8)
      << "tets" << std::setw(8) << "tris" << std::setw(9) << "step50" << std::setw(9) << "step99"
      << std::setw(9) << "integ" << std::setw(9) << "detect" << std::setw(9) << "depth" << std::setw(9)
      << "respond" << std::setw(9) << "report" << std::setw(9) << "resp+c" << std::setw(9) << "resp-c"
      << "   (ms" << (options.cpu_time ? " of thread CPU time" : "")
      << ", p50 unless 99; resp+c / resp-c: steps with / without contacts)\n"
      << std::flush;
  for (const auto& file : files) {
    Scene scene = load_scene(file.string());
    if (options.contact) scene.world.contact.method = contact_method_from_string(*options.contact);
    if (options.threads) scene.threads = *options.threads;
    std::vector<std::pair<Scene, std::string>> variants = {{scene, ""}};
    if (options.friction_variants && uses_friction(scene)) {
      Scene off = scene;
      off.world.contact.friction = false;
      variants.emplace_back(off, "friction off");
    }
    for (const auto& [s, variant] : variants) {
      const BenchRow row = bench_scene(s, variant, options);
      const nlohmann::json j = row_json(row);
      rows.push_back(j);
      failed = failed || !row.fault.empty();
      const std::string label = row.scene + (variant.empty() ? "" : " (" + variant + ")");
      log << std::left << std::setw(32) << label << std::right << std::setw(8) << row.vertices << std::setw(8)
          << row.tets << std::setw(8) << row.surface_triangles;
      for (const char* c : kColumns) log << std::setw(9) << cell(j[c]);
      log << (row.fault.empty() ? "" : "  FAILED: " + row.fault) << "\n" << std::flush;
      if (!row.windows.empty()) log_windows(j, log);
    }
  }

  if (!options.json.empty()) {
    const nlohmann::json doc = {{"steps", options.steps},
                                {"warm_up_steps", options.warm_up_steps},
                                {"clock", options.cpu_time ? "thread_cpu_time" : "steady_clock"},
                                {"window_steps", options.window_steps},
                                {"threads", options.threads ? *options.threads : 0},
                                {"percentiles", "nearest rank"},
                                {"rows", rows}};
    write_file_atomically(options.json, doc.dump(2) + "\n");
  }
  if (!options.csv.empty()) {
    std::ostringstream csv;
    csv << "scene,variant,method,bodies,vertices,tets,surface_triangles,steps,step_ms_p50,step_ms_p99,"
           "integrate_ms_p50,detect_ms_p50,depth_ms_p50,respond_ms_p50,report_ms_p50,respond_ms_p50_with_"
           "contact,"
           "steps_with_contact,respond_ms_p50_without_contact,steps_without_contact,colliding_vertices_"
           "mean\n";
    csv << std::setprecision(6);
    for (const auto& r : rows) {
      csv << r["scene"].get<std::string>() << ',' << r["variant"].get<std::string>() << ','
          << r["method"].get<std::string>();
      for (const char* k :
           {"bodies", "vertices", "tets", "surface_triangles", "steps", "step_ms_p50", "step_ms_p99",
            "integrate_ms_p50", "detect_ms_p50", "depth_ms_p50", "respond_ms_p50", "report_ms_p50",
            "respond_ms_p50_with_contact", "steps_with_contact", "respond_ms_p50_without_contact",
            "steps_without_contact", "colliding_vertices_mean"}) {
        csv << ',';
        if (!r[k].is_null()) csv << r[k];
      }
      csv << '\n';
    }
    write_file_atomically(options.csv, csv.str());
  }
  return failed ? 1 : 0;
}

namespace {

// One scene of the haptic benchmark.
nlohmann::json haptic_bench_scene(const Scene& scene, const BenchOptions& options, std::ostream& log) {
  SceneRunner runner(scene);
  long vertices = 0, tets = 0;
  for (const Body* body : runner.world().bodies()) {
    if (body == nullptr || body->motion == BodyMotion::kinematic) continue;
    vertices += body->mesh->vertex_count();
    tets += body->mesh->tet_count();
  }
  SteadyClock clock;
  ClockStageProfiler profiler(clock);
  const double budget = scene.loop.budget_or_period();
  for (long i = 0; i < options.warm_up_steps; ++i) {
    if (!runner.tick(&profiler)) break;
  }
  // The scene's "haptics" limits (clamp, rate limit, tick rate), as `pliant run --realtime` uses.
  HapticSettings settings = scene.haptics;
  if (options.haptic_threads) settings.threads = *options.haptic_threads;
  const HapticLimits& limits = settings.limits;
  SceneHaptics haptics(clock, runner, settings, options.seconds, options.realtime_priority);
  StepTimeStats step;
  long over_budget = 0;
  const double t_start = clock.now();
  const std::optional<double> steal_start = host_steal_seconds();
  haptics.start();
  while (runner.fault().empty() && clock.now() - t_start < options.seconds) {
    if (!runner.tick(&profiler)) break;
    haptics.refresh(runner, clock.now());
    step.add(profiler.total());
    if (profiler.total() > budget) ++over_budget;
  }
  haptics.stop();
  const std::optional<double> steal_end = host_steal_seconds();
  // Steal of both CPUs over the run (ms): time the host ran other guests while ours wanted to run;
  // -1 where /proc/stat has none.
  const double steal_ms = steal_start && steal_end ? (*steal_end - *steal_start) * 1e3 : -1.0;
  const HapticTiming timing = haptics.timing();
  nlohmann::json j = {{"scene", scene.name},
                      {"tissue_vertices", vertices},
                      {"tissue_tets", tets},
                      {"seconds", clock.now() - t_start},
                      {"physics_steps", step.count()},
                      {"simulated_time", runner.time()},
                      {"physics_step_ms", percentiles_ms_json(step)},
                      {"physics_budget_ms", budget * 1e3},
                      {"physics_steps_over_budget", over_budget},
                      {"haptic_limits", {{"max_force_n", limits.max_force},
                                         {"max_force_rate_n_per_s", limits.max_delta * limits.rate_hz},
                                         {"rate_hz", limits.rate_hz}}},
                      {"haptics", haptic_summary_json(timing, haptics.stats())},
                      {"host_steal_ms", steal_ms >= 0.0 ? nlohmann::json(steal_ms) : nlohmann::json(nullptr)},
                      {"fault", runner.fault().empty() ? nlohmann::json(nullptr) : nlohmann::json(runner.fault())}};
  const auto ms = [](const Percentiles& p, double q) { return (q < 0.9 ? p.p50 : (q < 1.0 ? p.p99 : p.max)) * 1e3; };
  log << std::left << std::setw(14) << scene.name << std::right << std::fixed << std::setprecision(3) << std::setw(7)
      << vertices << std::setw(8) << step.count() << std::setw(9) << (step.count() ? step.percentile(0.5) * 1e3 : 0.0)
      << std::setw(9) << (step.count() ? step.percentile(0.99) * 1e3 : 0.0) << std::setw(8) << over_budget
      << std::setw(8) << haptics.stats().ticks << std::setw(9) << ms(timing.period_jitter, 0.5) << std::setw(9)
      << ms(timing.period_jitter, 0.99) << std::setw(9) << ms(timing.period_jitter, 1.0) << std::setw(9)
      << ms(timing.lateness, 0.99) << std::setw(7) << timing.deadline_misses << std::setw(4)
      << (timing.realtime_priority ? "rt" : "-") << std::setw(4) << timing.ticks_by_thread.size()
      << std::setprecision(0) << std::setw(7)
      << steal_ms << (runner.fault().empty() ? "" : "  FAILED: " + runner.fault())
      << "\n"
      << std::flush;
  log.unsetf(std::ios::fixed);
  return j;
}

}  // namespace

nlohmann::json percentiles_ms_json(const StepTimeStats& stats) {
  if (stats.count() == 0) return nullptr;
  const Percentiles p = stats.summary();
  return {{"p50", p.p50 * 1e3}, {"p99", p.p99 * 1e3}, {"max", p.max * 1e3}};
}

int run_haptic_bench(const BenchOptions& options, std::ostream& log) {
  if (!(options.seconds > 0.0)) throw InputError(InputErrorKind::bad_value, "--seconds", "must be positive");
  std::vector<std::filesystem::path> files;
  for (const std::string& s : options.scenes) files.push_back(resolve_scene(s));
  if (files.empty()) {
    const std::filesystem::path folder = find_scene_folder();
    if (folder.empty()) throw InputError(InputErrorKind::io, "assets/scenes", "shipped scene folder not found");
    files = {folder / "probe.json", folder / "probe_5k.json"};
  }
  log << std::left << std::setw(14) << "scene" << std::right << std::setw(7) << "verts" << std::setw(8) << "steps"
      << std::setw(9) << "step50" << std::setw(9) << "step99" << std::setw(8) << ">budget" << std::setw(8)
      << "ticks" << std::setw(9) << "jit50" << std::setw(9) << "jit99" << std::setw(9) << "jitmax" << std::setw(9)
      << "late99" << std::setw(7) << "misses" << std::setw(4) << "pri" << std::setw(4) << "thr" << std::setw(7) << "steal"
      << "   (ms; verts: tissue; jit: |tick period - 1/rate|, late: start - slot; thr: haptic threads; steal: host, both CPUs, -1 unknown)\n"
      << std::flush;
  nlohmann::json rows = nlohmann::json::array();
  bool failed = false;
  for (const auto& file : files) {
    Scene scene = load_scene(file.string());
    if (options.contact) scene.world.contact.method = contact_method_from_string(*options.contact);
    if (options.threads) scene.threads = *options.threads;
    if (scene.instruments.empty()) {
      log << scene.name << ": no instruments, skipped\n";
      continue;
    }
    if (!scene.haptics.enabled) {
      log << scene.name << ": \"haptics\": {\"enabled\": false}, skipped\n";
      continue;
    }
    rows.push_back(haptic_bench_scene(scene, options, log));
    failed = failed || !rows.back()["fault"].is_null();
  }
  if (!options.json.empty()) {
    const nlohmann::json doc = {{"benchmark", "haptic"},
                                {"seconds", options.seconds},
                                {"warm_up_steps", options.warm_up_steps},
                                {"clock", "steady_clock"},
                                {"percentiles", "nearest rank"},
                                {"rows", rows}};
    write_file_atomically(options.json, doc.dump(2) + "\n");
  }
  return failed ? 1 : 0;
}

}  // namespace pliant
