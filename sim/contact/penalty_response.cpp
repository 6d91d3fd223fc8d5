#include "sim/contact/penalty_response.h"

#include <algorithm>
#include <map>

namespace pliant {
namespace {

// Adds a force to a vertex of a deformable body as an impulse over dt (symplectic: the position
// moves with the new velocity, as if the force had been part of the integration).
void apply_force(Body& body, int v, const Vec3& f, double dt) {
  if (body.is_immovable(v)) return;
  const auto i = static_cast<size_t>(v);
  const Vec3 dv = dt * f / body.masses[i];
  body.velocities[i] += dv;
  body.positions[i] += dt * dv;
}

}  // namespace

void PenaltyResponse::respond(std::span<Body* const> bodies, std::span<const VertexContact> contacts, double dt,
                              const ContactSettings& settings, StepReport& report) {
  std::map<std::pair<int, int>, PairContactForce> pairs;
  for (const auto& c : contacts) {
    Body& m = *bodies[static_cast<size_t>(c.body)];
    Body& n = *bodies[static_cast<size_t>(c.penetrated_body)];
    const auto& tri = n.mesh->surface_triangles()[static_cast<size_t>(c.contact_triangle)];
    const Vec3& r = c.penetration_direction;

    // Relative velocity of the vertex against the contact point.
    Vec3 v_contact = Vec3::Zero();
    for (int k = 0; k < 3; ++k) v_contact += c.contact_barycentric[k] * n.velocities[static_cast<size_t>(tri[static_cast<size_t>(k)])];
    const Vec3 v_rel = m.velocities[static_cast<size_t>(c.vertex)] - v_contact;
    const double v_normal = v_rel.dot(r);

    Vec3 f = settings.penalty_stiffness * c.penetration_depth * r;
    if (settings.penalty_damping > 0.0 && v_normal < 0.0) f -= settings.penalty_damping * v_normal * r;
    const double mu = std::max(m.material.friction, n.material.friction);
    if (settings.friction && mu > 0.0) {
      const Vec3 v_t = v_rel - v_normal * r;
      const double speed = v_t.norm();
      if (speed > 1e-12) f -= mu * f.norm() * v_t / speed;
    }

    // f on the vertex, -f spread over the contact triangle.
    apply_force(m, c.vertex, f, dt);
    for (int k = 0; k < 3; ++k) {
      const double w = c.contact_barycentric[k];
      apply_force(n, tri[static_cast<size_t>(k)], -w * f, dt);
    }
    // A penalty force does not remove the overlap it sees; it pushes during the next steps, and
    // at rest the overlap is the spring's static deflection. So the overlap left is the depth.
    report.max_residual_overlap = std::max(report.max_residual_overlap, c.penetration_depth);
    report.total_contact_force += f.norm();

    // Reactions on kinematic bodies (the force the tissue exerts on the instrument).
    for (auto& reaction : report.reactions) {
      const Body& k = *bodies[static_cast<size_t>(reaction.body)];
      if (reaction.body == c.penetrated_body) {
        reaction.force += -f;
        reaction.torque += (c.contact_point - k.pose.translation).cross(-f);
      } else if (reaction.body == c.body) {
        reaction.force += f;
        reaction.torque += (m.positions[static_cast<size_t>(c.vertex)] - k.pose.translation).cross(f);
      }
    }
    const int a = std::min(c.body, c.penetrated_body);
    const int b = std::max(c.body, c.penetrated_body);
    auto& pair = pairs[{a, b}];
    pair.body_a = a;
    pair.body_b = b;
    pair.force_on_a += (a == c.body) ? f : Vec3(-f);
    pair.force_on_b += (a == c.body) ? Vec3(-f) : f;
    pair.contacts++;
  }
  for (auto& [key, pair] : pairs) report.pair_forces.push_back(pair);
}

}  // namespace pliant
