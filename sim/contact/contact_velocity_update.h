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
// Warm start (held contact forces, docs/contact-surface.md): when the contact's normal force of
// the last step already acted through this step's integration as the impulse J_held, the update
// computes the total normal impulse J = max(0, J_held + dJ) with dJ = -vn / (1/m_x + 1/m_p) and
// applies only J - J_held: it may take back (part of) the held impulse where the contact separates,
// never more than it (no adhesion). The friction cone uses the total J.
#pragma once

#include <span>
#include <vector>

#include <Eigen/Dense>

#include "sim/body.h"
#include "sim/collision/contact_types.h"
#include "sim/contact/friction_move_limit.h"
#include "sim/step_report.h"

namespace pliant {

/// Per-contact impulses of the step (N s), for force reporting and the warm start.
struct ContactImpulse {
  Vec3 normal = Vec3::Zero();    ///< on the colliding vertex's body, total (held plus correction)
  Vec3 friction = Vec3::Zero();  ///< on the colliding vertex's body
  double normal_magnitude = 0.0; ///< |normal| (N s), >= 0
};

/// Rigid modes of a free body (no fixed vertex, not kinematic or sleeping): lumped mass (kg), centre
/// and inverse inertia about it, and the rigid velocity change the take-backs accumulated in a pass.
struct RigidModes {
  bool ready = false, free = false;
  double mass = 0.0;
  Vec3 centre = Vec3::Zero();
  Eigen::Matrix3d inverse_inertia = Eigen::Matrix3d::Zero();
  Vec3 dv = Vec3::Zero(), domega = Vec3::Zero();
  /// Fills mass, centre and inverse inertia from the body's current positions (once per pass).
  void prepare(const Body& body);
  Vec3 velocity_at(const Vec3& x) const { return dv + domega.cross(x - centre); }
  double inverse_mass_at(const Vec3& x, const Vec3& n) const {
    const Vec3 rn = (x - centre).cross(n);
    return 1.0 / mass + rn.dot(inverse_inertia * rn);
  }
  void apply(const Vec3& x, const Vec3& j) {
    dv += j / mass;
    domega += inverse_inertia * (x - centre).cross(j);
  }
};


/// Applies the normal velocity update and (if `friction`) Coulomb friction for every contact.
/// `held_normal_impulse` (N s, one per contact, or empty for none) is the normal impulse that the
/// held contact force already applied in this step's integration. Contacts from index
/// `lingering_begin` on are held contacts that detection did not find again: their normal impulse
/// may only shrink (take back the held one), never grow. `impulses` gets one entry per contact;
/// `rigid_scratch` is working storage reused across calls. With `friction_moves`
/// (ContactSettings::limit_friction_move) a body's friction moves dt dv are recorded there and their
/// deforming part scaled by friction_move_scale so it stores at most the kinetic energy of the
/// body's friction impulses (docs/stability.md M6a); null: every move is dt dv (session 6's stage
/// 5, bit for bit). With `anchored_friction_compliance` (ContactSettings, docs/stability.md M7) a
/// friction impulse between two movable sides sees a vertex of a body with fixed vertices that is
/// stiff within the step (omega dt > 1) with its quasi-static compliance 1 / (k dt^2).
void apply_contact_velocity_update(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
                                   double dt, bool friction, std::span<const double> held_normal_impulse,
                                   size_t lingering_begin, std::vector<ContactImpulse>& impulses,
                                   std::vector<RigidModes>& rigid_scratch, FrictionMoveLedger* friction_moves = nullptr,
                                   bool anchored_friction_compliance = false);

}  // namespace pliant
