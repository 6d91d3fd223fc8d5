// The contact-surface method (Spillmann & Teschner), stages 3-5: deformation region, displacement
// vectors (Eq. 1), binary search on the pressure difference (Eq. 2), velocity update and Coulomb
// friction. Design notes and every choice where the paper is silent: docs/contact-surface.md.
#pragma once

#include <functional>
#include <utility>
#include <vector>

#include "sim/contact/contact_response.h"
#include "sim/contact/contact_velocity_update.h"
#include "sim/contact/deformation_region.h"

namespace pliant {

/// Points inside ContactSurfaceResponse::respond() where a diagnostic observer looks at the bodies.
enum class ContactStage {
  search,           ///< positions displaced to the contact surface (binary search, secant)
  projection,       ///< after the finishing projection (only when it is on)
  velocity_update,  ///< after the velocity update and friction
};

class ContactSurfaceResponse final : public ContactResponse {
 public:
  /// Diagnostic hook (energy ledger tests): called after each stage of respond(); empty: none.
  std::function<void(ContactStage)> observer;

  void respond(std::span<Body* const> bodies, std::span<const VertexContact> contacts, double dt,
               const ContactSettings& settings, StepReport& report) override;
  void take_held_forces(const Body& body, std::span<Vec3> forces) override;
  bool has_held_contacts() const override { return !held_contacts_.empty(); }
  void save_held_forces() override;
  void restore_held_forces() override;
  std::span<const VertexContact> held_contacts() const override { return held_contacts_; }
  void set_step_start_velocities(const std::vector<std::vector<Vec3>>* velocities) override {
    friction_moves_.step_start_velocities = velocities;
  }
  /// Runs the force queries of the region's body groups through `executor` (not owned; null: one
  /// thread), one group per chunk: each group is one body with its own model, so the result is the
  /// serial one bit for bit (docs/threads.md, session 22).
  void set_executor(TaskExecutor* executor) override { executor_ = executor; }

 private:
  /// The search's samples of one vertex: (fraction, own minus other pressure).
  struct SearchSamples {
    struct Sample {
      double fraction = 0.0;
      double difference = 0.0;
    };
    Sample last, previous, above, below;  ///< above: difference > 0; below: <= 0
    bool has_last = false, has_previous = false, has_above = false, has_below = false;
    void add(double fraction, double difference);
    /// Secant estimate of the balance (see ContactSettings::secant_refinement).
    double refine(double bisection) const;
  };

  /// Contact forces of the last step held for the next integration (warm start), per body slot.
  struct HeldForces {
    const Body* body = nullptr;  ///< identifies the slot's body (a removed body's entry is ignored)
    std::vector<Vec3> force;     ///< N per vertex, to act through the next integration
    std::vector<int> contact;    ///< per vertex: its held contact (index into held_contacts_) or -1
    bool pending = false;        ///< set by respond(), not yet taken by an integration
    bool taken = false;          ///< taken by the integration of the current step
  };
  /// all_contacts_: this step's contacts, then the held contacts detection did not find again
  /// (lingering: their held force acted, so the velocity update may take it back); and the
  /// normal impulse (N s) each one's held force applied in this step. With `release_distant`
  /// (ContactSettings::release_distant_held_contacts) a lingering contact whose vertex is more than
  /// a cell from the point it is held against is dropped instead.
  void gather_contacts(std::span<Body* const> bodies, std::span<const VertexContact> contacts, double dt,
                       bool warm_start, bool release_distant);
  /// Stores `fraction` of this step's normal contact forces for the next integration, and
  /// min(fraction, `deformable_pair_fraction`) of those between two movable deformable bodies (with
  /// `derived_pairs` also at most the pair's derived_held_fraction.h strength); with
  /// `record_directions` (the release needs them) also each held force's unit direction.
  void hold_forces(std::span<Body* const> bodies, double dt, double fraction, double deformable_pair_fraction,
                   bool derived_pairs, bool record_directions);
  /// ContactSettings::deformable_pair_held_force_derived: each movable deformable pair's held
  /// fraction from its contact mode, written to pair_held_ (the pair's normal from this step's impulses).
  void derive_pair_held_fractions(std::span<Body* const> bodies, double dt, double pair_fraction);
  /// The held fraction derive_pair_held_fractions found for the pair of bodies p and q.
  double pair_held_fraction(int p, int q) const;
  /// ContactSettings::held_force_release: per body pair whose centres of mass separate along its
  /// held force, scales that pair's held forces down by the impulse the separation carries.
  void release_separating_pairs(std::span<Body* const> bodies, double dt);

  std::vector<HeldForces> held_;
  /// One movable deformable pair's derived held fraction (session 10); few pairs per step.
  struct PairHeldFraction {
    int body_a = -1, body_b = -1;   ///< body slots, body_a < body_b
    Vec3 normal = Vec3::Zero();     ///< sum of the pair's normal impulses on body_a's side (N s)
    double fraction = 1.0;          ///< held fraction of the pair's contacts
  };
  std::vector<PairHeldFraction> pair_held_;
  std::vector<VertexContact> held_contacts_;  ///< last step's contacts with a normal force
  std::vector<double> held_normal_force_;     ///< N, per held contact
  /// The held state before the current step (save_held_forces), for an undone step.
  std::vector<HeldForces> saved_held_;
  std::vector<VertexContact> saved_held_contacts_;
  std::vector<double> saved_held_normal_force_;
  std::vector<char> held_used_;               ///< scratch: held contact found again this step
  std::vector<size_t> pair_order_;            ///< scratch: held contacts grouped by body pair
  std::vector<std::pair<size_t, size_t>> pair_groups_;  ///< scratch: [begin, end) of each pair in pair_order_
  std::vector<Vec3> held_direction_;          ///< scratch: unit held force on the vertex, per held contact
                                              ///< (filled only for the release)
  std::vector<VertexContact> all_contacts_;   ///< this step's contacts, then the lingering ones
  std::vector<double> held_impulses_;         ///< N s per entry of all_contacts_
  std::vector<Vec3> region_force_;            ///< N, internal force per region vertex (scratch)
  size_t lingering_begin_ = 0;                ///< first lingering entry of all_contacts_
  DeformationRegion region_;
  std::vector<SearchSamples> samples_;              ///< stage 3 result, reused across steps
  std::vector<PairContactForce> pairs_;             ///< this step's per-pair forces (scratch)
  /// Scratch: per lower body slot of a pair, (higher body slot, index into pairs_) of this step's pairs.
  std::vector<std::vector<std::pair<int, int>>> pair_slots_;
  std::vector<ContactImpulse> impulses_;  ///< stage 5 impulses per contact
  std::vector<RigidModes> rigid_modes_;   ///< stage 5 scratch: rigid modes per body slot
  FrictionMoveLedger friction_moves_;     ///< stage 5 scratch: friction moves per body slot (M6a)
  TaskExecutor* executor_ = nullptr;  ///< set_executor: the force queries' threads (null: one)
};

}  // namespace pliant
