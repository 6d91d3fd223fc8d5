// Design note. Both methods run the same scene file; only contact.method differs. Energies follow
// the paper's Fig. 10: kinetic and potential energy in % of the initial system energy E0 =
// kinetic + potential at t = 0. The World reports gravitational energy relative to the start of
// the run, so the absolute potential is that plus m g h at t = 0, with h measured from the lowest
// vertex of the scene at t = 0 (every body, kinematic ones included); elastic energy is added to
// the potential. Immovable vertices (fixed or kinematic) carry no energy. Time to rest: the first
// time after the kinetic-energy peak from which the kinetic energy stays below 1% of that peak to
// the end of the run (null if it never settles within the run).
#include "apps/experiment_command.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "apps/side_by_side_frames.h"
#include "interaction/clock.h"
#include "interaction/scene/scene_runner.h"
#include "interaction/step_time_stats.h"
#include "sim/input_error.h"
#include "sim/io/atomic_file.h"

namespace pliant {
namespace {

// One step of one method.
struct Sample {
  double time = 0.0;              ///< s
  double kinetic = 0.0;           ///< J
  double potential = 0.0;         ///< J, gravitational (from the scene's lowest point) + elastic
  double max_penetration = 0.0;   ///< m, before response
  double residual_overlap = 0.0;  ///< m, after response
  int colliding_vertices = 0;
  int sleeping_bodies = 0;
  double stage_ms[kStepStageCount] = {};
  double step_ms = 0.0;
};

// A run of one method.
struct MethodRun {
  std::string method;
  double initial_energy = 0.0;  ///< J, E0
  std::vector<Sample> samples;
  std::string fault;
  long retried_steps = 0;
};

// The paper's figures and the targets for each experiment (null where none is given).
struct PaperFigures {
  std::optional<double> response_ms;  ///< paper, Pentium 4 3.2 GHz
  std::optional<double> step_ms;      ///< paper
  std::optional<double> target_response_ms;
  std::optional<double> target_step_ms;
  int vertices = 0;
  int surface_triangles = 0;
};

const std::map<std::string, PaperFigures>& paper_figures() {
  static const std::map<std::string, PaperFigures> figures = {
      {"three_cubes", {2.0, std::nullopt, 0.040, std::nullopt, 323, 624}},
      {"sphere_squeeze", {0.9, std::nullopt, 0.018, std::nullopt, 95, 166}},
      {"fruit_dish", {72.0, 150.0, 1.44, 7.5, 16030, 27116}},
      {"membrane_stack", {std::nullopt, std::nullopt, std::nullopt, std::nullopt, 2178, 4320}},
  };
  return figures;
}

nlohmann::json opt_json(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

// Gravitational potential of the movable vertices, heights from `h_ref` along -g (J).
double gravitational_potential(const World& world, double h_ref) {
  const Vec3 g = world.settings().gravity;
  const double g_norm = g.norm();
  if (g_norm == 0.0) return 0.0;
  const Vec3 up = -g / g_norm;
  double e = 0.0;
  for (const Body* body : world.bodies()) {
    if (body == nullptr || body->is_kinematic()) continue;
    for (int v = 0; v < body->vertex_count(); ++v) {
      if (body->fixed[static_cast<size_t>(v)] != 0) continue;
      e += body->masses[static_cast<size_t>(v)] * g_norm *
           (body->positions[static_cast<size_t>(v)].dot(up) - h_ref);
    }
  }
  return e;
}

double kinetic_energy(const World& world) {
  double e = 0.0;
  for (const Body* body : world.bodies()) {
    if (body == nullptr || body->is_kinematic()) continue;
    for (int v = 0; v < body->vertex_count(); ++v) {
      if (body->fixed[static_cast<size_t>(v)] != 0) continue;
      e +=
          0.5 * body->masses[static_cast<size_t>(v)] * body->velocities[static_cast<size_t>(v)].squaredNorm();
    }
  }
  return e;
}

// Lowest point of the scene along -g at t = 0 (every body).
double lowest_height(const World& world) {
  const Vec3 g = world.settings().gravity;
  const Vec3 up = g.norm() > 0.0 ? Vec3(-g / g.norm()) : Vec3::UnitZ();
  double h = std::numeric_limits<double>::infinity();
  for (const Body* body : world.bodies()) {
    if (body == nullptr) continue;
    for (const Vec3& x : body->positions) h = std::min(h, x.dot(up));
  }
  return std::isfinite(h) ? h : 0.0;
}

// Side 0 (left panel) keeps its frames, side 1 renders them next to the kept ones.
void frame(SideBySideFrames* frames, int side, const World& world) {
  if (frames == nullptr) return;
  const long index = frames->due(side, world.time());
  if (index < 0) return;
  if (side == 0) {
    frames->keep_left(world, index);
  } else {
    frames->write_right(world, index);
  }
}

MethodRun run_method(const Scene& base, ContactMethod method, long steps, bool cpu_time, std::ostream* log,
                     SideBySideFrames* frames, int side) {
  Scene scene = base;
  scene.world.contact.method = method;
  SceneRunner runner(scene);
  const World& world = runner.world();
  MethodRun run;
  run.method = to_string(method);
  const double h_ref = lowest_height(world);
  const double gravitational0 = gravitational_potential(world, h_ref);
  const double kinetic0 = kinetic_energy(world);
  run.initial_energy = gravitational0 + kinetic0;
  run.samples.reserve(static_cast<size_t>(steps) + 1);
  Sample first;
  first.kinetic = kinetic0;
  first.potential = gravitational0;
  run.samples.push_back(first);
  frame(frames, side, world);

  SteadyClock steady;
  ThreadCpuClock cpu;
  ClockStageProfiler profiler(cpu_time ? static_cast<const Clock&>(cpu) : static_cast<const Clock&>(steady));
  const long progress_every = std::max(1L, steps / 10);
  for (long i = 0; i < steps; ++i) {
    if (!runner.tick(&profiler)) {
      run.fault = runner.fault();
      break;
    }
    const StepReport& r = runner.report();
    Sample s;
    s.time = r.time;
    s.kinetic = r.energy.kinetic;
    s.potential = gravitational0 + r.energy.gravitational + r.energy.elastic;
    s.max_penetration = r.max_penetration_before;
    s.residual_overlap = r.max_residual_overlap;
    s.colliding_vertices = r.colliding_vertices;
    s.sleeping_bodies = r.sleeping_bodies;
    for (int k = 0; k < kStepStageCount; ++k)
      s.stage_ms[k] = profiler.seconds(static_cast<StepStage>(k)) * 1e3;
    s.step_ms = profiler.total() * 1e3;
    run.samples.push_back(s);
    frame(frames, side, world);
    if (log != nullptr && (i + 1) % progress_every == 0) {
      *log << "pliant experiment: " << run.method << " " << (i + 1) << "/" << steps << " steps\n"
           << std::flush;
    }
  }
  run.retried_steps = runner.retried_steps();
  return run;
}

void write_steps_csv(const MethodRun& run, const std::filesystem::path& file) {
  std::ostringstream out;
  out << std::setprecision(9)
      << "time,kinetic_pct,potential_pct,kinetic,potential,max_penetration_before,max_residual_overlap,"
         "colliding_vertices,step_ms,integrate_ms,detect_ms,depth_ms,respond_ms,report_ms,sleeping_bodies\n";
  const double e0 = run.initial_energy > 0.0 ? run.initial_energy : 1.0;
  for (const Sample& s : run.samples) {
    out << s.time << ',' << 100.0 * s.kinetic / e0 << ',' << 100.0 * s.potential / e0 << ',' << s.kinetic
        << ',' << s.potential << ',' << s.max_penetration << ',' << s.residual_overlap << ','
        << s.colliding_vertices << ',' << s.step_ms;
    for (double ms : s.stage_ms) out << ',' << ms;
    out << ',' << s.sleeping_bodies << '\n';
  }
  write_file_atomically(file.string(), out.str());
}

// First time after the kinetic peak from which KE < 1% of the peak until the end; null if never.
nlohmann::json time_to_rest(const MethodRun& run, double* peak_time_out) {
  const auto& s = run.samples;
  if (s.size() < 2) return nullptr;
  size_t peak = 0;
  for (size_t i = 1; i < s.size(); ++i) {
    if (s[i].kinetic > s[peak].kinetic) peak = i;
  }
  *peak_time_out = s[peak].time;
  const double threshold = 0.01 * s[peak].kinetic;
  if (!(s.back().kinetic < threshold)) return nullptr;
  size_t rest = s.size() - 1;
  while (rest > peak + 1 && s[rest - 1].kinetic < threshold) --rest;
  return s[rest].time;
}

nlohmann::json stats_ms(const std::vector<double>& values) {
  if (values.empty()) return nullptr;
  StepTimeStats stats;
  double sum = 0.0;
  for (double v : values) {
    stats.add(v);
    sum += v;
  }
  const Percentiles p = stats.summary();
  return {{"mean", sum / static_cast<double>(values.size())}, {"p50", p.p50}, {"p99", p.p99}, {"max", p.max}};
}

nlohmann::json method_summary(const MethodRun& run) {
  std::vector<double> step, respond, respond_contact, collision, detect, depth;
  double max_pen = 0.0, max_residual = 0.0, residual_sum = 0.0, pen_sum = 0.0;
  long contact_steps = 0;
  int colliding_max = 0;
  for (size_t i = 1; i < run.samples.size(); ++i) {
    const Sample& s = run.samples[i];
    const auto stage = [&](StepStage st) { return s.stage_ms[static_cast<size_t>(st)]; };
    step.push_back(s.step_ms);
    respond.push_back(stage(StepStage::respond));
    detect.push_back(stage(StepStage::detect));
    depth.push_back(stage(StepStage::depth));
    collision.push_back(stage(StepStage::detect) + stage(StepStage::depth) + stage(StepStage::respond));
    if (s.colliding_vertices > 0) {
      respond_contact.push_back(stage(StepStage::respond));
      ++contact_steps;
      residual_sum += s.residual_overlap;
      pen_sum += s.max_penetration;
    }
    max_pen = std::max(max_pen, s.max_penetration);
    max_residual = std::max(max_residual, s.residual_overlap);
    colliding_max = std::max(colliding_max, s.colliding_vertices);
  }
  // Resting overlap: the mean over the last fifth of the run (the penalty's initial push-out and
  // the landing impact excluded).
  double resting_sum = 0.0;
  long resting_count = 0;
  for (size_t i = 1 + 4 * (run.samples.size() - 1) / 5; i < run.samples.size(); ++i) {
    resting_sum += run.samples[i].residual_overlap;
    ++resting_count;
  }
  double peak_time = 0.0;
  const nlohmann::json rest = time_to_rest(run, &peak_time);
  const double e0 = run.initial_energy > 0.0 ? run.initial_energy : 1.0;
  const Sample& last = run.samples.back();
  return {
      {"steps", static_cast<long>(run.samples.size()) - 1},
      {"simulated_time", last.time},
      {"initial_energy_J", run.initial_energy},
      {"final_kinetic_pct", 100.0 * last.kinetic / e0},
      {"final_potential_pct", 100.0 * last.potential / e0},
      {"kinetic_peak_time_s", peak_time},
      {"time_to_rest_s", rest},
      {"step_ms", stats_ms(step)},
      {"response_ms", stats_ms(respond)},
      {"response_ms_steps_with_contact", stats_ms(respond_contact)},
      {"detect_ms", stats_ms(detect)},
      {"depth_ms", stats_ms(depth)},
      {"collision_handling_ms", stats_ms(collision)},
      {"steps_with_contact", contact_steps},
      {"colliding_vertices_max", colliding_max},
      {"max_penetration_before_m", max_pen},
      {"max_residual_overlap_m", max_residual},
      {"mean_penetration_before_m", contact_steps > 0 ? pen_sum / static_cast<double>(contact_steps) : 0.0},
      {"mean_residual_overlap_m",
       contact_steps > 0 ? residual_sum / static_cast<double>(contact_steps) : 0.0},
      {"resting_residual_overlap_m",
       resting_count > 0 ? resting_sum / static_cast<double>(resting_count) : 0.0},
      {"retried_steps", run.retried_steps},
      {"fault", run.fault.empty() ? nlohmann::json(nullptr) : nlohmann::json(run.fault)},
  };
}

// gnuplot script for DIR/energy.png, DIR/penetration.png and DIR/stages.png; run if gnuplot is installed.
bool write_plots(const std::filesystem::path& dir, const std::string& title, std::ostream* log) {
  std::ostringstream gp;
  gp << "# Made by `pliant experiment`; rerun with: gnuplot plots.gp (from this folder)\n"
     << "set datafile separator ','\nset key autotitle columnhead noenhanced\nset grid\n"
     << "set terminal pngcairo noenhanced size 800,700 font ',10'\n"
     << "set output 'energy.png'\nset multiplot layout 2,1 title '" << title
     << ": energy in % of the initial energy (cf. paper Fig. 10)'\n"
     << "set xlabel 'time (s)'\nset ylabel 'kinetic energy (% of E0)'\n"
     << "plot 'surface/steps.csv' using 1:2 with lines lw 2 title 'contact surface', "
        "'penalty/steps.csv' using 1:2 with lines lw 2 title 'penalty'\n"
     << "set ylabel 'potential energy (% of E0)'\n"
     << "plot 'surface/steps.csv' using 1:3 with lines lw 2 title 'contact surface', "
        "'penalty/steps.csv' using 1:3 with lines lw 2 title 'penalty'\n"
     << "unset multiplot\n"
     << "set terminal pngcairo noenhanced size 800,400 font ',10'\nset output 'penetration.png'\n"
     << "set title '" << title << ": largest penetration depth per step'\n"
     << "set xlabel 'time (s)'\nset ylabel 'depth (mm)'\n"
     << "plot 'surface/steps.csv' using 1:($6*1000) with lines lw 2 title 'contact surface: before "
        "response', "
        "'surface/steps.csv' using 1:($7*1000) with lines lw 2 title 'contact surface: after response', "
        "'penalty/steps.csv' using 1:($6*1000) with lines lw 2 title 'penalty'\n"
     << "set terminal pngcairo noenhanced size 800,500 font ',10'\nset output 'stages.png'\n"
     << "set title '" << title << ": time per stage and sleeping bodies (contact surface run)'\n"
     << "set xlabel 'time (s)'\nset ylabel 'wall time per step (ms)'\nset y2label 'sleeping bodies'\n"
     << "set y2tics\nset ytics nomirror\nset key top right\n"
     << "plot 'surface/steps.csv' using 1:9 with lines lw 2 title 'step', "
        "'' using 1:10 with lines title 'integrate', '' using 1:11 with lines title 'detect', "
        "'' using 1:12 with lines title 'depth', '' using 1:13 with lines title 'respond', "
        "'' using 1:15 axes x1y2 with lines lw 2 dt 2 title 'sleeping bodies (right axis)'\n";
  write_file_atomically((dir / "plots.gp").string(), gp.str());
  const std::string command = "cd '" + dir.string() + "' && gnuplot plots.gp > plots.log 2>&1";
  const int rc = std::system(command.c_str());
  if (rc != 0 && log != nullptr) *log << "pliant experiment: gnuplot failed or is missing (see plots.log)\n";
  return rc == 0;
}

std::string fmt(const nlohmann::json& v, double scale = 1.0, int precision = 3) {
  if (!v.is_number()) return "n/a";
  std::ostringstream s;
  s << std::setprecision(precision) << v.get<double>() * scale;
  return s.str();
}

std::string report_markdown(const nlohmann::json& summary) {
  const auto& s = summary["methods"]["surface"];
  const auto& p = summary["methods"]["penalty"];
  const auto& paper = summary["paper"];
  std::ostringstream md;
  md << "# Experiment " << summary["name"].get<std::string>() << "\n\n"
     << summary["vertices"] << " vertices, " << summary["tets"] << " tets, " << summary["surface_triangles"]
     << " surface triangles (paper: " << paper["vertices"] << " / " << paper["surface_triangles"] << "); "
     << summary["steps"] << " steps of " << fmt(summary["dt"], 1e3)
     << " ms. Timings are "
     << (summary["clock"] == "thread_cpu_time" ? "thread CPU time" : "wall clock") << " on "
     << summary["threads"].get<int>() << (summary["threads"].get<int>() == 1 ? " thread" : " threads")
     << " of the machine that ran this; p50 is robust to load.\n\n"
     << "| | contact surface | penalty | paper (Pentium 4) | target |\n|---|---|---|---|---|\n"
     << "| response ms, mean (p50) | " << fmt(s["response_ms"]["mean"]) << " ("
     << fmt(s["response_ms"]["p50"]) << ") | " << fmt(p["response_ms"]["mean"]) << " ("
     << fmt(p["response_ms"]["p50"]) << ") | " << fmt(paper["response_ms"]) << " | "
     << fmt(paper["target_response_ms"]) << " |\n"
     << "| response ms in steps with contact, mean | " << fmt(s["response_ms_steps_with_contact"]["mean"])
     << " | " << fmt(p["response_ms_steps_with_contact"]["mean"]) << " | | |\n"
     << "| detect + depth + response ms, mean | " << fmt(s["collision_handling_ms"]["mean"]) << " | "
     << fmt(p["collision_handling_ms"]["mean"]) << " | | |\n"
     << "| step ms, mean (p50) | " << fmt(s["step_ms"]["mean"]) << " (" << fmt(s["step_ms"]["p50"]) << ") | "
     << fmt(p["step_ms"]["mean"]) << " (" << fmt(p["step_ms"]["p50"]) << ") | " << fmt(paper["step_ms"])
     << " | " << fmt(paper["target_step_ms"]) << " |\n"
     << "| max penetration before response (mm) | " << fmt(s["max_penetration_before_m"], 1e3) << " | "
     << fmt(p["max_penetration_before_m"], 1e3) << " | | |\n"
     << "| max residual overlap after response (mm) | " << fmt(s["max_residual_overlap_m"], 1e3) << " | "
     << fmt(p["max_residual_overlap_m"], 1e3) << " | | |\n"
     << "| mean residual overlap, steps with contact (mm) | " << fmt(s["mean_residual_overlap_m"], 1e3)
     << " | " << fmt(p["mean_residual_overlap_m"], 1e3) << " | | |\n"
     << "| resting residual overlap, mean over the last fifth (mm) | "
     << fmt(s["resting_residual_overlap_m"], 1e3) << " | " << fmt(p["resting_residual_overlap_m"], 1e3)
     << " | | surface <= 1% of penalty |\n"
     << "| colliding vertices, max | " << s["colliding_vertices_max"] << " | " << p["colliding_vertices_max"]
     << " | | |\n"
     << "| time to rest (s) | " << fmt(s["time_to_rest_s"]) << " | " << fmt(p["time_to_rest_s"])
     << " | | surface <= half of penalty |\n"
     << "| final kinetic / potential energy (% of E0) | " << fmt(s["final_kinetic_pct"]) << " / "
     << fmt(s["final_potential_pct"]) << " | " << fmt(p["final_kinetic_pct"]) << " / "
     << fmt(p["final_potential_pct"]) << " | | |\n\n"
     << "Time to rest: from the kinetic-energy peak until it stays below 1% of the peak (n/a: not within the "
        "run).\n"
     << "Resting residual-overlap ratio surface / penalty: " << fmt(summary["residual_overlap_ratio"])
     << "; time-to-rest ratio: " << fmt(summary["rest_time_ratio"]) << ".\n\n";
  if (summary["plots"].get<bool>()) md << "![energy](energy.png)\n\n![penetration](penetration.png)\n\n![stages](stages.png)\n";
  for (const char* m : {"surface", "penalty"}) {
    if (!summary["methods"][m]["fault"].is_null()) {
      md << "\n**" << m << " stopped:** " << summary["methods"][m]["fault"].get<std::string>() << "\n";
    }
  }
  return md.str();
}

}  // namespace

std::filesystem::path find_scene_folder() {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory("assets/scenes", ec)) return fs::path("assets/scenes");
  char exe[4096] = {};
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n > 0) {
    for (fs::path dir = fs::path(std::string(exe, static_cast<size_t>(n))).parent_path(); !dir.empty();
         dir = dir.parent_path()) {
      if (fs::is_directory(dir / "assets" / "scenes", ec)) return dir / "assets" / "scenes";
      if (dir == dir.root_path()) break;
    }
  }
  return {};
}

std::filesystem::path resolve_scene(const std::string& name_or_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_regular_file(name_or_path, ec)) return name_or_path;
  const fs::path folder = find_scene_folder();
  if (!folder.empty()) {
    for (const fs::path& candidate :
         {folder / "paper" / (name_or_path + ".json"), folder / (name_or_path + ".json")}) {
      if (fs::is_regular_file(candidate, ec)) return candidate;
    }
  }
  throw InputError(InputErrorKind::io, name_or_path,
                   "no such scene file, and no assets/scenes/paper/" + name_or_path +
                       ".json (known: three_cubes, "
                       "sphere_squeeze, fruit_dish, membrane_stack)");
}

int run_experiment(const ExperimentOptions& options, std::ostream& log) {
  const std::filesystem::path scene_file = resolve_scene(options.name);
  Scene scene = load_scene(scene_file.string());
  if (options.threads) scene.threads = *options.threads;
  if (options.cpu_time && scene.threads > 1) {
    log << "note: --cpu-time counts the stepping thread's CPU only, not the other threads' work: compare "
           "thread counts by wall time (docs/threads.md)\n";
  }
  const double duration = options.duration ? *options.duration : scene.duration;
  const long steps = static_cast<long>(std::llround(duration / scene.time_step));
  if (steps < 1) throw InputError(InputErrorKind::bad_value, "--duration", "must give at least one step");

  const std::filesystem::path out = options.out;
  std::error_code ec;
  for (const char* m : {"surface", "penalty"}) {
    std::filesystem::create_directories(out / m, ec);
    if (ec)
      throw InputError(InputErrorKind::io, (out / m).string(),
                       "cannot create output folder: " + ec.message());
  }

  std::ostream* progress = options.quiet ? nullptr : &log;
  std::unique_ptr<SideBySideFrames> frames;
  if (options.frames) {
    SideBySideSettings fs;
    fs.folder = out / "frames";
    fs.frame_rate = options.frame_rate;
    frames = std::make_unique<SideBySideFrames>(scene, fs, progress);
    if (!frames->enabled()) frames.reset();
  }
  std::map<std::string, MethodRun> runs;
  int side = 0;
  for (ContactMethod method : {ContactMethod::contact_surface, ContactMethod::penalty}) {
    MethodRun run = run_method(scene, method, steps, options.cpu_time, progress, frames.get(), side++);
    write_steps_csv(run, out / run.method / "steps.csv");
    runs.emplace(run.method, std::move(run));
  }
  if (frames) frames->finish();
  const bool plots = write_plots(out, scene.name, progress);

  // Sizes, counting every body (kinematic ones too), as the paper does.
  SceneInstance instance = instantiate_scene(scene);
  long vertices = 0, tets = 0, triangles = 0;
  for (const Body* body : instance.world->bodies()) {
    if (body == nullptr) continue;
    vertices += body->mesh->vertex_count();
    tets += body->mesh->tet_count();
    triangles += body->mesh->surface_triangle_count();
  }
  nlohmann::json paper = {{"response_ms", nullptr},
                          {"step_ms", nullptr},
                          {"target_response_ms", nullptr},
                          {"target_step_ms", nullptr},
                          {"vertices", nullptr},
                          {"surface_triangles", nullptr},
                          {"machine", "Pentium 4, 3.20 GHz, NVIDIA Quadro FX 3400"}};
  if (auto it = paper_figures().find(scene.name); it != paper_figures().end()) {
    const PaperFigures& f = it->second;
    paper["response_ms"] = opt_json(f.response_ms);
    paper["step_ms"] = opt_json(f.step_ms);
    paper["target_response_ms"] = opt_json(f.target_response_ms);
    paper["target_step_ms"] = opt_json(f.target_step_ms);
    paper["vertices"] = f.vertices;
    paper["surface_triangles"] = f.surface_triangles;
  }
  nlohmann::json methods = {{"surface", method_summary(runs["surface"])},
                            {"penalty", method_summary(runs["penalty"])}};
  const double residual_penalty = methods["penalty"]["resting_residual_overlap_m"].get<double>();
  nlohmann::json summary = {
      {"name", scene.name},
      {"scene", scene_file.string()},
      {"dt", scene.time_step},
      {"steps", steps},
      {"clock", options.cpu_time ? "thread_cpu_time" : "steady_clock"},
      {"threads", scene.threads},
      {"vertices", vertices},
      {"tets", tets},
      {"surface_triangles", triangles},
      {"finishing_projection", scene.world.contact.finishing_projection},
      {"binary_search_iterations", scene.world.contact.binary_search_iterations},
      {"penalty_stiffness_N_per_m", scene.world.contact.penalty_stiffness},
      {"paper", paper},
      {"methods", methods},
      {"residual_overlap_ratio",
       residual_penalty > 0.0
           ? nlohmann::json(methods["surface"]["resting_residual_overlap_m"].get<double>() / residual_penalty)
           : nlohmann::json(nullptr)},
      {"rest_time_ratio", methods["surface"]["time_to_rest_s"].is_number() &&
                                  methods["penalty"]["time_to_rest_s"].is_number() &&
                                  methods["penalty"]["time_to_rest_s"].get<double>() > 0.0
                              ? nlohmann::json(methods["surface"]["time_to_rest_s"].get<double>() /
                                               methods["penalty"]["time_to_rest_s"].get<double>())
                              : nlohmann::json(nullptr)},
      {"plots", plots},
      {"frames", frames ? frames->written() : 0},
      {"frame_rate", options.frame_rate},
  };
  write_file_atomically((out / "summary.json").string(), summary.dump(2) + "\n");
  write_file_atomically((out / "report.md").string(), report_markdown(summary));
  if (!options.quiet) {
    log << "pliant experiment: " << scene.name << ": response ms mean surface "
        << fmt(methods["surface"]["response_ms"]["mean"]) << ", penalty "
        << fmt(methods["penalty"]["response_ms"]["mean"]) << "; max residual overlap mm surface "
        << fmt(methods["surface"]["max_residual_overlap_m"], 1e3) << ", penalty "
        << fmt(methods["penalty"]["max_residual_overlap_m"], 1e3) << "; wrote " << out.string()
        << "/{summary.json,report.md,surface/,penalty/" << (plots ? ",energy.png,penetration.png,stages.png" : "")
        << "}\n";
  }
  for (const auto& [name, run] : runs) {
    if (!run.fault.empty()) {
      log << "pliant experiment: " << name << " stopped: " << run.fault << "\n";
      return 1;
    }
  }
  return 0;
}

}  // namespace pliant
