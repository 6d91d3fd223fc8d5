// Stage 5 of the contact-surface method (paper section 4.5): after the vertices are displaced onto
// the contact surface, update velocities so that no energy is injected, and apply Coulomb friction
// between each colliding vertex and its contact triangle.
//
// Per contact (vertex x against the point p = sum b_k y_k of its contact triangle, normal n of
// that triangle), one Gauss-Seidel pass:
//   normal:   if the relative normal velocity vn = (v_x - v_p).n < 0, remove it with an inelastic
//             impulse J = -vn / (1/m_x + 1/m_p), m_p = 1 / sum(b_k^2 / m_k) (immovable: 1/m = 0);
//   friction: reduce the tangential relative velocity by at most mu J / m_eff (Coulomb cone),
//             mu = sqrt(mu_M mu_N); the friction impulse also moves the vertex by h dv, so a
//             sticking vertex does not creep (its position was integrated with the old velocity).
// Removing relative velocity with equal and opposite impulses never adds kinetic energy.
#pragma once

#include <span>

#include "sim/body.h"
#include "sim/collision/contact_types.h"
#include "sim/step_report.h"

namespace pliant {

/// Per-contact impulses from the velocity update (N s), for force reporting.
struct ContactImpulse {
  Vec3 normal = Vec3::Zero();    ///< on the colliding vertex's body
  Vec3 friction = Vec3::Zero();  ///< on the colliding vertex's body
};

/// Applies the normal velocity update and (if `friction`) Coulomb friction for every contact.
/// `impulses` gets one entry per contact.
void apply_contact_velocity_update(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
                                   double dt, bool friction, std::vector<ContactImpulse>& impulses);

}  // namespace pliant
