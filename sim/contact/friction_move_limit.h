// How far stage 5's friction may move a body's vertices (docs/stability.md, M6a).
//
// Design note. The friction impulse changes a vertex's velocity by dv and also moves it by
// u = dt dv (docs/contact-surface.md, "Coulomb friction": the position was integrated with the old
// velocity). A move field u stores the elastic energy E(u) = u^T K u / 2, while the impulses take
// out only sum m dv^2 / 2 of kinetic energy. Moving one vertex alone stores k u^2 / 2 (k = d^T K_vv d,
// vertex_stiffness_along): where omega dt = sqrt(k / m) dt > 1 (a light vertex, or a sliver tet's
// apex) the move stores (omega dt)^2 times what the impulse removes (energy out of nothing). But a
// rigid motion of the body stores nothing, and a layer of vertices moving together (a sticking
// block's bottom face) stores far less than the sum of its vertices' own k u^2 / 2: a per-vertex cap
// min(1, 1 / (omega dt)) made a sticking stiff block creep down an incline (4.45 mm vs < 0.2 mm).
// So the limit works per body: the moves are split into the moved set's best rigid motion (kept
// whole: a sticking face moves back as one) and the deforming remainder r; E(r) is linear
// elasticity about the current shape, and where it exceeds the budget B = sum m |dv|^2 / 2 of the
// body's friction impulses, r is scaled by sqrt(B / E(r)) so it stores at most B. One vertex alone
// (no rigid part): exactly min(1, 1 / (omega dt)). Velocities are untouched.
#pragma once

#include <span>
#include <vector>

#include "sim/body.h"

namespace pliant {

/// Stiffness (N/m) a vertex feels when it alone moves along the unit `direction`, all others held:
/// d^T K_vv d = sum over its tets of V (mu |g|^2 + (lambda + mu) (g . d)^2), g = grad N (linear
/// elasticity in the rest frame: element rotations are not applied to d).
double vertex_stiffness_along(const Body& body, int vertex, const Vec3& direction);

/// Elastic energy (J) of moving the body's vertices by `move` (m, one per vertex) in linear
/// elasticity about the current positions: sum over tets of V (mu eps:eps + lambda / 2 tr(eps)^2),
/// eps = sym(sum_a u_a grad N_a^T) (V, grad N of the current tet). Zero for a rigid translation or
/// an infinitesimal rotation of the whole body; one vertex alone: vertex_stiffness_along u^2 / 2
/// (about the rest shape).
double move_energy(const Body& body, std::span<const Vec3> move);

/// The part of a body's friction moves `move` (m, one per vertex) that deforms the moved set S
/// (the vertices with a move), written to `deforming` (resized): `move` minus S's best rigid
/// motion (translation + small rotation, mass-weighted least squares over S), zero off S. With
/// fewer than 3 moved vertices S has no rigid motion of its own (one or two contacts moving alone
/// deform the body): the whole move.
void friction_move_deforming_part(const Body& body, std::span<const Vec3> move, std::vector<Vec3>& deforming);

/// Stage 5's record of the friction moves of a pass, per body slot (working storage reused across
/// steps: no allocation once grown).
struct FrictionMoveLedger {
  std::vector<std::vector<Vec3>> moves;  ///< per body slot: dt dv summed per vertex (m); empty: none
  std::vector<double> budget;            ///< per body slot: sum m |dv|^2 / 2 of its impulses (J)
  std::vector<char> touched;             ///< per body slot: has a move this pass
  std::vector<Vec3> deforming;           ///< scratch for friction_move_deforming_part
  /// Starts a pass over `bodies` body slots.
  void begin(size_t bodies) {
    if (moves.size() < bodies) moves.resize(bodies);
    budget.assign(bodies, 0.0);
    touched.assign(bodies, 0);
  }
  /// Records the friction velocity change `dv` (m/s) of `vertex` of slot `slot`, moved by dt dv.
  void record(const Body& body, size_t slot, int vertex, const Vec3& dv, double dt) {
    if (!touched[slot]) {
      touched[slot] = 1;
      moves[slot].assign(body.positions.size(), Vec3::Zero());
    }
    moves[slot][static_cast<size_t>(vertex)] += dt * dv;
    budget[slot] += 0.5 * body.masses[static_cast<size_t>(vertex)] * dv.squaredNorm();
  }
  /// Takes back (1 - friction_move_scale) of each touched body's deforming part.
  void limit(std::span<Body* const> bodies);
};

/// Factor in (0, 1] on a body's friction moves: min(1, sqrt(budget / move_energy)), `budget` (J)
/// the kinetic energy sum m |dv|^2 / 2 of the body's friction impulses; 1 where the move stores
/// nothing.
double friction_move_scale(const Body& body, std::span<const Vec3> move, double budget);

}  // namespace pliant
