// The sleeping-body rules of World::step (criterion and wake rules: sim/sleep/sleep_settings.h).
// Each function is one place in the step: pair filtering before detection, waking after it,
// falling asleep after the report.
// Opt-in wake rule (session 12, SleepSettings::wake_on_centre_motion): a deformable body is a
// mover only when its centre of mass has moved more than the ball's radius since it last woke its
// neighbours. In the full dish the ball exits are fruits turning and changing shape in place (the
// centre had moved 0.56 mm, median, when a vertex left the 2 mm ball), half of them by fruits just
// woken by such an exit, so waking on any vertex kept 80-110 of 138 fruits awake; waking on the
// centre lets the pile sleep (docs/experiments.md "Session 12").
// Opt-in rest rule (session 14, SleepSettings::rest_by_centre_when_supported): a body supported
// only by things that do not move on their own (sleepers, fixtures, clamped bodies) rests by its
// centre of mass instead of by every vertex. In the membrane stack the clamped membrane0 and
// membrane1 churn against each other under the sleeping membranes 2-8 (surface vertices sliding
// 5-16 mm within 0.2 s while the centres creep ~0.1 mm: session 13's frames), so the vertex rule
// never lets them sleep, and membrane1's creep eventually wakes the stack above. With the rule
// membrane1 (on clamped membrane0, under sleeping membrane2) sleeps by its centre, then membrane0
// (touching only a sleeper) does. The price: such a body is frozen wherever its vertices are in
// the churn, so freezing may move a vertex by more than the ball's radius (the vertex rule's
// promise holds for its centre only). Clamped partners count as support though they are awake:
// their fixed vertices hold them to the world.
#pragma once

#include <span>
#include <vector>

#include "sim/body.h"
#include "sim/collision/contact_types.h"
#include "sim/sleep/sleep_settings.h"
#include "sim/step_report.h"

namespace pliant {

/// Disallows pairs (and self pairs) between bodies that do not move this step: sleeping
/// deformable bodies and kinematic bodies that kept their pose (not instruments). Indices are body
/// slots.
void filter_resting_pairs(std::span<Body* const> bodies, CollisionFilter& filter);

/// Whether no body can set another in motion this step: every one is resting in the sense of
/// filter_resting_pairs (asleep, or kinematic, still and not an instrument), so that filter
/// disallows every pair and detection has nothing to find.
bool nothing_moves(std::span<Body* const> bodies);

/// Marks each deformable body an instrument touches this step (SleepState::instrument_contact):
/// a vertex-in-tet pair in `colliding` between it and an instrument, or a contact in `held` (the
/// contacts of the last step that still hold a force) between them. Returns the number marked.
int note_instrument_contacts(std::span<Body* const> bodies, const std::vector<VertexInTet>& colliding,
                             std::span<const VertexContact> held);

/// Wakes every sleeping body that a moving body touches in `colliding` (a kinematic body that
/// moved this step, any instrument, or an awake deformable body that left its rest ball in its
/// last step), and every sleeping body whose bounding box comes within settings.wake_margin of an
/// awake deformable body that left its rest ball (not transitively: a woken body keeps its anchor
/// and is no mover until it leaves its own ball). With settings.wake_on_centre_motion a deformable
/// body is a mover only when its centre of mass left its wake ball (SleepState::centre_moved).
/// Returns the number of bodies woken.
int wake_touched_bodies(std::span<Body* const> bodies, const std::vector<VertexInTet>& colliding,
                        const SleepSettings& settings);

/// Sets SleepState::supported on each awake deformable body (rest_by_centre_when_supported): true
/// when the body is clamped (a fixed vertex) or has a partner in `colliding` or `held` (the last
/// step's contacts that still hold a force), and every such partner is asleep, a fixture (kinematic,
/// not an instrument) or clamped. Self contacts are ignored. Returns the number supported.
int note_supported_bodies(std::span<Body* const> bodies, const std::vector<VertexInTet>& colliding,
                          std::span<const VertexContact> held);

/// Wakes one body now (velocities stay zero; it is integrated from the next step on). Its rest
/// anchor is kept: it rests where it slept until it leaves that ball.
void wake_body(Body& body);

/// After a step of dt (s): checks each awake deformable body against its rest ball
/// (sleep_settings.h), advancing its rest time or restarting the rest with a new anchor, and puts
/// bodies to sleep (velocities set to zero) once the rest time reaches settings.time. A body an
/// instrument touches (note_instrument_contacts) keeps its rest time at zero. With
/// settings.rest_by_centre_when_supported a supported body (note_supported_bodies) stays in its
/// rest ball while its centre of mass stays within the radius of the anchor's centre.
/// `body_energy` is this step's report per slot; its elastic energy is kept for the reports while
/// the body sleeps (`has_energy`: whether it was computed). Returns the number of bodies asleep.
int update_sleep(std::span<Body* const> bodies, double dt, const SleepSettings& settings,
                 std::span<const EnergyReport> body_energy, bool has_energy);

}  // namespace pliant
