// Contact inside the implicit solve (beyond the paper, opt-in: ContactSettings::implicit_correction;
// docs/contact-surface.md "Contact inside the implicit solve (session 6)"). After the contact-surface
// response has found the contact surface (stages 3-5, the paper's pressure split untouched), every
// corotational-FEM body with contact vertices re-solves its implicit step from the start-of-step
// state with each contact vertex's normal position prescribed there, (x_{n+1} - x_target) . n = 0,
// tangential components free (Baraff & Witkin 1998 sec. 5.3, filtered CG:
// sim/model/corotational_constrained_solve.cpp). The dent then spreads over the depth the implicit
// step reaches, and x_{n+1} = x_n + h v_{n+1} come from one solve: no one-layer dent is stored
// (docs/stability.md, M1). Constrained vertices: each colliding vertex (normal: its contact
// triangle's outward normal at the displaced positions) and each vertex of its contact triangle
// (the opposite normal); a vertex in several contacts takes the normalised sum. Explicit-model,
// kinematic and sleeping bodies and fixed vertices keep what the response gave them.
// Scope (ContactSettings::implicit_correction): `all` re-solves every such body (held forces off,
// World::respond); `stiff_partners` re-solves only a body whose every contact partner is immovable
// (a kinematic or sleeping body, or fixed vertices: the whole colliding vertex, or all three
// vertices of the contact triangle), in this step's contacts or in the held contacts whose forces
// acted in its integration. A body with a contact between two free deformable bodies keeps the
// paper's response and its held forces: two separate re-solves cannot keep their constraint forces
// equal and opposite (docs). The re-solve does not apply a body's held forces again (its
// constraints hold the dent); the integration still takes them, as with the correction off
// (skipping them there for bodies re-solved in the last step was measured and rejected: docs).
// `coupled` (session 7) is `all` with each contact between two free corotational-FEM bodies carried
// by one normal force lambda >= 0, equal and opposite on the pair by construction, found by
// projected CG over the paired bodies' re-solves (design note in the .cpp).
#pragma once

#include <array>
#include <span>
#include <vector>

#include "sim/body.h"
#include "sim/collision/contact_types.h"
#include "sim/contact/contact_settings.h"
#include "sim/step_report.h"

namespace pliant {

class ImplicitContactCorrection {
 public:
  /// Re-solves the step of the corotational-FEM bodies with contact vertices in `contacts` that
  /// `settings.implicit_correction` admits, from `start_positions` / `start_velocities` (per body slot, the
  /// state before the step), under gravity (m/s^2) and the bodies' applied forces (held contact forces are
  /// not applied again: the constraints hold the dent), over dt (s). `held_contacts`: the contacts whose held
  /// forces acted in the step's integration (stiff_partners: a pair in them counts as a contact). Replaces
  /// the report's reaction on a kinematic body that touches only re-solved bodies by minus the constraint
  /// forces of the vertices touching it.
  void correct(std::span<Body* const> bodies, std::span<const VertexContact> contacts,
               std::span<const VertexContact> held_contacts,
               std::span<const std::vector<Vec3>> start_positions,
               std::span<const std::vector<Vec3>> start_velocities, const Vec3& gravity, double dt,
               const ContactSettings& settings, StepReport& report);
  /// Constraint forces (N) per vertex of body slot `body` from the last correction; empty if the
  /// body was not re-solved in it.
  std::span<const Vec3> constraint_forces(int body) const;
  /// Forgets the last correction (a step in which no body was re-solved).
  void clear() {
    for (auto& c : per_body_) c.active = false;
    corrected_bodies_ = 0;
    pairs_.clear();
    coupled_passes_ = 0;
    coupled_gap_error_ = 0.0;
  }
  /// Bodies re-solved by the last correction.
  int corrected_bodies() const { return corrected_bodies_; }
  /// Coupled mode: contacts between two free bodies in the last correction.
  int coupled_contacts() const { return static_cast<int>(pairs_.size()); }
  /// Coupled mode: re-solve passes of the bodies in free-free contact in the last correction.
  int coupled_passes() const { return coupled_passes_; }
  /// Coupled mode: largest gap error left by the last correction (m; active: |g - target|,
  /// inactive: penetration below target).
  double coupled_gap_error() const { return coupled_gap_error_; }
  /// The settings the contact-surface response runs with under contact.implicit_correction: `contact`
  /// itself, except that `all` turns held forces off (its constraints hold the dent); the copy then
  /// lives in this object until the next call.
  const ContactSettings& response_settings(const ContactSettings& contact);

 private:
  /// Per body slot: the constraints gathered this step and the solve's output.
  struct BodyConstraints {
    bool active = false;                  ///< has at least one constrained vertex this step
    bool free_partner = false;            ///< touches a movable vertex of another free body
    std::vector<Vec3> normal;             ///< sum of oriented unit normals, then normalised (0: free)
    std::vector<int> partner;             ///< per vertex: body slot of its first contact partner, -1
    std::vector<double> normal_velocity;  ///< m/s, prescribed v_{n+1} . n
    std::vector<Vec3> force;              ///< N, constraint forces of the solve
    std::vector<Vec3> external;           ///< N, gravity plus applied forces
    std::vector<Vec3> pair_force;         ///< N, coupled: the pair contacts' forces on each vertex
    std::vector<Vec3> load;               ///< N, coupled: external plus pair_force (the solve's input)
    bool paired = false;                  ///< coupled: has a pair contact this step
  };
  /// A contact between two free corotational-FEM bodies in coupled mode: a scalar normal force
  /// lambda >= 0 (N) acts +lambda n on the colliding vertex and -w_k lambda n on its contact
  /// triangle's vertices; the gap g = (x_a - sum_k w_k x_bk) . n at x_{n+1} should reach `target`.
  struct PairContact {
    int body = -1, vertex = -1;      ///< colliding body slot and vertex
    int triangle_body = -1;          ///< penetrated body slot
    std::array<int, 3> triangle{};   ///< contact triangle's vertices
    std::array<double, 3> weight{};  ///< barycentric weights, clamped at 0 and normalised
    Vec3 normal = Vec3::Zero();      ///< contact triangle's outward unit normal (response positions)
    double target = 0.0;             ///< m, gap at the response's positions
    double lambda = 0.0;             ///< N, normal force (CG unknown)
    /// m/N, the CG's preconditioner: the contact's local compliance h^2 (n^T D_a^-1 n + sum w_k^2
    /// n^T D_bk^-1 n) from the bodies' diagonal system blocks, or h^2 (1/m_a + sum w_k^2 / m_bk)
    double scale = 0.0;
  };
  /// A pair contact's force kept for the next step's warm start, sorted by (body, vertex,
  /// triangle_body, order).
  struct LastLambda {
    int body = -1, vertex = -1, triangle_body = -1;  ///< the contact's key
    int order = 0;                                   ///< position in last step's list (last wins)
    double lambda = 0.0;                             ///< N
  };
  /// The contact-force CG's vectors (one entry per pair contact), reused across steps.
  struct PairScratch {
    std::vector<double> lambda, g, r, z, p, sp, trial;
    std::vector<char> active;
  };
  /// Body slots re-solved this step: `coupled` lists the ones with a pair contact.
  void activate(std::span<Body* const> bodies, size_t body);
  /// Re-solves body slot b from the start of the step with its prescribed constraints and its
  /// external forces plus the pair forces (positions, velocities and constraint forces written).
  void solve_body(Body& body, size_t b, std::span<const std::vector<Vec3>> start_positions,
                  std::span<const std::vector<Vec3>> start_velocities, double dt, StepReport& report);
  /// Coupled mode: projected CG on the pair contacts' forces (design note in the .cpp).
  void solve_pairs(std::span<Body* const> bodies, std::span<const std::vector<Vec3>> start_positions,
                   std::span<const std::vector<Vec3>> start_velocities, double dt,
                   const ContactSettings& settings, StepReport& report);
  /// Adds a push direction to a body's vertex (ignored for bodies that are not re-solved).
  /// `stiff`: the partner cannot move (kinematic, sleeping or fixed).
  void add_constraint(std::span<Body* const> bodies, int body, int vertex, const Vec3& push, int partner,
                      bool stiff);

  std::vector<BodyConstraints> per_body_;
  int corrected_bodies_ = 0;
  std::vector<PairContact> pairs_;     ///< coupled: this step's free-free contacts
  std::vector<LastLambda> last_lambda_;  ///< coupled: last step's pair forces (warm start)
  PairScratch scratch_;                ///< coupled: the CG's vectors
  int coupled_passes_ = 0;             ///< coupled: re-solve passes of the last correction
  double coupled_gap_error_ = 0.0;     ///< coupled: largest gap error left (m)
  ContactSettings response_settings_;  ///< response_settings' copy when it differs from the input
};

}  // namespace pliant
