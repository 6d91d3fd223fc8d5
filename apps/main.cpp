// The `pliant` command line: wires scene and mesh files to sim, interaction and render.
// Exit codes: 0 success, 1 runtime failure, 2 bad input (file, scene, script or flag).
#include <CLI/CLI.hpp>
#include <iostream>

#include "apps/bench_command.h"
#include "apps/experiment_command.h"
#include "apps/mesh_command.h"
#include "apps/run_command.h"
#include "apps/tradeoff_command.h"
#include "sim/input_error.h"

int main(int argc, char** argv) {
  CLI::App app{"pliant: interactive soft-tissue simulation with contact-surface response"};
  app.require_subcommand(1);
  int exit_code = 0;

  pliant::RunOptions run;
  std::string contact;
  int iterations = -1;
  auto* run_cmd = app.add_subcommand("run", "Run a scene: summary.json, steps.csv, tool_forces.csv, frames");
  run_cmd->add_option("scene", run.scene, "Scene file (JSON)")->required();
  run_cmd->add_option("--out", run.out, "Output folder")->capture_default_str();
  auto* steps_opt = run_cmd->add_option("--steps", run.steps, "Number of steps")->check(CLI::PositiveNumber);
  run_cmd->add_option("--duration", run.duration, "Simulated time (s)")->check(CLI::PositiveNumber)->excludes(steps_opt);
  run_cmd->add_option("--contact", contact, "Contact method")->check(CLI::IsMember({"surface", "penalty", "none"}));
  run_cmd->add_option("--iterations", iterations, "Binary-search iterations of the contact surface")
      ->check(CLI::Range(0, 30));
  run_cmd->add_flag("--frames", run.frames, "Render frames even if the scene does not ask");
  run_cmd->add_flag("--no-frames", run.no_frames, "Do not render frames");
  run_cmd->add_flag("--vtu", run.vtu, "Write .vtu frames and a .pvd series");
  run_cmd->add_flag("--realtime", run.realtime, "Run on the wall clock at the scene's loop rate");
  bool no_haptics = false, no_rt_priority = false;
  run_cmd->add_flag("--no-haptics", no_haptics, "With --realtime: no haptic thread");
  run_cmd->add_flag("--no-rt-priority", no_rt_priority, "With --realtime: do not ask SCHED_FIFO for the haptic thread");
  run_cmd->add_flag("--quiet", run.quiet, "Print nothing on success");
  int run_threads = 0;
  auto* run_threads_opt = run_cmd->add_option("--threads", run_threads, "Threads the step runs on (overrides the scene's)")
                              ->check(CLI::Range(1, 256));
  run_cmd->callback([&] {
    if (!contact.empty()) run.contact = contact;
    if (iterations >= 0) run.binary_search_iterations = iterations;
    run.haptics = !no_haptics;
    run.realtime_priority = !no_rt_priority;
    if (run_threads_opt->count() > 0) run.threads = run_threads;
    exit_code = pliant::run_scene(run, std::cout);
  });

  auto* mesh_cmd = app.add_subcommand("mesh", "Mesh tools");
  mesh_cmd->require_subcommand(1);
  std::string mesh_file, mesh_out;
  auto* info = mesh_cmd->add_subcommand("info", "Counts, volume, bounding box, quality, validation");
  info->add_option("file", mesh_file, "Mesh file (.node/.ele, .msh, .vtk)")->required();
  info->callback([&] { exit_code = pliant::run_mesh_info(mesh_file, std::cout); });
  auto* convert = mesh_cmd->add_subcommand("convert", "Convert between mesh formats");
  convert->add_option("in", mesh_file, "Input mesh")->required();
  convert->add_option("out", mesh_out, "Output mesh (.vtu, .vtk, .node/.ele, .msh)")->required();
  convert->callback([&] { exit_code = pliant::run_mesh_convert(mesh_file, mesh_out, std::cout); });

  pliant::ExperimentOptions experiment;
  double experiment_duration = 0.0;
  auto* experiment_cmd = app.add_subcommand(
      "experiment", "Run a paper experiment with both contact methods: series, plots, summary.json, report.md");
  experiment_cmd
      ->add_option("name", experiment.name, "three_cubes, sphere_squeeze, fruit_dish, membrane_stack or a scene file")
      ->required();
  experiment_cmd->add_option("--out", experiment.out, "Output folder")->capture_default_str();
  auto* experiment_duration_opt =
      experiment_cmd->add_option("--duration", experiment_duration, "Simulated time (s)")->check(CLI::PositiveNumber);
  experiment_cmd->add_flag("--quiet", experiment.quiet, "Print nothing on success");
  experiment_cmd->add_flag("--cpu-time", experiment.cpu_time,
                           "Time the stages in thread CPU time (a shared, loaded machine)");
  bool experiment_no_frames = false;
  experiment_cmd->add_flag("--no-frames", experiment_no_frames, "Write no side-by-side frames");
  experiment_cmd->add_option("--frame-rate", experiment.frame_rate, "Side-by-side frames per simulated second")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  int experiment_threads = 0;
  auto* experiment_threads_opt =
      experiment_cmd
          ->add_option("--threads", experiment_threads, "Threads the step runs on (overrides the scene's; time it by wall clock)")
          ->check(CLI::Range(1, 256));
  experiment_cmd->callback([&] {
    if (experiment_duration_opt->count() > 0) experiment.duration = experiment_duration;
    if (experiment_threads_opt->count() > 0) experiment.threads = experiment_threads;
    experiment.frames = !experiment_no_frames;
    exit_code = pliant::run_experiment(experiment, std::cout);
  });

  pliant::BenchOptions bench;
  std::string bench_contact;
  bool bench_no_variants = false;
  auto* bench_cmd = app.add_subcommand("bench", "Sizes and per-stage step times of every shipped scene");
  bench_cmd->add_option("scenes", bench.scenes, "Scene files or paper scene names (default: all shipped scenes)");
  bench_cmd->add_option("--json", bench.json, "Write the table as JSON");
  bench_cmd->add_option("--csv", bench.csv, "Write the table as CSV");
  bench_cmd->add_option("--steps", bench.steps, "Timed steps per scene")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  bench_cmd->add_option("--warm-up", bench.warm_up_steps, "Untimed steps first")->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  bench_cmd->add_option("--contact", bench_contact, "Contact method for every scene")
      ->check(CLI::IsMember({"surface", "penalty", "none"}));
  bench_cmd->add_flag("--no-variants", bench_no_variants, "No friction-off rows");
  bench_cmd->add_flag("--callgrind-timed", bench.callgrind_timed,
                     "Under valgrind --tool=callgrind --instr-atstart=no: count the timed steps only");
  bench_cmd->add_flag("--cpu-time", bench.cpu_time, "Time the stages in thread CPU time (a shared, loaded machine)");
  bench_cmd->add_option("--window", bench.window_steps,
                        "Also profile every K timed steps (stage p50s, awake bodies) against simulated time")
      ->check(CLI::NonNegativeNumber);
  int bench_threads = 0;
  auto* bench_threads_opt =
      bench_cmd->add_option("--threads", bench_threads, "Threads the step runs on (overrides the scenes'; time it by wall clock)")
          ->check(CLI::Range(1, 256));
  bool bench_no_rt = false;
  bench_cmd->add_flag("--haptic", bench.haptic,
                      "Haptic benchmark: physics back to back with the 1 kHz haptic thread beside it "
                      "(default scenes: probe, probe_5k)");
  bench_cmd->add_option("--seconds", bench.seconds, "Haptic benchmark: wall-clock seconds per scene")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  bench_cmd->add_flag("--no-rt-priority", bench_no_rt, "Haptic benchmark: do not ask SCHED_FIFO for the haptic thread");
  int bench_haptic_threads = 1;
  auto* bench_haptic_threads_opt =
      bench_cmd->add_option("--haptic-threads", bench_haptic_threads,
                            "Haptic benchmark: threads that wake for every tick, a CPU each (overrides the scenes' "
                            "\"haptics\" \"threads\")")
          ->check(CLI::Range(1, pliant::kMaxHapticThreads));
  bench_cmd->callback([&] {
    if (!bench_contact.empty()) bench.contact = bench_contact;
    bench.friction_variants = !bench_no_variants;
    bench.realtime_priority = !bench_no_rt;
    if (bench_haptic_threads_opt->count() > 0) bench.haptic_threads = bench_haptic_threads;
    if (bench_threads_opt->count() > 0) bench.threads = bench_threads;
    exit_code = pliant::run_bench(bench, std::cout);
  });

  pliant::TradeoffOptions tradeoff;
  auto* tradeoff_cmd = app.add_subcommand(
      "tradeoff", "Sweep binary-search iterations, CG iterations and dt against a reference: tradeoff.csv, Pareto plot");
  tradeoff_cmd->add_option("scene", tradeoff.scene, "Scene file (JSON)")->required();
  tradeoff_cmd->add_option("--out", tradeoff.out, "Output folder")->capture_default_str();
  tradeoff_cmd->add_option("--steps", tradeoff.steps, "Scene steps per run")->check(CLI::PositiveNumber)->capture_default_str();
  tradeoff_cmd->add_option("--binary-search", tradeoff.binary_search_iterations, "Binary-search iterations to try")
      ->check(CLI::Range(0, 30));
  tradeoff_cmd->add_option("--solver", tradeoff.solver_iterations, "CG iteration caps to try")->check(CLI::Range(1, 10000));
  tradeoff_cmd->add_option("--dt", tradeoff.dt_factors, "dt factors (times the scene's dt) to try")
      ->check(CLI::PositiveNumber);
  tradeoff_cmd->add_option("--resolution", tradeoff.resolution_factors,
                           "Cell-count factors for generated box/membrane meshes (1 alone: no resolution sweep)")
      ->check(CLI::Range(0.05, 8.0));
  tradeoff_cmd->add_option("--held-final-strain", tradeoff.held_final_strains,
                           "contact.held_linearised_final_strain values to try (default: the scene's)")
      ->check(CLI::NonNegativeNumber);
  tradeoff_cmd->add_flag("--quiet", tradeoff.quiet, "Print nothing on success");
  tradeoff_cmd->callback([&] { exit_code = pliant::run_tradeoff(tradeoff, std::cout); });

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  } catch (const pliant::InputError& e) {
    std::cerr << "pliant: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "pliant: runtime failure: " << e.what() << "\n";
    return 1;
  }
  return exit_code;
}
