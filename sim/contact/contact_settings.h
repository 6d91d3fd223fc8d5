// How contacts are resolved: the contact-surface method (default) or the penalty baseline.
#pragma once

namespace pliant {

enum class ContactMethod {
  contact_surface,  ///< Spillmann & Teschner: displace to the contact surface by pressure balance
  penalty,          ///< f = k d r springs (the paper's baseline, [10])
  none,             ///< detect and report only
};

/// "surface" / "penalty" / "none".
const char* to_string(ContactMethod method);

/// Which contacts the opt-in implicit correction constrains (ContactSettings::implicit_correction).
enum class ImplicitCorrection {
  off,             ///< the paper's response alone (the default)
  /// Only bodies whose every contact vertex touches an infinitely stiff partner (a kinematic body,
  /// or a contact triangle / colliding vertex that is fixed) are re-solved; contacts between two
  /// free deformable bodies keep the paper's response and its held forces, as with off.
  stiff_partners,
  /// Every corotational-FEM body with contact vertices is re-solved, held forces off (session 6's
  /// first pass; unstable between two free deformable bodies: the per-body solves break Newton's
  /// third law).
  all,
  /// As all against immovable partners; a contact between two free corotational-FEM bodies is
  /// not prescribed per body but carried by a scalar normal force lambda >= 0 that acts +lambda n on
  /// the colliding vertex and -w_k lambda n on its triangle's vertices (equal and opposite by
  /// construction), found by projected CG on the gaps over the bodies' re-solves (session 7;
  /// docs/contact-surface.md "Coupled"). Held forces off.
  coupled,
};

struct ContactSettings {
  ContactMethod method = ContactMethod::contact_surface;
  int binary_search_iterations = 4;   ///< paper: four suffice
  bool finishing_projection = false;  ///< beyond the paper: remove the residual overlap exactly
  /// Beyond the paper: after the binary search, one secant (regula falsi) estimate of the balance
  /// from the samples the search took, so stiffness ratios beyond 2^(n+1) are represented.
  bool secant_refinement = false;
  /// Inside the binary search, evaluate internal forces with element rotations frozen at the
  /// model's last linearisation (DeformationModel::internal_forces_at_frozen_rotations: cheaper,
  /// approximate) for a body whose searching vertices move by at most h / 2^(n+1) (h: local edge
  /// length), where its error stays below the search's resolution (docs/contact-surface.md,
  /// "Speed"). The final evaluation at the contact surface (held-force cap, reported forces) is
  /// always exact, and the frozen rotations are extracted only for the tets the search touches
  /// (session 4); false: every query exact (the default: merged with the SSOR solver and held
  /// forces, the frozen search gains energy on a 1 mg body with a sliver tet, Stability test
  /// SurfaceMilligramBodyWithASliver 1.18x the work put in, and saves no measurable time).
  bool frozen_rotation_search = false;
  /// Inside the binary search (not the final evaluation), an element rotation extracted by an
  /// earlier query or step is reused while the element's deformation gradient moved by at most
  /// this much (Frobenius norm of dF, dimensionless; DeformationModel::
  /// internal_forces_at_nearby_rotations, docs/contact-surface.md "Speed (session 5)"). 0: every
  /// search query extracts every rotation (exact).
  double search_rotation_tolerance = 1e-3;
  /// Beyond the paper (session 6, docs/contact-surface.md "Speed (session 6)"): the binary search's
  /// iterations after the first evaluate a body's forces as f(x1) - K' (x - x1), x1 the first
  /// evaluation's positions and K' the stiffness matrix of the body's last implicit step
  /// (DeformationModel::stiffness_product_at: rotations frozen, no per-element work), for a body
  /// whose searching vertices have |s| <= h / 2^(n+2) (a quarter of frozen_rotation_search's
  /// gate). The first evaluation is the exact query (session 8: no reused rotations at the point
  /// every later iteration linearises about) and the final one stays a query. On by default again
  /// since session 8: session 7's "12x more churn" was one sample of a chaotic run; over 16 shifted
  /// starts the free stack churns less than with the session-5 search (docs/contact-surface.md
  /// "Linearised search on again"). false: every search iteration asks the force query (the
  /// session-5 search, bit for bit).
  bool linearised_search = true;
  /// The linearised search's second gate: a body's later iterations ask the query instead where a
  /// searching vertex's move since the first evaluation changes one of its elements' deformation
  /// gradient by more than this (|d| |grad N|, dimensionless; a sliver's rotation turns fast).
  double linearised_search_strain = 1e-2;
  /// Beyond the paper (session 7, docs/contact-surface.md "Speed (session 7)"): without held forces
  /// (held_force_fraction 0: the final evaluation's forces are only reported), the final
  /// evaluation at the contact surface takes f(x1) - K' (x - x1) too, for the bodies whose search
  /// was linearised and whose moves since x1 (all region vertices, the projection's included) pass
  /// linearised_search_strain; elsewhere, and with held forces (unless held_linearised_final_strain
  /// > 0, below), it stays the exact query.
  /// The step's positions and velocities are unchanged; later steps differ only through the
  /// rotations the exact query would have remembered for search_rotation_tolerance's reuse.
  /// false: the final evaluation is always exact (bit for bit).
  bool linearised_final_evaluation = true;
  /// Session 21, opt-in (docs/contact-surface.md "Response time, session 21"): with held forces the
  /// final evaluation's forces cap the next step's held force, so it stays exact unless this is
  /// > 0; then a linearised group's final evaluation is linearised as above where its moves since
  /// x1 pass this gate (|d| |grad N|), which is tighter than the search's (session 7: at the search's
  /// 1e-2 the 1 mg sliver case gained 4.85x the work put in). 0 (default): exact, bit for bit.
  double held_linearised_final_strain = 0.0;
  double penalty_stiffness = 2e3;     ///< k (N/m) of the penalty response
  double penalty_damping = 0.0;       ///< k_d (N s/m) on the normal relative velocity
  bool friction = true;               ///< Coulomb friction where materials have mu > 0
  /// Beyond the paper (docs/contact-surface.md, "Held contact forces at full strength"): the
  /// contact-surface response's normal contact forces of a step act as external force through the
  /// next integration, so a dent the search made is held instead of springing back; the velocity
  /// update supplies the rest, and takes back an excess held impulse on a free body with the body's
  /// rigid-mode effective mass (accumulated impulse clamped at zero: never adhesive). 1 = full
  /// strength, the contact's whole reaction (the default since session 4); 0 = off (the paper's
  /// method, for comparison); fractions in between only for comparison (the stability harness
  /// and its ledger keep their session-2 value 0.8).
  double held_force_fraction = 1.0;
  /// Beyond the paper, opt-in (docs/contact-surface.md, "Resting churn", session 7): a held force
  /// is the last step's contact force, so where the two bodies' centres of mass already separate
  /// along it, it pushes them apart through the next integration (positive work on the rigid modes:
  /// the stack's bounce at dt 1 ms). With this on, a pair whose sides are each free or immovable
  /// (kinematic, sleeping; not a body with fixed vertices) and whose centres separate at u along
  /// its held force F releases min(|F| dt, mu u) of the held impulse (mu the pair's reduced mass).
  /// Measured: two free blocks at 1 ms, late KE 4.9e-4 -> 3.3e-5 J (mu 0) but 1.4e-5 -> 3.3e-5 J
  /// (mu 0.5) with session 6's linearised search; 4.1e-5 -> 2.2e-5 J (mu 0) with the default search;
  /// not resting either way, so off by default.
  bool held_force_release = false;
  /// Beyond the paper, opt-in experiment (docs/stability.md, M1): where a body's pressure wave
  /// crosses more than a cell in the step (CFL c_p dt / h > 1), a vertex takes only 1/CFL^2 of the
  /// displacement the search found; the rest stays as overlap for the next steps. Off by default:
  /// it passes the matrix's nu 0.499 and ratio 1e6 cases but fails four default-suite tests
  /// (scale invariance, Hertz slope, secant at extreme ratios, free block at rest) and makes dt 20 ms worse.
  bool cfl_limited_displacement = false;
  /// Beyond the paper, opt-in (docs/contact-surface.md, "Contact inside the implicit solve (session
  /// 6)"): after the response, corotational-FEM bodies with contact vertices re-solve their
  /// implicit step from the start of the step with each contact vertex's normal position prescribed
  /// at the contact surface the response found (Baraff & Witkin 1998 sec. 5.3), so the dent spreads
  /// over the depth the implicit step reaches and positions and velocities come from one solve.
  /// Reactions on kinematic bodies then come from the constraint forces. off: the paper's path.
  ImplicitCorrection implicit_correction = ImplicitCorrection::off;
  /// coupled: most re-solve passes of the bodies in free-free contact per step (the first solve,
  /// then one per CG iteration on the contact forces).
  int coupled_passes = 8;
  /// coupled: the CG on the contact forces stops when every active contact's gap is within this of
  /// its target and no inactive one penetrates by more (m).
  double coupled_gap_tolerance = 1e-7;
  /// coupled: the contact-force CG's preconditioner from the bodies' diagonal system blocks, the
  /// local compliance h^2 (n^T D_a^-1 n + sum w_k^2 n^T D_bk^-1 n) (session 8); false: the mass-only
  /// h^2 (1/m_a + sum w_k^2 / m_bk) of session 7, bit for bit.
  bool coupled_block_preconditioner = true;
  /// Beyond the paper, opt-in (docs/stability.md, M6a): stage 5's friction moves dt dv of a body
  /// are scaled so their deforming part (the moves minus the moved set's rigid fit) adds at most
  /// the kinetic energy sum m |dv|^2 / 2 of its friction impulses to the strain of the step's own
  /// displacement (session 10: a stuck contact's return is free; the probe is unchanged with it
  /// on). Off by default: the long matrix gains nothing with it (docs/stability.md "Session 10").
  /// false: every friction move is dt dv (session 6's stage 5, bit for bit).
  bool limit_friction_move = false;
  /// Beyond the paper, opt-in (session 8, docs/stability.md M7): between two movable sides, a
  /// friction impulse sees a vertex of a body with fixed vertices that is stiff within the step
  /// (omega dt > 1, omega^2 = k / m, k its one-vertex stiffness) with its quasi-static compliance
  /// 1 / (k dt^2) instead of 1 / m, so its move dt dv stores at most the kinetic energy the impulse
  /// removes (tissue on a 1e10 Pa block: stage 5 added +107 J over 0.3 s, with this 6.5e-6 J). Off
  /// by default: the soft side then takes the whole tangential correction and the matrix's corner
  /// ratio 1e-6 nu 0.499 overlap 0.5 goes 1.16 -> 2.86 (nu 0.499 1.75 -> 1.79, dt 5 ms 5.45 -> 5.81).
  /// false: session 7's stage 5 bit for bit (so is true where no such vertex meets friction).
  bool anchored_friction_compliance = false;
  /// Barycentric weights in Eq. 1 and Eq. 2 (the paper). false weighs every contribution 1:
  /// only for measuring what the weighting buys (continuity test).
  bool barycentric_weighting = true;
  /// Beyond the paper, opt-in (session 9, docs/contact-surface.md "Resting churn, session 9"): the
  /// held fraction of a contact between two movable deformable bodies (neither kinematic nor
  /// sleeping) is min(held_force_fraction, this). The full held force is one step late, and between
  /// two movable bodies that lag pumps their contact mode at omega dt ~ 1 (the resting churn);
  /// against kinematic and sleeping partners the full force stays (the instrument's reaction).
  /// Measured over 8 shifted starts: 0.8 rests the free stack with friction at 1 ms and cuts the
  /// fixed-base stack's churn ~300x. 1: held_force_fraction everywhere, bit for bit.
  double deformable_pair_held_force_fraction = 1.0;
  /// Beyond the paper, opt-in (session 9, docs/stability.md M10): a held contact that detection no
  /// longer finds (lingering) is released when its vertex is farther from the point it is held
  /// against than one cell of the partner's mesh (the contact triangle's longest rest edge), not only
  /// by a separating velocity. Closes the held forces of vertices that went through a body (1000 kg
  /// on 1e9 Pa: max energy 3.05e5 -> 1.30e5 J in the ledger); off by default because it also
  /// releases the probe's lingering contacts 2.5-4.4 mm above the tissue while it slides (probe
  /// tool force differs from t = 1.906 s, by up to 0.25 N). false: session 8's release, bit for bit.
  bool release_distant_held_contacts = false;
  /// Beyond the paper, opt-in (session 10, docs/contact-surface.md "Resting churn, session 10"): a
  /// contact between two movable deformable bodies holds min(held_force_fraction,
  /// deformable_pair_held_force_fraction, 1 / (1 + (omega dt / 2)^2)) of its normal force, omega^2 =
  /// k / m the pair's contact mode (derived_held_fraction.h): the force an energy-conserving
  /// (trapezoidal) step of that contact spring applies from a state at rest. Scene value "derived".
  /// false: session 9's rule, bit for bit.
  bool deformable_pair_held_force_derived = false;
  /// Beyond the paper, opt-in (session 15, docs/experiments.md "Session 15"; scene value
  /// `"limit_friction_move": "charge_returns"`): with limit_friction_move on, the limit charges a
  /// friction move's whole deforming part, also the part that returns a stuck patch to where the
  /// step's integration relaxed it from, which session 10 excused. Between two movable deformable
  /// bodies stiff within the step ((omega dt)^2 > 1 in plane: the membrane stack's clamped bottom
  /// pair under sleepers) those returns store more strain each step than the friction impulses
  /// remove, and the pair churns for ever; under a held probe the same returns are the stick, so the
  /// probe's tool force changes with this on (by up to 0.30 N from t = 1.388 s).
  /// false: session 10's limit, bit for bit.
  bool limit_friction_move_charges_returns = false;
  /// Beyond the paper, opt-in (session 16, docs/stability.md "Session 16"; scene value
  /// `"limit_friction_move": "charge_deformable_returns"`): with limit_friction_move_charges_returns,
  /// a body whose friction moves of the step were all against kinematic partners (instruments) keeps
  /// session 10's excuse for returns; a body with a friction move against a deformable (or sleeping)
  /// partner has its returns charged. The probe's tool force is then byte-identical; not the default
  /// because Stability.SurfaceMilligramBodyWithASliver fails (0 -> 23.4x, the charge between the 1 mg
  /// body and its block) and the instrument rows at dt 20 ms lose the charge's gain.
  /// false: session 15's charge bit for bit.
  bool limit_friction_move_excuses_instrument_returns = false;
  /// Beyond the paper, opt-in (session 17, docs/stability.md "Session 17"; scene value
  /// `"limit_friction_move": "energy_flow"`): with limit_friction_move on, a body's deforming friction
  /// move r, returns included, costs its strain energy in the model's own (corotated, rest-shape)
  /// stiffness and is charged against the impulses' kinetic energy B plus implicit Euler's kinetic
  /// dissipation at the moved vertices, sum m |v_{n+1} - v_n|^2 / 2. A return that undoes a dynamic
  /// relaxation (omega dt below ~1: the probe's dragged patch, cost <= 0.37 of that budget) is kept;
  /// one that re-strains a patch the step let relax quasi-statically (omega dt >> 1: the matrix's
  /// instrument at dt 20 ms, nu 0.499, cost 10-800x) is scaled. Overrides the two settings above.
  /// Off by default: Stability.SurfaceMilligramBodyWithASliver fails with it (0 -> 86.7x: the 1 mg
  /// block's returns are quasi-static and charged, and M6b's search bursts then land higher), and the
  /// membrane stack rests with it at 1 of 3 starts (charge_returns: 3 of 3).
  /// false: the rule those settings select, bit for bit.
  bool limit_friction_move_energy_flow = false;
};

}  // namespace pliant
