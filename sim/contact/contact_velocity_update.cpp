#include "sim/contact/contact_velocity_update.h"

#include <algorithm>
#include <cmath>

namespace pliant {
namespace {

double inverse_mass(const Body& body, int v) {
  return body.is_immovable(v) ? 0.0 : 1.0 / body.masses[static_cast<size_t>(v)];
}

}  // namespace

void apply_contact_velocity_update(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
                                   double dt, bool friction, std::span<const double> held_normal_impulse,
                                   size_t lingering_begin, std::vector<ContactImpulse>& impulses) {
  impulses.assign(contacts.size(), ContactImpulse{});
  for (size_t c = 0; c < contacts.size(); ++c) {
    const VertexContact& contact = contacts[c];
    Body& m = *bodies[static_cast<size_t>(contact.body)];
    Body& n = *bodies[static_cast<size_t>(contact.penetrated_body)];
    const auto& tri = n.mesh->surface_triangles()[static_cast<size_t>(contact.contact_triangle)];
    const Vec3& b = contact.contact_barycentric;

    Vec3 normal = n.mesh->triangle_normal(n.positions, contact.contact_triangle);
    if (normal.squaredNorm() == 0.0) normal = contact.penetration_direction;
    if (normal.squaredNorm() == 0.0) continue;

    const double w_x = inverse_mass(m, contact.vertex);
    double w_p = 0.0;
    Vec3 v_p = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      const int y = tri[static_cast<size_t>(k)];
      w_p += b[k] * b[k] * inverse_mass(n, y);
      v_p += b[k] * n.velocities[static_cast<size_t>(y)];
    }
    const double w_sum = w_x + w_p;
    if (w_sum <= 0.0) continue;  // both sides immovable

    // Applies impulse j (on x; -j spread over the triangle) and moves positions by h dv if asked.
    auto apply = [&](const Vec3& j, bool move_positions) {
      if (w_x > 0.0) {
        const Vec3 dv = w_x * j;
        m.velocities[static_cast<size_t>(contact.vertex)] += dv;
        if (move_positions) m.positions[static_cast<size_t>(contact.vertex)] += dt * dv;
      }
      for (int k = 0; k < 3; ++k) {
        const int y = tri[static_cast<size_t>(k)];
        const double wy = inverse_mass(n, y);
        if (wy == 0.0 || b[k] == 0.0) continue;
        // Distribute so the contact point's velocity changes by -w_p j (minimum-norm split).
        const Vec3 dv = -b[k] * wy * j;
        n.velocities[static_cast<size_t>(y)] += dv;
        if (move_positions) n.positions[static_cast<size_t>(y)] += dt * dv;
      }
    };

    const Vec3 v_rel = m.velocities[static_cast<size_t>(contact.vertex)] - v_p;
    const double vn = v_rel.dot(normal);
    const double held = held_normal_impulse.empty() ? 0.0 : held_normal_impulse[c];
    double normal_impulse = std::max(0.0, held - vn / w_sum);  // total, never adhesive
    if (c >= lingering_begin) normal_impulse = std::min(normal_impulse, held);  // no push at a distance
    if (normal_impulse != held) apply((normal_impulse - held) * normal, false);
    impulses[c].normal = normal_impulse * normal;
    impulses[c].normal_magnitude = normal_impulse;
    if (!friction) continue;
    const double mu = std::sqrt(m.material.friction * n.material.friction);
    if (mu <= 0.0 || normal_impulse <= 0.0) continue;
    const Vec3 v_t = v_rel - vn * normal;
    const double speed = v_t.norm();
    if (speed <= 0.0) continue;
    const double stick_impulse = speed / w_sum;
    const double jt = std::min(stick_impulse, mu * normal_impulse);
    const Vec3 j = -jt * (v_t / speed);
    apply(j, true);
    impulses[c].friction = j;
  }
}

}  // namespace pliant
