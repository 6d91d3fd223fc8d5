#include "sim/contact/implicit_contact_correction.h"

#include <algorithm>

namespace pliant {
namespace {

// A body whose step can be re-solved with constraints: awake, deformable, corotational FEM.
bool resolvable(const Body* body) {
  return body != nullptr && !body->is_kinematic() && !body->is_sleeping() && body->model &&
         body->model->kind() == ModelKind::corotational_fem;
}

}  // namespace

void ImplicitContactCorrection::add_constraint(std::span<Body* const> bodies, int body, int vertex,
                                               const Vec3& push, int partner, bool stiff) {
  const auto b = static_cast<size_t>(body);
  const auto v = static_cast<size_t>(vertex);
  if (!resolvable(bodies[b]) || bodies[b]->fixed[v] != 0) return;
  BodyConstraints& c = per_body_[b];
  if (!stiff) c.free_partner = true;
  if (!c.active) {
    const size_t n = bodies[b]->positions.size();
    c.active = true;
    c.normal.assign(n, Vec3::Zero());
    c.partner.assign(n, -1);
    c.normal_velocity.assign(n, 0.0);
    c.force.assign(n, Vec3::Zero());
  }
  c.normal[v] += push;
  if (c.partner[v] < 0) c.partner[v] = partner;
}

void ImplicitContactCorrection::correct(std::span<Body* const> bodies,
                                        std::span<const VertexContact> contacts,
                                        std::span<const VertexContact> held_contacts,
                                        std::span<const std::vector<Vec3>> start_positions,
                                        std::span<const std::vector<Vec3>> start_velocities,
                                        const Vec3& gravity, double dt, ImplicitCorrection scope,
                                        StepReport& report) {
  per_body_.resize(bodies.size());
  for (auto& c : per_body_) c.active = c.free_partner = false;
  corrected_bodies_ = 0;
  if (scope == ImplicitCorrection::off) return;

  // Push directions: the contact triangle's outward normal at the displaced positions pushes the
  // colliding vertex out of the penetrated body, and the triangle's vertices the other way.
  for (const auto& contact : contacts) {
    const Body* penetrated = bodies[static_cast<size_t>(contact.penetrated_body)];
    if (penetrated == nullptr || contact.contact_triangle < 0) continue;
    Vec3 n = penetrated->mesh->triangle_normal(penetrated->positions, contact.contact_triangle);
    if (n.isZero()) n = contact.penetration_direction;
    if (n.isZero()) continue;
    const auto& tri = penetrated->mesh->surface_triangles()[static_cast<size_t>(contact.contact_triangle)];
    // Immovable partners (the response gives the soft side the whole displacement there).
    const bool triangle_stiff = penetrated->is_immovable(tri[0]) && penetrated->is_immovable(tri[1]) &&
                                penetrated->is_immovable(tri[2]);
    const bool vertex_stiff = bodies[static_cast<size_t>(contact.body)]->is_immovable(contact.vertex);
    add_constraint(bodies, contact.body, contact.vertex, n, contact.penetrated_body, triangle_stiff);
    for (int k = 0; k < 3; ++k) {
      if (contact.contact_barycentric[k] <= 0.0) continue;  // the search did not move it
      add_constraint(bodies, contact.penetrated_body, tri[static_cast<size_t>(k)], -n, contact.body,
                     vertex_stiff);
    }
  }
  // Scoped: a body with a free-free contact, detected or held, keeps the paper's response (its
  // state is untouched).
  if (scope == ImplicitCorrection::stiff_partners) {
    for (const auto& contact : held_contacts) {
      const Body* penetrated = bodies[static_cast<size_t>(contact.penetrated_body)];
      const Body* colliding = bodies[static_cast<size_t>(contact.body)];
      if (penetrated == nullptr || colliding == nullptr || contact.contact_triangle < 0) continue;
      const auto& tri = penetrated->mesh->surface_triangles()[static_cast<size_t>(contact.contact_triangle)];
      if (!(penetrated->is_immovable(tri[0]) && penetrated->is_immovable(tri[1]) &&
            penetrated->is_immovable(tri[2]))) {
        per_body_[static_cast<size_t>(contact.body)].free_partner = true;
      }
      if (!colliding->is_immovable(contact.vertex)) {
        per_body_[static_cast<size_t>(contact.penetrated_body)].free_partner = true;
      }
    }
    for (auto& c : per_body_) {
      if (c.free_partner) c.active = false;
    }
  }

  // Re-solve each body from the start of the step; prescribed v_{n+1} . n = (x_target - x_n) . n / h.
  for (size_t b = 0; b < bodies.size(); ++b) {
    BodyConstraints& c = per_body_[b];
    if (!c.active) continue;
    Body& body = *bodies[b];
    const auto& x0 = start_positions[b];
    const auto& v0 = start_velocities[b];
    const size_t n = body.positions.size();
    for (size_t i = 0; i < n; ++i) {
      const double length = c.normal[i].norm();
      if (length < 1e-12) {
        c.normal[i].setZero();
        continue;
      }
      c.normal[i] /= length;
      c.normal_velocity[i] = (body.positions[i] - x0[i]).dot(c.normal[i]) / dt;
    }
    c.external.resize(n);
    for (size_t i = 0; i < n; ++i) c.external[i] = body.masses[i] * gravity + body.applied_forces[i];
    std::copy(x0.begin(), x0.end(), body.positions.begin());
    std::copy(v0.begin(), v0.end(), body.velocities.begin());
    IntegrationInput in{body.masses, body.fixed, c.external, dt};
    in.constraint_normals = c.normal;
    in.constraint_normal_velocities = c.normal_velocity;
    in.constraint_forces = c.force;
    const IntegrationResult r = body.model->advance(body.positions, body.velocities, in);
    report.solver_iterations_max = std::max(report.solver_iterations_max, r.solver_iterations);
    report.solver_converged = report.solver_converged && r.converged;
    ++corrected_bodies_;
  }

  // Reactions on kinematic bodies: minus the constraint forces of the vertices touching them. A
  // kinematic body that also touches a body left to the response keeps the response's reaction.
  for (auto& reaction : report.reactions) {
    if (scope == ImplicitCorrection::stiff_partners) {
      bool touches_unsolved = false;
      for (const auto& contact : contacts) {
        const int other = contact.body == reaction.body              ? contact.penetrated_body
                          : contact.penetrated_body == reaction.body ? contact.body
                                                                     : -1;
        if (other >= 0 && !per_body_[static_cast<size_t>(other)].active) touches_unsolved = true;
      }
      if (touches_unsolved) continue;
    }
    const Body& k = *bodies[static_cast<size_t>(reaction.body)];
    reaction.force.setZero();
    reaction.torque.setZero();
    for (size_t b = 0; b < bodies.size(); ++b) {
      const BodyConstraints& c = per_body_[b];
      if (!c.active) continue;
      for (size_t i = 0; i < c.force.size(); ++i) {
        if (c.partner[i] != reaction.body || c.force[i].isZero()) continue;
        reaction.force -= c.force[i];
        reaction.torque += (bodies[b]->positions[i] - k.pose.translation).cross(-c.force[i]);
      }
    }
  }
}

const ContactSettings& ImplicitContactCorrection::response_settings(const ContactSettings& contact) {
  if (contact.implicit_correction != ImplicitCorrection::all) return contact;
  response_settings_ = contact;
  response_settings_.held_force_fraction = 0.0;  // the constraints hold the dent (docs, session 6)
  return response_settings_;
}

std::span<const Vec3> ImplicitContactCorrection::constraint_forces(int body) const {
  const auto b = static_cast<size_t>(body);
  if (b >= per_body_.size() || !per_body_[b].active) return {};
  return per_body_[b].force;
}

}  // namespace pliant
