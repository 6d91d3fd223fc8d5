// `pliant experiment NAME --out DIR`: one of the paper's four experiments (Spillmann & Teschner,
// Sec. 5: three_cubes, sphere_squeeze, fruit_dish, membrane_stack) run with both contact methods,
// the contact surface and the penalty baseline, from the same scene file. Writes
// DIR/<method>/steps.csv, DIR/frames/frame_NNNNNN.png (both methods side by side), DIR/energy.png (kinetic and potential energy in % of the initial
// energy, as the paper's Fig. 10), DIR/penetration.png, DIR/summary.json and DIR/report.md with
// the measured timings beside the paper's. Choices: docs/experiments.md.
#pragma once

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>

namespace pliant {

struct ExperimentOptions {
  std::string name;                ///< a scene in assets/scenes/paper/ (stem) or a scene file
  std::string out = "out";         ///< output folder
  std::optional<double> duration;  ///< s, overrides the scene's duration
  bool quiet = false;
  bool frames = true;              ///< side-by-side PNGs in DIR/frames (when the renderer is built)
  double frame_rate = 30.0;        ///< frames per simulated second
  bool cpu_time = false;           ///< stage times in thread CPU time, not wall time (loaded machine)
  std::optional<int> threads;      ///< override the scene's "threads" (>= 1; docs/threads.md)
};

/// Runs the experiment. Returns 0 on success, 1 if a method met a step it could not recover
/// (its series stop there; everything is still written). Bad input throws InputError.
int run_experiment(const ExperimentOptions& options, std::ostream& log);

/// The shipped `assets/scenes` folder: looked for under the working directory and then above
/// the running executable (so build/apps/pliant finds the source tree). Empty if not found.
std::filesystem::path find_scene_folder();

/// A scene given by file path, or by stem under assets/scenes/paper/ or assets/scenes/.
/// Throws InputError (kind io) naming what was tried.
std::filesystem::path resolve_scene(const std::string& name_or_path);

}  // namespace pliant
