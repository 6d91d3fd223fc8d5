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
// whole: a sticking face moves back as one) and the deforming remainder r, scaled by the largest
// s <= 1 whose added strain energy stays within the budget B = sum m |dv|^2 / 2 of the body's
// friction impulses. Session 10: the added energy is counted beyond what the stuck contacts
// already store. Under a held probe the tissue's stuck patch is pre-stressed; each step the
// integration lets it relax (dt v, 0.23 mm per step in the probe scene) and friction moves it back
// to where it was stuck. Charged alone, r stores about B (probe: 0.65-0.8 B, once 1.003 B: the
// limit bit there and the run departed from t = 1.388 s). Counted on top of the step's own displacement
// d = dt v + the rigid part (x_{n+1} = x_n + dt v_{n+1}, v before the impulses), the move adds
// Q(d + s r) - Q(d) = s a(r, d) + s^2 a(r, r) / 2 (Q(u) = a(u, u) / 2 linear elasticity about the
// current shape): a move that undoes the step's relaxation adds nothing (a(r, d) < 0), one vertex
// pinned while its body moved on rigidly (d rigid: a(r, d) = 0) is charged E(r) as before, so
// one vertex alone is still capped at min(1, 1 / (omega dt)). Not charged: the work against the
// step start's stress (the stuck contact's stored energy, returned to, not created). Velocities
// are untouched.
// Session 17 (opt-in energy_flow, docs/stability.md "Session 17"): the returns are pure returns
// (r ~ -d) on the probe and on the failing matrix rows alike; what differs is the returned mode's
// omega dt. Measured in the model's own stiffness (model_move_energy: move_energy's current-shape
// linear elasticity read up to 4,400x the model's energy in the probe's compressed tets), a return
// is charged against B plus implicit Euler's kinetic dissipation at the moved vertices, sum m |v_{n+1}
// - v_n|^2 / 2: the probe's costs at most 0.37 of that, the quasi-static returns of the dt 20 ms and
// nu 0.499 rows 2-800x.
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

/// Elastic energy (J) of moving the body's vertices by `move` (m, one per vertex) in the body's own
/// stiffness: the corotational FEM's linear elasticity with each tet's rotation frozen at its current
/// deformation gradient's (sum over the tets with a moved vertex of V0 (mu e:e + lambda / 2 tr(e)^2),
/// e = sym(R^T sum_a u_a grad N_a^T), V0 and grad N of the rest tet, R the rotation of F), i.e. the
/// second-order term of the model's energy change. move_energy's linear elasticity about the current
/// shape is the same at rest but grows as 1 / (current size)^2 in a compressed tet (session 17: up to
/// 4,400x the model's second difference under the probe, where this stays within 0.99-1.19x).
/// Visits only the tets of the moved vertices. Where the sources are silent: the estimate for any
/// body (Teschner's explicit model included), R from the SVD of F (reflection-fixed if inverted).
double model_move_energy(const Body& body, std::span<const Vec3> move);

/// Strain-energy terms of adding a move r to a displacement field d (m, one per vertex each) in
/// linear elasticity about the current positions (as move_energy): Q(d + s r) - Q(d) = s cross +
/// s^2 own / 2, a(u, w) = sum over tets of V (2 mu eps_u:eps_w + lambda tr(eps_u) tr(eps_w)).
struct MoveEnergyTerms {
  double cross = 0.0;  ///< a(r, d) (J)
  double own = 0.0;    ///< a(r, r) = 2 move_energy(r) (J)
  /// Q(d + s r) - Q(d) (J).
  double added(double s) const { return s * cross + 0.5 * s * s * own; }
};

/// The terms of `move` on top of `base` (empty: d = 0, then own / 2 = move_energy); only tets
/// with a moved vertex count (elsewhere a(r, .) = 0).
MoveEnergyTerms move_energy_terms(const Body& body, std::span<const Vec3> move, std::span<const Vec3> base);

/// Largest s in (0, 1] with terms.added(s) <= budget (J); 1 where the whole move fits.
double friction_move_scale(const MoveEnergyTerms& terms, double budget);

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
  /// per body slot: a move this pass came from a contact whose partner is not kinematic
  std::vector<char> deformable_partner;
  std::vector<Vec3> deforming;           ///< scratch for friction_move_deforming_part
  std::vector<std::vector<Vec3>> start_velocities;  ///< per body slot: v at the pass's start (m/s)
  std::vector<Vec3> base;                ///< scratch: the step's displacement d (m)
  double time_step = 0.0;                ///< the pass's dt (s)
  /// Charge the whole deforming part, returns of stuck patches included (no base d):
  /// ContactSettings::limit_friction_move_charges_returns. Set by the caller before the pass.
  bool charge_returns = false;
  /// With charge_returns: a body whose every friction move of the pass is against a kinematic
  /// partner (an instrument) keeps session 10's excuse for returns (ContactSettings::
  /// limit_friction_move_excuses_instrument_returns). Set by the caller before the pass.
  bool excuse_instrument_returns = false;
  /// The energy-flow charge (ContactSettings::limit_friction_move_energy_flow, session 17): each
  /// touched body's deforming part r, returns included, costs model_move_energy(r) and is charged
  /// against B plus implicit Euler's kinetic dissipation at the moved vertices this step,
  /// sum m |v_{n+1} - v_n|^2 / 2 (v_n from step_start_velocities). Overrides charge_returns and
  /// excuse_instrument_returns. Set by the caller before the pass.
  bool energy_flow = false;
  /// Per body slot: the velocities at the step's start (before the integration), for energy_flow;
  /// null, or a slot whose size differs from its body's: no dissipation term (B alone).
  const std::vector<std::vector<Vec3>>* step_start_velocities = nullptr;
  /// Starts a pass over `bodies` with time step `step` (s): keeps the deformable bodies' velocities,
  /// the ones the integration moved the positions with (x_{n+1} = x_n + dt v_{n+1}).
  void begin(std::span<Body* const> bodies, double step) {
    time_step = step;
    if (moves.size() < bodies.size()) moves.resize(bodies.size());
    if (start_velocities.size() < bodies.size()) start_velocities.resize(bodies.size());
    for (size_t i = 0; i < bodies.size(); ++i) {
      const Body& body = *bodies[i];
      if (!body.is_kinematic()) start_velocities[i].assign(body.velocities.begin(), body.velocities.end());
    }
    budget.assign(bodies.size(), 0.0);
    touched.assign(bodies.size(), 0);
    deformable_partner.assign(bodies.size(), 0);
  }
  /// Records the friction velocity change `dv` (m/s) of `vertex` of slot `slot`, moved by dt dv,
  /// from a contact with `partner` (the other side).
  void record(const Body& body, size_t slot, int vertex, const Vec3& dv, double dt, const Body& partner) {
    if (!partner.is_kinematic()) deformable_partner[slot] = 1;
    if (!touched[slot]) {
      touched[slot] = 1;
      moves[slot].assign(body.positions.size(), Vec3::Zero());
    }
    moves[slot][static_cast<size_t>(vertex)] += dt * dv;
    budget[slot] += 0.5 * body.masses[static_cast<size_t>(vertex)] * dv.squaredNorm();
  }
  /// Takes back (1 - s) of each touched body's deforming part r, s = friction_move_scale of r on
  /// top of the step's displacement d = dt v (v the velocities at the pass's start) plus the
  /// moves' rigid part; with charge_returns, of r alone (d = 0), except, with
  /// excuse_instrument_returns, for a body whose moves were all against kinematic partners; with
  /// energy_flow, model_move_energy(s r) <= B + the moved vertices' kinetic dissipation.
  void limit(std::span<Body* const> bodies);
};

/// Factor in (0, 1] on a body's friction moves counted alone (d = 0): min(1, sqrt(budget /
/// move_energy)), `budget` (J) the kinetic energy sum m |dv|^2 / 2 of the body's friction
/// impulses; 1 where the move stores nothing. (The session-9 limit, blind to the pre-stress.)
double friction_move_scale(const Body& body, std::span<const Vec3> move, double budget);

}  // namespace pliant
