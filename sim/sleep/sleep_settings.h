// Sleeping bodies (DESIGN.md "Model only what the scene requires"; docs/experiments.md
// "Resting motion" and "Sleeping bodies"). A deformable body is at rest while no vertex has moved
// farther than `speed` x `time` (the rest ball, 1 mm by default) from where it was when the rest
// began: over `time` it moved slower than `speed` on average, read from its positions. Leaving the
// ball restarts the rest there (a new anchor). Why positions, not the stored velocities: resting
// on the contact surface, contact vertices carry stored velocities of 5-70 mm/s (fruits in the
// dish) to 130 mm/s (the heavy cube) that do not move them (each step's response puts them back:
// the vertices jitter by tenths of a millimetre around a fixed place), while a fastest-vertex speed
// threshold cannot tell that from motion. Freezing a body moves none of its states of the last
// `time` seconds by more than the ball's radius. A body at rest for `time` (s) of simulated time
// falls asleep: its velocities are set to zero and from then on it is not integrated, and pairs
// between it and other bodies that do not move (sleeping bodies, kinematic bodies that keep their
// pose) are not detected. Its state stays bit-identical while it sleeps. A sleeping body counts as
// immovable in contact (like a fixed support), and it wakes, within the same step, when a moving
// body touches it: a kinematic body that moved this step (an instrument), or an awake deformable
// body that left its rest ball in its last step (or has just been created). Such a deformable body
// also wakes the sleepers whose bounding boxes come within `wake_margin` of its own, touching or
// not (a body lying on one that moves away must not hover). Waking does not pass on: a woken body
// keeps its rest anchor (it has not moved) and wakes its own neighbours only once it leaves that
// ball (session 5; before, waking spread at once through every overlapping box, so in the fruit
// dish one moving fruit woke the whole pile: docs/experiments.md "Session 5").
// Instruments (kinematic bodies flagged Body::instrument: the scene's tools, not its fixtures,
// floors or dishes) are different: a body an instrument touches (a colliding vertex either way
// this step, or a contact of the last step that still holds a force) does not rest, so it never
// falls asleep under an instrument that stands still (a probe holding a dent: the tissue keeps
// answering with the reaction force), and it wakes if it sleeps; pairs with an instrument are never
// filtered as resting. A kinematic fixture still lets bodies fall asleep on it.
#pragma once

#include <vector>

#include "sim/math_types.h"

namespace pliant {

/// When bodies fall asleep; off by default in the library (scenes turn it on, see scene-format).
struct SleepSettings {
  bool enabled = false;
  double speed = 0.005;  ///< m/s, at rest: slower than this on average over `time` (every vertex)
  double time = 0.2;     ///< s of simulated time at rest before the body falls asleep
  /// m, the rest ball's radius: how far a vertex may move from the rest's anchor.
  double rest_distance() const { return speed * time; }
  double wake_margin = 0.002;  ///< m, a moving body wakes sleepers whose bounding boxes are this close to its own
  /// Which motion of an awake deformable body wakes the sleepers it touches or comes near
  /// (session 12, opt-in; docs/experiments.md "Session 12"): false (default), leaving its rest
  /// ball with any vertex; true, its centre of mass moving farther than the rest ball's radius
  /// from where it was when it last woke its neighbours (or was created). A body turning or
  /// changing shape in place then wakes nobody; it still cannot fall asleep itself.
  bool wake_on_centre_motion = false;
  /// Session 14, opt-in (docs/experiments.md "Session 14"): false (default), every awake body rests
  /// while each vertex stays in its rest ball; true, a supported body (SleepState::supported: it is
  /// clamped or touches something, and everything it touches is asleep, a fixture or clamped) rests
  /// while its centre of mass stays within the ball's radius of the anchor's, whatever its vertices
  /// do. Lets the clamped bottom of a stack, which churns under sleepers, fall asleep.
  bool rest_by_centre_when_supported = false;
};

/// A deformable body's sleep bookkeeping (kept in Body).
struct SleepState {
  bool sleeping = false;
  bool resting = false;        ///< still inside its rest ball after the last step (rest_time > 0)
  double rest_time = 0.0;      ///< s spent at rest so far (reset when the body moves or wakes)
  std::vector<Vec3> rest_anchor;  ///< m, positions when the rest began (empty: not at rest)
  double elastic_energy = 0.0; ///< J, the body's elastic energy when it fell asleep (positions frozen)
  bool has_elastic_energy = false;
  bool instrument_contact = false;  ///< an instrument touches the body this step (never rests)
  Vec3 box_lo = Vec3::Zero();  ///< m, bounding box of the positions it fell asleep at (valid while asleep)
  Vec3 box_hi = Vec3::Zero();  ///< m
  /// m, centre of mass when it last woke its neighbours or was created (wake_on_centre_motion).
  Vec3 wake_centre = Vec3::Zero();
  bool has_wake_centre = false;
  bool centre_moved = false;   ///< its centre left the ball around wake_centre in its last step
  /// Session 13: the kinetic and gravitational energy of the frozen state, computed by the first
  /// report after the body fell asleep and reused while it sleeps (World::body_energy), with the
  /// gravity they were computed for; cleared when it wakes. Nothing moves a sleeper (every contact
  /// response treats it as immovable, Body::is_immovable), so the sums are the same bits each step.
  bool has_frozen_energy = false;
  double frozen_kinetic_energy = 0.0;        ///< J
  double frozen_gravitational_energy = 0.0;  ///< J, relative to the body's initial positions
  Vec3 frozen_energy_gravity = Vec3::Zero(); ///< m/s^2, the world's gravity when they were computed
  /// Session 14 (rest_by_centre_when_supported): in this step's contacts the body is clamped or
  /// touches something, and every body it touches is asleep, a fixture (kinematic, not an
  /// instrument) or clamped (has a fixed vertex). Set by note_supported_bodies.
  bool supported = false;
};

}  // namespace pliant
