// The held force's strength between two deformable bodies, derived from their contact mode
// (session 10, issue #8; docs/contact-surface.md "Resting churn, session 10").
//
// Design note. The held force is last step's contact force f_n acting through this step's implicit
// integration as an external force: for the contact mode (a spring k between the two bodies,
// reduced mass m, omega^2 = k / m) it is explicit, one step late, while stage 5 supplies the rest of
// the load at the step's end as an inelastic impulse. The trapezoidal rule, which conserves a linear
// spring's energy (injects and removes nothing per cycle), applies over a step that starts from the
// relative normal velocity stage 5 leaves (zero) the mean force
//     F = f_n / (1 + (omega dt / 2)^2) + W (omega dt / 2)^2 / (1 + (omega dt / 2)^2),
// W the load the contact carries (gravity's share). The first term depends on the state the step
// starts from and is what may be held; the second is the share of the load the step's own motion
// supplies, which stage 5 gives at the step's end. Held fraction 1 / (1 + (omega dt / 2)^2): 1 for a
// slow contact (omega dt -> 0, the session-4 default), 0.8 at omega dt = 1 (session 9's measured
// optimum of the stacked blocks, whose contact mode is at omega dt ~ 1). Backward Euler gives
// 1 / (1 + (omega dt)^2) the same way, and dissipates; session 9 measured 0.5 as worse.
// The contact mode: each body's bounce stiffness along the contact normal n, k_b = E_b V_b / L_b^2
// (its rest volume compressed uniaxially over its current extent L_b along n: E A / L for a column),
// the two in series; m the reduced mass of the bodies' translations, a body with fixed vertices
// counting as immovable (its centre does not move; where both have fixed vertices, nothing says:
// the reduced mass of the two bodies' masses).
#pragma once

#include "sim/body.h"

namespace pliant {

/// 1 / (1 + (omega dt / 2)^2): the part of a contact spring's start-of-step force that a trapezoidal
/// step applies from relative rest (omega dt >= 0, dimensionless).
double held_fraction_for_contact_mode(double omega_dt);

/// A body's bounce stiffness (N/m) along the unit `normal`: E V / L^2, V its rest volume, L the
/// extent of its current positions along `normal`.
double bounce_stiffness_along(const Body& body, const Vec3& normal);

/// The angular frequency (rad/s) of the contact mode of two bodies touching along the unit
/// `normal`: sqrt(k / m), k their bounce stiffnesses in series, m the reduced mass of their
/// translations (bodies with fixed vertices immovable unless both have them).
double contact_mode_omega(const Body& a, const Body& b, const Vec3& normal);

}  // namespace pliant
