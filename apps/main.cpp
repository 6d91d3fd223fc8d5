// The `pliant` command line: wires scene and mesh files to sim, interaction and render.
// Exit codes: 0 success, 1 runtime failure, 2 bad input (file, scene, script or flag).
#include <CLI/CLI.hpp>
#include <iostream>

#include "apps/mesh_command.h"
#include "apps/run_command.h"
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
  run_cmd->add_flag("--quiet", run.quiet, "Print nothing on success");
  run_cmd->callback([&] {
    if (!contact.empty()) run.contact = contact;
    if (iterations >= 0) run.binary_search_iterations = iterations;
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
