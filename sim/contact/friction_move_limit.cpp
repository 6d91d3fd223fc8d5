#include "sim/contact/friction_move_limit.h"

#include <cmath>

#include <Eigen/Dense>

namespace pliant {

double vertex_stiffness_along(const Body& body, int vertex, const Vec3& direction) {
  const TetMesh& mesh = *body.mesh;
  const auto& x = mesh.rest_positions();
  const double mu = body.material.lame_mu(), lambda = body.material.lame_lambda();
  double k = 0.0;
  for (int t : mesh.vertex_tets(vertex)) {
    const TetIndices& tet = mesh.tets()[static_cast<size_t>(t)];
    Vec3 face[3];
    int n = 0;
    for (int a = 0; a < 4; ++a) {
      if (tet[static_cast<size_t>(a)] != vertex)
        face[n++] = x[static_cast<size_t>(tet[static_cast<size_t>(a)])];
    }
    const double volume = mesh.rest_volumes()[static_cast<size_t>(t)];
    if (!(volume > 0.0)) continue;
    // grad N of the vertex: the opposite face's area normal / (3 V) (its sign does not matter here).
    const Vec3 g = 0.5 * (face[1] - face[0]).cross(face[2] - face[0]) / (3.0 * volume);
    k += volume * (mu * g.squaredNorm() + (lambda + mu) * std::pow(g.dot(direction), 2));
  }
  return k;
}

MoveEnergyTerms move_energy_terms(const Body& body, std::span<const Vec3> move, std::span<const Vec3> base) {
  const TetMesh& mesh = *body.mesh;
  const double mu = body.material.lame_mu(), lambda = body.material.lame_lambda();
  const bool with_base = !base.empty();
  MoveEnergyTerms terms;
  for (const TetIndices& tet : mesh.tets()) {
    bool moved = false;
    for (int v : tet) moved = moved || move[static_cast<size_t>(v)].squaredNorm() > 0.0;
    if (!moved) continue;
    const Vec3& x0 = body.positions[static_cast<size_t>(tet[0])];
    Eigen::Matrix3d edges;  // columns x_a - x_0, a = 1..3
    for (int a = 1; a < 4; ++a) edges.col(a - 1) = body.positions[static_cast<size_t>(tet[static_cast<size_t>(a)])] - x0;
    const double volume = std::abs(edges.determinant()) / 6.0;
    if (!(volume > 0.0)) continue;
    // Rows of edges^-1 are grad N_1..3; grad N_0 = -(their sum). grad u = sum_a u_a grad N_a^T.
    const Eigen::Matrix3d inverse = edges.inverse();
    auto strain = [&](std::span<const Vec3> u) {
      Eigen::Matrix3d grad_u = Eigen::Matrix3d::Zero();
      const Vec3& u0 = u[static_cast<size_t>(tet[0])];
      for (int a = 1; a < 4; ++a) {
        grad_u += (u[static_cast<size_t>(tet[static_cast<size_t>(a)])] - u0) * inverse.row(a - 1);
      }
      return Eigen::Matrix3d(0.5 * (grad_u + grad_u.transpose()));
    };
    const Eigen::Matrix3d er = strain(move);
    terms.own += volume * (2.0 * mu * er.squaredNorm() + lambda * std::pow(er.trace(), 2));
    if (!with_base) continue;
    const Eigen::Matrix3d ed = strain(base);
    terms.cross += volume * (2.0 * mu * er.cwiseProduct(ed).sum() + lambda * er.trace() * ed.trace());
  }
  return terms;
}

double model_move_energy(const Body& body, std::span<const Vec3> move) {
  const TetMesh& mesh = *body.mesh;
  const auto& rest = mesh.rest_positions();
  const double mu = body.material.lame_mu(), lambda = body.material.lame_lambda();
  double energy = 0.0;
  for (size_t v = 0; v < move.size(); ++v) {
    if (move[v].squaredNorm() == 0.0) continue;
    for (int t : mesh.vertex_tets(static_cast<int>(v))) {
      const TetIndices& tet = mesh.tets()[static_cast<size_t>(t)];
      // Each tet once: at its first moved vertex.
      bool first = true;
      for (int w : tet) first = first && !(static_cast<size_t>(w) < v && move[static_cast<size_t>(w)].squaredNorm() > 0.0);
      if (!first) continue;
      const double volume = mesh.rest_volumes()[static_cast<size_t>(t)];
      if (!(volume > 0.0)) continue;
      Mat3 rest_edges, edges;  // columns X_a - X_0, x_a - x_0, a = 1..3
      for (int a = 1; a < 4; ++a) {
        const size_t i = static_cast<size_t>(tet[static_cast<size_t>(a)]), o = static_cast<size_t>(tet[0]);
        rest_edges.col(a - 1) = rest[i] - rest[o];
        edges.col(a - 1) = body.positions[i] - body.positions[o];
      }
      // Rows of rest_edges^-1 are the rest grad N_1..3; grad N_0 = -(their sum).
      const Mat3 inverse = rest_edges.inverse();
      // The rotation of F by its SVD, U diag(1, 1, det(U V^T)) V^T (the polar rotation; for an
      // inverted tet the reflection-fixed one, as the model's). Not extract_rotation from the
      // identity: without the model's warm start its iteration can diverge on a tet turned by more
      // than 90 degrees (a rolled fruit: overflow, session 17).
      const Eigen::JacobiSVD<Mat3> svd(edges * inverse, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Mat3 u_factor = svd.matrixU();
      if ((u_factor * svd.matrixV().transpose()).determinant() < 0.0) u_factor.col(2) *= -1.0;
      const Mat3 rotation = u_factor * svd.matrixV().transpose();
      Mat3 grad_u = Mat3::Zero();
      const Vec3& u0 = move[static_cast<size_t>(tet[0])];
      for (int a = 1; a < 4; ++a) grad_u += (move[static_cast<size_t>(tet[static_cast<size_t>(a)])] - u0) * inverse.row(a - 1);
      const Mat3 h = rotation.transpose() * grad_u;
      const Mat3 e = 0.5 * (h + h.transpose());
      energy += volume * (mu * e.squaredNorm() + 0.5 * lambda * e.trace() * e.trace());
    }
  }
  return energy;
}

double move_energy(const Body& body, std::span<const Vec3> move) {
  return 0.5 * move_energy_terms(body, move, {}).own;
}

double friction_move_scale(const MoveEnergyTerms& terms, double budget) {
  if (terms.added(1.0) <= budget) return 1.0;
  // added(s) = budget: own s^2 / 2 + cross s - budget = 0, the positive root (added(0) = 0 <= budget,
  // so it lies in (0, 1)), written without cancellation for either sign of cross.
  const double root = std::sqrt(terms.cross * terms.cross + 2.0 * terms.own * budget);
  return terms.cross >= 0.0 ? 2.0 * budget / (terms.cross + root) : (root - terms.cross) / terms.own;
}

void friction_move_deforming_part(const Body& body, std::span<const Vec3> move, std::vector<Vec3>& remainder) {
  remainder.assign(move.begin(), move.end());
  double mass = 0.0;
  Vec3 centre = Vec3::Zero(), translation = Vec3::Zero();
  int moved = 0;
  for (size_t v = 0; v < move.size(); ++v) {
    if (move[v].squaredNorm() == 0.0) continue;
    ++moved;
    mass += body.masses[v];
    centre += body.masses[v] * body.positions[v];
    translation += body.masses[v] * move[v];
  }
  if (moved < 3 || !(mass > 0.0)) return;
  centre /= mass;
  translation /= mass;
  // Small rotation theta minimising sum m |u - t - theta x r|^2: I theta = sum m r x (u - t).
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  Vec3 moment = Vec3::Zero();
  for (size_t v = 0; v < move.size(); ++v) {
    if (move[v].squaredNorm() == 0.0) continue;
    const Vec3 r = body.positions[v] - centre;
    inertia += body.masses[v] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
    moment += body.masses[v] * r.cross(move[v] - translation);
  }
  const Vec3 rotation = inertia.completeOrthogonalDecomposition().pseudoInverse() * moment;
  for (size_t v = 0; v < move.size(); ++v) {
    if (move[v].squaredNorm() == 0.0) continue;
    remainder[v] -= translation + rotation.cross(body.positions[v] - centre);
  }
}

double friction_move_scale(const Body& body, std::span<const Vec3> move, double budget) {
  return friction_move_scale(move_energy_terms(body, move, {}), budget);
}

void FrictionMoveLedger::limit(std::span<Body* const> bodies) {
  for (size_t i = 0; i < touched.size(); ++i) {
    if (!touched[i]) continue;
    Body& body = *bodies[i];
    friction_move_deforming_part(body, moves[i], deforming);
    if (energy_flow) {
      // Session 17: the deforming part, returns included, in the model's own stiffness, against
      // the impulses' kinetic energy B plus implicit Euler's kinetic dissipation at the moved
      // vertices, sum m |v_{n+1} - v_n|^2 / 2 (docs/stability.md "Session 17").
      double dissipation = 0.0;
      const std::vector<Vec3>& v1 = start_velocities[i];
      const std::vector<Vec3>* v0 = step_start_velocities != nullptr && i < step_start_velocities->size()
                                        ? &(*step_start_velocities)[i]
                                        : nullptr;
      if (v0 != nullptr && v0->size() == body.positions.size()) {
        for (size_t v = 0; v < v1.size(); ++v) {
          if (moves[i][v].squaredNorm() > 0.0) dissipation += 0.5 * body.masses[v] * (v1[v] - (*v0)[v]).squaredNorm();
        }
      }
      const MoveEnergyTerms terms{0.0, 2.0 * model_move_energy(body, deforming)};
      const double scale = friction_move_scale(terms, budget[i] + dissipation);
      if (scale >= 1.0) continue;
      for (size_t v = 0; v < body.positions.size(); ++v) body.positions[v] -= (1.0 - scale) * deforming[v];
      continue;
    }
    // The step's displacement before the deforming part: the integration's dt v_{n+1} (the
    // velocities before this pass's impulses: a normal impulse changes a velocity, not a position)
    // plus the moves' rigid part, which is kept. Charging returns, there is none: a move that puts
    // a stuck patch back where the integration relaxed it from is charged as new strain.
    if (charge_returns && (deformable_partner[i] || !excuse_instrument_returns)) {
      base.clear();
    } else {
      const std::vector<Vec3>& v0 = start_velocities[i];
      base.resize(body.positions.size());
      for (size_t v = 0; v < base.size(); ++v) base[v] = time_step * v0[v] + (moves[i][v] - deforming[v]);
    }
    const double scale = friction_move_scale(move_energy_terms(body, deforming, base), budget[i]);
    if (scale >= 1.0) continue;
    for (size_t v = 0; v < body.positions.size(); ++v) body.positions[v] -= (1.0 - scale) * deforming[v];
  }
}

}  // namespace pliant
