// `pliant tradeoff SCENE --out DIR [--steps N]`: the speed-accuracy trade (issue 8, item 4). Sweeps
// binary-search iterations, solver (CG) iterations, dt, mesh resolution and (session 21, on request)
// the held final evaluation's strain gate, measures each setting against a
// reference run at the highest settings, and writes DIR/tradeoff.csv and DIR/tradeoff.png
// (Pareto plot via scripts/plot_tradeoff.sh). Metrics and choices: docs/tradeoff.md.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace pliant {

struct TradeoffOptions {
  std::string scene;
  std::string out = "tradeoff";
  long steps = 600;  ///< scene steps (at the scene's dt); other dt run the same simulated time
  std::vector<int> binary_search_iterations{1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  std::vector<int> solver_iterations{5, 10, 20, 40};
  std::vector<double> dt_factors{0.5, 1.0, 2.0};  ///< times the scene's dt
  /// Cell-count factors for the scene's generated box and membrane meshes (1 = as in the scene);
  /// run at the scene's default settings against a reference at the largest factor.
  std::vector<double> resolution_factors{0.5, 1.0, 2.0};
  /// contact.held_linearised_final_strain values to try (session 21; docs/contact-surface.md
  /// "Response time, session 21"); empty: the scene's own value only. The reference takes the
  /// smallest (0: the exact final evaluation).
  std::vector<double> held_final_strains;
  bool plot = true;   ///< run scripts/plot_tradeoff.sh when gnuplot is available
  bool quiet = false;
};

/// Runs the sweep. Returns 0 on success, 1 if the reference run fails. Bad input throws InputError.
int run_tradeoff(const TradeoffOptions& options, std::ostream& log);

}  // namespace pliant
