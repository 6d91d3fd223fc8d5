// Coupled mode (sessions 7-8, docs/contact-surface.md "Coupled"): a contact between two free
// corotational-FEM bodies is not prescribed in each body's solve; a scalar normal force lambda_k >= 0
// acts +lambda n on the colliding vertex and -w_j lambda n on its triangle's vertices (J^T lambda:
// equal and opposite by construction, so the pair's momentum is kept). Each body's step is affine in
// lambda (the implicit step is linear in the external force; its prescribed constraints against
// immovable partners stay in it), so the gaps g(lambda) = g(0) + S lambda with S = J A^-1 J^T h^2
// symmetric positive definite. Projected CG on S lambda = target - g(0) over the active contacts
// (Polyak's active-set CG for bound constraints), preconditioned by the contact's local compliance
// h^2 (n^T D_a^-1 n + sum w^2 n^T D_b^-1 n), D the bodies' diagonal system blocks of this step (session
// 8; session 7's mass-only h^2 (1/m_a + sum w^2 / m_b) by ContactSettings::coupled_block_preconditioner):
// each iteration re-solves the paired bodies at lambda + p (one pass), S p = g(lambda + p) -
// g(lambda), and the gaps at lambda + alpha p follow from the two solves (affine). A step that would make a
// lambda negative stops at zero and drops that contact; an inactive contact that penetrates is added; both
// restart the CG. lambda starts at the last step's value for the same vertex and partner (a sorted
// flat list, no per-step allocation once the buffers have grown). The
// bodies' final state is one more solve at the final lambda, not the affine combination of the
// solves (the step lengths, up to ~100 with the mass-only preconditioner, amplified the solves'
// residuals: momentum drifted 1e-10 N s per step in the head-on test).
#include "sim/contact/implicit_contact_correction.h"

#include <algorithm>
#include <cmath>

#include "sim/model/corotational_fem.h"

namespace pliant {
namespace {

// A body whose step can be re-solved with constraints: awake, deformable, corotational FEM.
bool resolvable(const Body* body) {
  return body != nullptr && !body->is_kinematic() && !body->is_sleeping() && body->model &&
         body->model->kind() == ModelKind::corotational_fem;
}

// h^2 n^T D_i^-1 n (m/N): how far a force along n on vertex i alone moves it in this step, from the
// body's diagonal system block D_i = (1 + h alpha) m_i I + h (beta + h) K'_ii of its last advance
// (this step's integration from the same state); the mass-only h^2 / m_i where the block is not
// available or not positive.
double local_compliance(const Body& body, size_t i, const Vec3& n, double dt) {
  const double mass_only = dt * dt / body.masses[i];
  const auto* fem = dynamic_cast<const CorotationalFem*>(body.model.get());
  if (fem == nullptr || fem->diagonal_system_blocks().size() != body.positions.size()) return mass_only;
  const Mat3& D = fem->diagonal_system_blocks()[i];
  if (!(D.determinant() > 0.0)) return mass_only;
  const double c = n.dot(D.ldlt().solve(n));
  return c > 0.0 ? dt * dt * c : mass_only;
}

bool by_key(const auto& a, const auto& b) {
  return std::tie(a.body, a.vertex, a.triangle_body) < std::tie(b.body, b.vertex, b.triangle_body);
}

}  // namespace

void ImplicitContactCorrection::activate(std::span<Body* const> bodies, size_t b) {
  BodyConstraints& c = per_body_[b];
  if (c.active) return;
  const size_t n = bodies[b]->positions.size();
  c.active = true;
  c.normal.assign(n, Vec3::Zero());
  c.partner.assign(n, -1);
  c.normal_velocity.assign(n, 0.0);
  c.force.assign(n, Vec3::Zero());
}

void ImplicitContactCorrection::add_constraint(std::span<Body* const> bodies, int body, int vertex,
                                               const Vec3& push, int partner, bool stiff) {
  const auto b = static_cast<size_t>(body);
  const auto v = static_cast<size_t>(vertex);
  if (!resolvable(bodies[b]) || bodies[b]->fixed[v] != 0) return;
  BodyConstraints& c = per_body_[b];
  if (!stiff) c.free_partner = true;
  activate(bodies, b);
  c.normal[v] += push;
  if (c.partner[v] < 0) c.partner[v] = partner;
}

void ImplicitContactCorrection::solve_body(Body& body, size_t b,
                                           std::span<const std::vector<Vec3>> start_positions,
                                           std::span<const std::vector<Vec3>> start_velocities, double dt,
                                           StepReport& report) {
  BodyConstraints& c = per_body_[b];
  std::copy(start_positions[b].begin(), start_positions[b].end(), body.positions.begin());
  std::copy(start_velocities[b].begin(), start_velocities[b].end(), body.velocities.begin());
  IntegrationInput in{body.masses, body.fixed, c.paired ? c.load : c.external, dt};
  in.constraint_normals = c.normal;
  in.constraint_normal_velocities = c.normal_velocity;
  in.constraint_forces = c.force;
  const IntegrationResult r = body.model->advance(body.positions, body.velocities, in);
  report.solver_iterations_max = std::max(report.solver_iterations_max, r.solver_iterations);
  report.solver_converged = report.solver_converged && r.converged;
}

void ImplicitContactCorrection::correct(std::span<Body* const> bodies,
                                        std::span<const VertexContact> contacts,
                                        std::span<const VertexContact> held_contacts,
                                        std::span<const std::vector<Vec3>> start_positions,
                                        std::span<const std::vector<Vec3>> start_velocities,
                                        const Vec3& gravity, double dt, const ContactSettings& settings,
                                        StepReport& report) {
  const ImplicitCorrection scope = settings.implicit_correction;
  per_body_.resize(bodies.size());
  for (auto& c : per_body_) c.active = c.free_partner = c.paired = false;
  corrected_bodies_ = 0;
  coupled_passes_ = 0;
  coupled_gap_error_ = 0.0;
  // The last step's pair forces, by (colliding body, vertex, penetrated body): the CG's start (of
  // equal keys the last one, as a map assigned in order would keep).
  last_lambda_.clear();
  for (const PairContact& k : pairs_) {
    last_lambda_.push_back({k.body, k.vertex, k.triangle_body, static_cast<int>(last_lambda_.size()), k.lambda});
  }
  std::sort(last_lambda_.begin(), last_lambda_.end(), [](const LastLambda& a, const LastLambda& b) {
    return by_key(a, b) || (!by_key(b, a) && a.order < b.order);
  });
  pairs_.clear();
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
    const Body* colliding = bodies[static_cast<size_t>(contact.body)];
    const bool vertex_stiff = colliding->is_immovable(contact.vertex);
    if (scope == ImplicitCorrection::coupled && !triangle_stiff && !vertex_stiff && resolvable(colliding) &&
        resolvable(penetrated)) {
      // Two free deformable bodies: one normal force for the pair (equal and opposite).
      PairContact k;
      k.body = contact.body;
      k.vertex = contact.vertex;
      k.triangle_body = contact.penetrated_body;
      k.normal = n.normalized();
      double sum = 0.0;
      for (size_t j = 0; j < 3; ++j) {
        k.triangle[j] = tri[j];
        k.weight[j] = std::max(contact.contact_barycentric[static_cast<int>(j)], 0.0);
        sum += k.weight[j];
      }
      if (!(sum > 0.0)) continue;
      Vec3 on_triangle = Vec3::Zero();
      for (size_t j = 0; j < 3; ++j) {
        k.weight[j] /= sum;
        on_triangle += k.weight[j] * penetrated->positions[static_cast<size_t>(tri[j])];
      }
      k.target = (colliding->positions[static_cast<size_t>(k.vertex)] - on_triangle).dot(k.normal);
      if (settings.coupled_block_preconditioner) {
        k.scale = local_compliance(*colliding, static_cast<size_t>(k.vertex), k.normal, dt);
        for (size_t j = 0; j < 3; ++j) {
          const auto v = static_cast<size_t>(tri[j]);
          if (penetrated->fixed[v] == 0) {
            k.scale += k.weight[j] * k.weight[j] * local_compliance(*penetrated, v, k.normal, dt);
          }
        }
      } else {  // session 7's mass-only scale, its arithmetic as it was
        double compliance = 1.0 / colliding->masses[static_cast<size_t>(k.vertex)];
        for (size_t j = 0; j < 3; ++j) {
          const auto v = static_cast<size_t>(tri[j]);
          if (penetrated->fixed[v] == 0) compliance += k.weight[j] * k.weight[j] / penetrated->masses[v];
        }
        k.scale = dt * dt * compliance;
      }
      const LastLambda key{k.body, k.vertex, k.triangle_body, 0, 0.0};
      const auto last = std::upper_bound(last_lambda_.begin(), last_lambda_.end(), key,
                                         [](const LastLambda& a, const LastLambda& b) { return by_key(a, b); });
      if (last != last_lambda_.begin() && !by_key(*std::prev(last), key)) k.lambda = std::prev(last)->lambda;
      pairs_.push_back(k);
      for (const size_t body : {static_cast<size_t>(k.body), static_cast<size_t>(k.triangle_body)}) {
        activate(bodies, body);
        per_body_[body].paired = true;
      }
      continue;
    }
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
    if (c.paired) {
      c.pair_force.assign(n, Vec3::Zero());
      c.load.resize(n);
    }
    ++corrected_bodies_;
  }
  // Bodies without pair contacts: one solve each (all positions read above, so resets are safe).
  for (size_t b = 0; b < bodies.size(); ++b) {
    if (per_body_[b].active && !per_body_[b].paired) {
      solve_body(*bodies[b], b, start_positions, start_velocities, dt, report);
    }
  }
  if (!pairs_.empty()) solve_pairs(bodies, start_positions, start_velocities, dt, settings, report);

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
  // The pair forces join the reported constraint forces (after the reactions: they touch no
  // kinematic body).
  for (auto& c : per_body_) {
    if (!c.active || !c.paired) continue;
    for (size_t i = 0; i < c.force.size(); ++i) c.force[i] += c.pair_force[i];
  }
}

void ImplicitContactCorrection::solve_pairs(std::span<Body* const> bodies,
                                            std::span<const std::vector<Vec3>> start_positions,
                                            std::span<const std::vector<Vec3>> start_velocities, double dt,
                                            const ContactSettings& settings, StepReport& report) {
  const size_t m = pairs_.size();
  auto solve_all = [&](std::span<const double> lambda) {
    for (size_t b = 0; b < bodies.size(); ++b) {
      if (per_body_[b].paired)
        std::fill(per_body_[b].pair_force.begin(), per_body_[b].pair_force.end(), Vec3::Zero());
    }
    for (size_t j = 0; j < m; ++j) {
      const PairContact& k = pairs_[j];
      per_body_[static_cast<size_t>(k.body)].pair_force[static_cast<size_t>(k.vertex)] +=
          lambda[j] * k.normal;
      for (size_t t = 0; t < 3; ++t) {
        per_body_[static_cast<size_t>(k.triangle_body)].pair_force[static_cast<size_t>(k.triangle[t])] -=
            (k.weight[t] * lambda[j]) * k.normal;
      }
    }
    for (size_t b = 0; b < bodies.size(); ++b) {
      BodyConstraints& c = per_body_[b];
      if (!c.paired) continue;
      for (size_t i = 0; i < c.load.size(); ++i) c.load[i] = c.external[i] + c.pair_force[i];
      solve_body(*bodies[b], b, start_positions, start_velocities, dt, report);
    }
    ++coupled_passes_;
  };
  auto gap = [&](const PairContact& k) {
    const Body& a = *bodies[static_cast<size_t>(k.body)];
    const Body& t = *bodies[static_cast<size_t>(k.triangle_body)];
    Vec3 on_triangle = Vec3::Zero();
    for (size_t j = 0; j < 3; ++j)
      on_triangle += k.weight[j] * t.positions[static_cast<size_t>(k.triangle[j])];
    return (a.positions[static_cast<size_t>(k.vertex)] - on_triangle).dot(k.normal);
  };

  PairScratch& s = scratch_;
  for (auto* v : {&s.lambda, &s.g, &s.r, &s.z, &s.p, &s.sp, &s.trial}) v->assign(m, 0.0);
  s.active.assign(m, 0);
  std::vector<double>&lambda = s.lambda, &g = s.g, &r = s.r, &z = s.z, &p = s.p, &sp = s.sp, &trial = s.trial;
  std::vector<char>& active = s.active;
  for (size_t j = 0; j < m; ++j) lambda[j] = pairs_[j].lambda;
  solve_all(lambda);
  bool solved_at_lambda = true;  // the bodies hold the solve at lambda (not a trial)
  for (size_t j = 0; j < m; ++j) g[j] = gap(pairs_[j]);
  const double tolerance = settings.coupled_gap_tolerance;
  // Gap error: active contacts |target - g|, inactive ones their penetration below the target.
  auto error = [&](size_t j) {
    const double e = pairs_[j].target - g[j];
    return active[j] != 0 ? std::abs(e) : std::max(e, 0.0);
  };
  for (size_t j = 0; j < m; ++j) active[j] = lambda[j] > 0.0 || g[j] < pairs_[j].target;
  bool restart = true;
  double rz = 0.0;
  // The last pass is kept for the solve at the final lambda.
  while (coupled_passes_ < settings.coupled_passes - 1) {
    double worst = 0.0;
    for (size_t j = 0; j < m; ++j) worst = std::max(worst, error(j));
    if (worst <= tolerance) break;
    if (restart) {
      // Add the inactive contacts that penetrate; steepest (preconditioned) direction.
      rz = 0.0;
      for (size_t j = 0; j < m; ++j) {
        if (active[j] == 0 && g[j] < pairs_[j].target - tolerance) active[j] = 1;
        r[j] = active[j] != 0 ? pairs_[j].target - g[j] : 0.0;
        z[j] = pairs_[j].scale > 0.0 ? r[j] / pairs_[j].scale : 0.0;
        p[j] = z[j];
        rz += r[j] * z[j];
      }
      restart = false;
    }
    // S p from a trial solve at lambda + p (the gaps are affine in lambda).
    for (size_t j = 0; j < m; ++j) trial[j] = lambda[j] + p[j];
    solve_all(trial);
    solved_at_lambda = false;
    double psp = 0.0;
    for (size_t j = 0; j < m; ++j) {
      sp[j] = gap(pairs_[j]) - g[j];
      psp += p[j] * sp[j];
    }
    if (!(psp > 0.0) || !(rz > 0.0)) break;  // no descent left (solver noise)
    double alpha = rz / psp;
    // Stop at the first lambda that would turn negative (it leaves the active set).
    size_t blocking = m;
    for (size_t j = 0; j < m; ++j) {
      if (active[j] != 0 && p[j] < 0.0 && lambda[j] + alpha * p[j] < 0.0) {
        alpha = -lambda[j] / p[j];
        blocking = j;
      }
    }
    double rz_next = 0.0;
    for (size_t j = 0; j < m; ++j) {
      lambda[j] = std::max(lambda[j] + alpha * p[j], 0.0);
      g[j] += alpha * sp[j];
      if (active[j] != 0) r[j] -= alpha * sp[j];
      z[j] = pairs_[j].scale > 0.0 ? r[j] / pairs_[j].scale : 0.0;
      rz_next += r[j] * z[j];
    }
    if (blocking < m) {
      lambda[blocking] = 0.0;
      active[blocking] = 0;
      restart = true;
    } else {
      const double beta = rz_next / rz;
      rz = rz_next;
      for (size_t j = 0; j < m; ++j) p[j] = active[j] != 0 ? z[j] + beta * p[j] : 0.0;
    }
    // An inactive contact that penetrates joins (restart).
    for (size_t j = 0; j < m; ++j) {
      if (active[j] == 0 && g[j] < pairs_[j].target - tolerance) restart = true;
    }
  }
  // The bodies' state is a solve at the final lambda (not an affine combination of solves, which
  // would amplify the solves' residuals by the step lengths); the pair forces are that lambda's.
  if (!solved_at_lambda) {
    solve_all(lambda);
    for (size_t j = 0; j < m; ++j) g[j] = gap(pairs_[j]);
  }
  coupled_gap_error_ = 0.0;
  for (size_t j = 0; j < m; ++j) {
    pairs_[j].lambda = lambda[j];
    coupled_gap_error_ = std::max(coupled_gap_error_, error(j));
  }
}

const ContactSettings& ImplicitContactCorrection::response_settings(const ContactSettings& contact) {
  if (contact.implicit_correction != ImplicitCorrection::all &&
      contact.implicit_correction != ImplicitCorrection::coupled) {
    return contact;
  }
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
