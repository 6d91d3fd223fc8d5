// Design note (held contact forces at full strength, docs/contact-surface.md). A held force acted
// through the implicit step, which on a stiff free body moves the whole body (its rigid modes), so
// an excess held impulse shows as a separating velocity of the whole body. Taking it back with the
// vertex's own mass removes only m_vertex / M of it per step and the body bounces (the wind-up of
// fraction 1). So a separating contact that holds an impulse on a free body (no fixed vertex, not
// kinematic or sleeping) takes it back with the body's rigid-mode effective inverse mass
// 1/M + (r x n)^T I^-1 (r x n) and applies the take-back as a rigid velocity change of the body
// (sequential impulses on a rigid body), accumulated over the pass and added to every vertex at the
// end. Bodies with fixed vertices have no rigid modes: their take-back stays local.
#include "sim/contact/contact_velocity_update.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Dense>

#include "sim/contact/friction_move_limit.h"

namespace pliant {
namespace {

double inverse_mass(const Body& body, int v) {
  return body.is_immovable(v) ? 0.0 : 1.0 / body.masses[static_cast<size_t>(v)];
}

// Session 8 (docs/stability.md M7): the inverse mass a friction impulse along the unit tangent t
// sees at vertex v. Stage 5 moves a vertex its friction impulse j slows by dt dv, dv = w j; moving
// it alone stores k (dt dv)^2 / 2 (k = vertex_stiffness_along), (omega dt)^2 times the kinetic
// energy m dv^2 / 2 the impulse removes (omega^2 = k / m). On a body with fixed vertices there is
// no rigid motion to excuse it, and where omega dt > 1 the step's implicit solve would have spread
// the impulse over the vertex's neighbours and into the fixed vertices behind them: the vertex
// answers with its quasi-static compliance 1 / (k dt^2) = w / (omega dt)^2, and its move stores at
// most the kinetic energy its impulse removes. Elsewhere (omega dt <= 1, or a free body, whose
// moves may be rigid: a sticking block) w itself, bit for bit.
double friction_inverse_mass(const Body& body, int v, const Vec3& t, double dt) {
  const double w = inverse_mass(body, v);
  if (w == 0.0) return w;
  const double omega_dt_squared = vertex_stiffness_along(body, v, t) * w * dt * dt;
  if (!(omega_dt_squared > 1.0)) return w;
  const bool anchored = std::any_of(body.fixed.begin(), body.fixed.end(), [](char f) { return f != 0; });
  return anchored ? w / omega_dt_squared : w;
}

}  // namespace

// Session 15: the same sums as Eigen's `inertia += m (|r|^2 I - r r^T)`, bit for bit, in six
// entries instead of nine. Eigen evaluates that expression entry by entry as m * (|r|^2 I_ij -
// r_i r_j) (the outer product into a temporary first, so each r_i r_j is one correctly rounded
// product); r_i r_j = r_j r_i exactly, so (i, j) and (j, i) receive the same terms in the same order
// and the lower triangle is copied at the end. Off the diagonal I_ij = 0 and |r|^2 * 0 = +0 for a
// finite |r|^2, so the term is spelled as Eigen computes it, 0.0 - r_i r_j. A kinematic or sleeping
// body is no longer scanned for fixed vertices (it is not free either way); 7 instructions per
// vertex of the floor every step. Test: RigidModesPrepare.IsEigensInertiaExpressionBitForBit.
void RigidModes::prepare(const Body& body) {
  if (ready) return;
  ready = true;
  free = !body.is_kinematic() && !body.is_sleeping() &&
         std::none_of(body.fixed.begin(), body.fixed.end(), [](char f) { return f != 0; });
  if (!free) return;
  for (size_t i = 0; i < body.positions.size(); ++i) {
    mass += body.masses[i];
    centre += body.masses[i] * body.positions[i];
  }
  centre /= mass;
  double xx = 0.0, yy = 0.0, zz = 0.0, xy = 0.0, xz = 0.0, yz = 0.0;
  for (size_t i = 0; i < body.positions.size(); ++i) {
    const Vec3 r = body.positions[i] - centre;
    const double m = body.masses[i], squared = r.squaredNorm();
    xx += m * (squared - r.x() * r.x());
    yy += m * (squared - r.y() * r.y());
    zz += m * (squared - r.z() * r.z());
    xy += m * (0.0 - r.x() * r.y());
    xz += m * (0.0 - r.x() * r.z());
    yz += m * (0.0 - r.y() * r.z());
  }
  Eigen::Matrix3d inertia;
  inertia << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  inverse_inertia = inertia.completeOrthogonalDecomposition().pseudoInverse();
}

void apply_contact_velocity_update(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
                                   double dt, bool friction, std::span<const double> held_normal_impulse,
                                   size_t lingering_begin, std::vector<ContactImpulse>& impulses,
                                   std::vector<RigidModes>& rigid_scratch, FrictionMoveLedger* friction_moves,
                                   bool anchored_friction_compliance) {
  impulses.assign(contacts.size(), ContactImpulse{});
  // Rigid modes per body slot, only when some contact holds an impulse (the scratch keeps its
  // capacity between steps: no allocation once grown).
  std::vector<RigidModes>& rigid = rigid_scratch;
  rigid.clear();
  if (std::any_of(held_normal_impulse.begin(), held_normal_impulse.end(), [](double j) { return j > 0.0; })) {
    rigid.resize(bodies.size());
  }
  if (friction_moves != nullptr) friction_moves->begin(bodies, dt);
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
    // The triangle's inverse masses once per contact (session 15: apply() and the take-back asked
    // inverse_mass again per vertex and impulse, a division each; the same values).
    std::array<double, 3> w_y{};
    double w_p = 0.0;
    Vec3 v_p = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      const int y = tri[static_cast<size_t>(k)];
      w_y[static_cast<size_t>(k)] = inverse_mass(n, y);
      w_p += b[k] * b[k] * w_y[static_cast<size_t>(k)];
      v_p += b[k] * n.velocities[static_cast<size_t>(y)];
    }
    const double w_sum = w_x + w_p;
    if (w_sum <= 0.0) continue;  // both sides immovable

    // Applies impulse j (on x; -j spread over the triangle) and moves positions by h dv if asked
    // (with a friction_moves ledger the moves are recorded per body and scaled at the end of the pass,
    // docs/stability.md M6a).
    auto record_move = [&](int body, int v, const Vec3& dv) {
      if (friction_moves != nullptr) {
        const Body& partner = body == contact.body ? n : m;
        friction_moves->record(*bodies[static_cast<size_t>(body)], static_cast<size_t>(body), v, dv, dt, partner);
      }
    };
    auto apply = [&](const Vec3& j, bool move_positions) {
      if (w_x > 0.0) {
        const Vec3 dv = w_x * j;
        m.velocities[static_cast<size_t>(contact.vertex)] += dv;
        if (move_positions) {
          m.positions[static_cast<size_t>(contact.vertex)] += dt * dv;
          record_move(contact.body, contact.vertex, dv);
        }
      }
      for (int k = 0; k < 3; ++k) {
        const int y = tri[static_cast<size_t>(k)];
        const double wy = w_y[static_cast<size_t>(k)];
        if (wy == 0.0 || b[k] == 0.0) continue;
        // Distribute so the contact point's velocity changes by -w_p j (minimum-norm split).
        const Vec3 dv = -b[k] * wy * j;
        n.velocities[static_cast<size_t>(y)] += dv;
        if (move_positions) {
          n.positions[static_cast<size_t>(y)] += dt * dv;
          record_move(contact.penetrated_body, y, dv);
        }
      }
    };

    const double held = held_normal_impulse.empty() ? 0.0 : held_normal_impulse[c];
    RigidModes* rm = rigid.empty() ? nullptr : &rigid[static_cast<size_t>(contact.body)];
    RigidModes* rn = rigid.empty() ? nullptr : &rigid[static_cast<size_t>(contact.penetrated_body)];
    const Vec3& x = m.positions[static_cast<size_t>(contact.vertex)];
    Vec3 p = Vec3::Zero();
    for (int k = 0; k < 3; ++k) p += b[k] * n.positions[static_cast<size_t>(tri[static_cast<size_t>(k)])];
    if (held > 0.0) {
      rm->prepare(m);
      rn->prepare(n);
    }
    const bool m_free = rm != nullptr && rm->ready && rm->free;
    const bool n_free = rn != nullptr && rn->ready && rn->free;
    // Relative velocity including the rigid take-backs of earlier contacts (Gauss-Seidel).
    Vec3 v_rel = m.velocities[static_cast<size_t>(contact.vertex)] - v_p;
    if (m_free) v_rel += rm->velocity_at(x);
    if (n_free) v_rel -= rn->velocity_at(p);
    double vn = v_rel.dot(normal);
    double normal_impulse = std::max(0.0, held - vn / w_sum);  // total, never adhesive
    if (c >= lingering_begin) normal_impulse = std::min(normal_impulse, held);  // no push at a distance
    if (vn > 0.0 && held > 0.0 && (m_free || n_free)) {
      // Excess held impulse on a free body: take it back with the rigid-mode effective mass.
      const double w_take =
          (m_free ? rm->inverse_mass_at(x, normal) : w_x) + (n_free ? rn->inverse_mass_at(p, normal) : w_p);
      normal_impulse = std::max(0.0, held - vn / w_take);
      const Vec3 j = (normal_impulse - held) * normal;
      if (m_free) {
        rm->apply(x, j);
      } else if (w_x > 0.0) {
        m.velocities[static_cast<size_t>(contact.vertex)] += w_x * j;
      }
      if (n_free) {
        rn->apply(p, -j);
      } else {
        for (int k = 0; k < 3; ++k) {
          const int y = tri[static_cast<size_t>(k)];
          n.velocities[static_cast<size_t>(y)] -= b[k] * w_y[static_cast<size_t>(k)] * j;
        }
      }
      vn = 0.0;
      v_rel -= v_rel.dot(normal) * normal;
    } else if (normal_impulse != held) {
      apply((normal_impulse - held) * normal, false);
    }
    impulses[c].normal = normal_impulse * normal;
    impulses[c].normal_magnitude = normal_impulse;
    if (!friction) continue;
    const double mu = std::sqrt(m.material.friction * n.material.friction);
    if (mu <= 0.0 || normal_impulse <= 0.0) continue;
    const Vec3 v_t = v_rel - vn * normal;
    const double speed = v_t.norm();
    if (speed <= 0.0) continue;
    const Vec3 tangent = v_t / speed;
    // M7 (friction_inverse_mass): only between two movable sides; against an immovable partner
    // the movable side takes the whole velocity change whatever its inverse mass.
    double wf_x = w_x, wf_p = w_p;
    std::array<double, 3> wf_y{};
    bool compliant = false;
    if (anchored_friction_compliance && w_x > 0.0 && w_p > 0.0) {
      wf_x = friction_inverse_mass(m, contact.vertex, tangent, dt);
      compliant = wf_x != w_x;
      wf_p = 0.0;
      for (int k = 0; k < 3; ++k) {
        const int y = tri[static_cast<size_t>(k)];
        wf_y[static_cast<size_t>(k)] = friction_inverse_mass(n, y, tangent, dt);
        compliant = compliant || wf_y[static_cast<size_t>(k)] != w_y[static_cast<size_t>(k)];
        wf_p += b[k] * b[k] * wf_y[static_cast<size_t>(k)];
      }
    }
    if (!compliant) {
      const double stick_impulse = speed / w_sum;
      const double jt = std::min(stick_impulse, mu * normal_impulse);
      const Vec3 j = -jt * tangent;
      apply(j, true);
      impulses[c].friction = j;
      continue;
    }
    const double jt = std::min(speed / (wf_x + wf_p), mu * normal_impulse);
    const Vec3 j = -jt * tangent;
    if (wf_x > 0.0) {
      const Vec3 dv = wf_x * j;
      m.velocities[static_cast<size_t>(contact.vertex)] += dv;
      m.positions[static_cast<size_t>(contact.vertex)] += dt * dv;
      record_move(contact.body, contact.vertex, dv);
    }
    for (int k = 0; k < 3; ++k) {
      const int y = tri[static_cast<size_t>(k)];
      if (wf_y[static_cast<size_t>(k)] == 0.0 || b[k] == 0.0) continue;
      const Vec3 dv = -b[k] * wf_y[static_cast<size_t>(k)] * j;
      n.velocities[static_cast<size_t>(y)] += dv;
      n.positions[static_cast<size_t>(y)] += dt * dv;
      record_move(contact.penetrated_body, y, dv);
    }
    impulses[c].friction = j;
  }
  // The limit (docs/stability.md M6a): a body's friction moves store at most their kinetic budget;
  // a rigid part stores nothing and is kept whole.
  if (friction_moves != nullptr) friction_moves->limit(bodies);
  for (size_t i = 0; i < rigid.size(); ++i) {
    if (!rigid[i].ready || !rigid[i].free) continue;
    Body& body = *bodies[i];
    for (size_t v = 0; v < body.positions.size(); ++v) body.velocities[v] += rigid[i].velocity_at(body.positions[v]);
  }
}

}  // namespace pliant
