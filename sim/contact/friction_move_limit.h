// How far stage 5's friction may move a vertex (docs/stability.md, M6).
//
// Design note. The friction impulse changes a vertex's velocity by dv and also moves it by dt dv
// (docs/contact-surface.md, "Coulomb friction": the position was integrated with the old velocity).
// Moving one vertex alone by u along d stores k u^2 / 2 of elastic energy, k = d^T K_vv d its own
// stiffness (the diagonal block of the stiffness matrix: every other vertex held), while the
// impulse takes out only m dv^2 / 2 of kinetic energy. Where omega dt = sqrt(k / m) dt > 1 (a
// light vertex, or a stiff one such as a sliver tet's apex) the full move stores more than the
// impulse removes: energy out of nothing. With the limit on the move is scaled by
// min(1, 1 / (omega dt)), so it stores at most what the impulse removes; the velocity change is
// untouched. It is an experiment, off in every caller (apply_contact_velocity_update's
// limit_friction_move): a sticking stiff block's vertices move together, which stores nothing, and
// with the limit the block creeps down an incline.
#pragma once

#include "sim/body.h"

namespace pliant {

/// Stiffness (N/m) a vertex feels when it alone moves along the unit `direction`, all others held:
/// d^T K_vv d = sum over its tets of V (mu |g|^2 + (lambda + mu) (g . d)^2), g = grad N (linear
/// elasticity in the rest frame: element rotations are not applied to d).
double vertex_stiffness_along(const Body& body, int vertex, const Vec3& direction);

/// Factor in (0, 1] on friction's positional move dt dv of `vertex` along the unit `direction`:
/// min(1, 1 / (omega dt)), omega = sqrt(k / m), k = vertex_stiffness_along; 1 if immovable.
double friction_move_scale(const Body& body, int vertex, const Vec3& direction, double dt);

}  // namespace pliant
