// Sleeping bodies (DESIGN.md "Model only what the scene requires"; docs/experiments.md
// "Sleeping bodies"). A deformable body whose every vertex moves slower than `speed` (m/s) for
// `time` (s) of simulated time in a row falls asleep: its velocities are set to zero and from then
// on it is not integrated, and pairs between it and other bodies that do not move (sleeping
// bodies, kinematic bodies that keep their pose) are not detected. Its state stays bit-identical
// while it sleeps. A sleeping body counts as immovable in contact (like a fixed support), and it
// wakes, within the same step, when a moving body touches it: a kinematic body that moved this
// step (an instrument), or an awake deformable body with a vertex faster than `speed`. Waking
// spreads to sleeping bodies whose bounding boxes overlap a woken one (a pile wakes together).
#pragma once

namespace pliant {

/// When bodies fall asleep; off by default in the library (scenes turn it on, see scene-format).
struct SleepSettings {
  bool enabled = false;
  double speed = 0.005;  ///< m/s, a body is at rest while its fastest vertex is slower than this
  double time = 0.2;     ///< s of simulated time at rest before the body falls asleep
  double wake_margin = 0.002;  ///< m, bounding boxes this close count as touching when waking spreads
};

/// A deformable body's sleep bookkeeping (kept in Body).
struct SleepState {
  bool sleeping = false;
  double rest_time = 0.0;      ///< s spent at rest so far (reset when the body moves or wakes)
  double elastic_energy = 0.0; ///< J, the body's elastic energy when it fell asleep (positions frozen)
  bool has_elastic_energy = false;
};

}  // namespace pliant
