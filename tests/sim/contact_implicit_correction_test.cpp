// Contact inside the implicit solve (session 6, docs/contact-surface.md "Contact inside the
// implicit solve"). First the model's constrained step (filtered CG, Baraff & Witkin 1998 sec. 5.3)
// against a dense KKT solve of the same linear system and against the unconstrained step; then the
// contact stage that re-solves a body's step with its contact vertices' normal positions prescribed.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "sim/mesh/box_mesh.h"
#include "sim/model/corotational_fem.h"
#include "sim/world.h"
#include "support/clamped_beam.h"
#include "support/drop_on_floor.h"
#include "support/vec_compare.h"

namespace pliant {
namespace {

ModelSettings precise() {
  ModelSettings s;
  s.accuracy.max_solver_iterations = 5000;
  s.accuracy.solver_tolerance = 1e-13;
  return s;
}

// A beam sagging under gravity, stepped a few times so x_n is rotated and v_n is not zero.
struct SaggingBeam : ClampedBeam {
  SaggingBeam() : ClampedBeam(4, [](const Vec3&, double m) { return Vec3(m * Vec3(0.0, 0.0, -9.81)); }) {}
};

// Bottom vertices of the free end: the ones a floor under the tip would hold.
std::vector<size_t> tip_bottom_vertices(const SaggingBeam& beam) {
  std::vector<size_t> out;
  const auto& rest = beam.mesh->rest_positions();
  for (size_t i = 0; i < rest.size(); ++i) {
    if (rest[i].x() > 0.5 - 1e-9 && rest[i].z() < -0.05 + 1e-9) out.push_back(i);
  }
  return out;
}

// Dense reference of one constrained step from (x, v): the system A dv = rhs + N mu, N^T dv = d
// with A = (1 + h alpha) M + h (beta + h) K' (K' at x, built column by column from the model's
// product), rhs = h (f(x) + f_ext - alpha M v) - h (beta + h) K' v; fixed vertices removed.
// Returns dv and the constraint forces mu_k n_k / h.
struct DenseStep {
  std::vector<Vec3> dv;
  std::vector<Vec3> force;
};
DenseStep dense_constrained_step(CorotationalFem& fem, const SaggingBeam& beam, std::span<const Vec3> x,
                                 std::span<const Vec3> v, const std::vector<size_t>& constrained,
                                 const std::vector<Vec3>& normals,
                                 const std::vector<double>& normal_velocity) {
  const double h = 5e-3;
  const double alpha = beam.material.mass_damping, beta = beam.material.stiffness_damping;
  const size_t n = x.size();
  fem.update_rotations(x);
  std::vector<Vec3> f(n), unit(n, Vec3::Zero()), column(n), kv(n);
  fem.internal_forces(x, f);
  fem.update_rotations(x);
  fem.apply_stiffness(v, kv);
  const auto dofs = static_cast<Eigen::Index>(3 * n);
  const auto m = static_cast<Eigen::Index>(constrained.size());
  Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(dofs + m, dofs + m);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(dofs + m);
  for (size_t j = 0; j < n; ++j) {
    for (int c = 0; c < 3; ++c) {
      const auto col = static_cast<Eigen::Index>(3 * j) + c;
      if (beam.fixed[j] != 0) {
        kkt(col, col) = 1.0;  // dv = 0
        continue;
      }
      unit[j][c] = 1.0;
      fem.apply_stiffness(unit, column);
      unit[j][c] = 0.0;
      for (size_t i = 0; i < n; ++i) {
        if (beam.fixed[i] != 0) continue;
        for (int r = 0; r < 3; ++r)
          kkt(static_cast<Eigen::Index>(3 * i) + r, col) = h * (beta + h) * column[i][r];
      }
      kkt(col, col) += (1.0 + h * alpha) * beam.masses[j];
      b(col) =
          h * (f[j][c] + beam.external[j][c] - alpha * beam.masses[j] * v[j][c]) - h * (beta + h) * kv[j][c];
    }
  }
  for (Eigen::Index k = 0; k < m; ++k) {
    const size_t i = constrained[static_cast<size_t>(k)];
    for (int r = 0; r < 3; ++r) {
      kkt(static_cast<Eigen::Index>(3 * i) + r, dofs + k) = -normals[i][r];
      kkt(dofs + k, static_cast<Eigen::Index>(3 * i) + r) = normals[i][r];
    }
    b(dofs + k) = normal_velocity[i] - v[i].dot(normals[i]);
  }
  const Eigen::VectorXd s = kkt.fullPivLu().solve(b);
  DenseStep out{std::vector<Vec3>(n), std::vector<Vec3>(n, Vec3::Zero())};
  for (size_t i = 0; i < n; ++i) out.dv[i] = s.segment<3>(static_cast<Eigen::Index>(3 * i));
  for (Eigen::Index k = 0; k < m; ++k) {
    const size_t i = constrained[static_cast<size_t>(k)];
    out.force[i] = normals[i] * (s(dofs + k) / h);
  }
  return out;
}

// The sagging beam stepped 6 times unconstrained (K' exact: no reuse), leaving a bent, moving state
// x0, v0 (the start of the constrained step).
struct BentBeam {
  SaggingBeam beam;
  CorotationalFem fem;
  std::vector<Vec3> x0, v0;
  explicit BentBeam(const ModelSettings& settings) : fem(beam.mesh, beam.material, settings) {
    fem.set_stiffness_rotation_tolerance(0.0);
    for (int s = 0; s < 6; ++s) fem.advance(beam.x, beam.v, beam.input());
    x0 = beam.x;
    v0 = beam.v;
  }
  size_t size() const { return x0.size(); }
  /// The free (unconstrained) step from (x0, v0) on a copy of the state: its v_{n+1}, x_{n+1}.
  std::pair<std::vector<Vec3>, std::vector<Vec3>> free_step() {
    std::vector<Vec3> x = x0, v = v0;
    fem.advance(x, v, beam.input());
    return {v, x};
  }
};

// One step's per-vertex constraints (zero normal: free vertex) and the forces the solve reports.
struct Constraints {
  std::vector<Vec3> normals;
  std::vector<double> normal_velocity;
  std::vector<Vec3> forces;
  explicit Constraints(size_t n)
      : normals(n, Vec3::Zero()), normal_velocity(n, 0.0), forces(n, Vec3::Zero()) {}
  /// Advances the bent beam's state one constrained step (forces filled).
  void advance(BentBeam& b) {
    IntegrationInput in = b.beam.input();
    in.constraint_normals = normals;
    in.constraint_normal_velocities = normal_velocity;
    in.constraint_forces = forces;
    b.fem.advance(b.beam.x, b.beam.v, in);
  }
};

TEST(ConstrainedImplicitStep, MatchesADenseKktSolveAndKeepsEveryNormalComponent) {
  BentBeam b(precise());
  // Hold the tip's bottom vertices against slightly tilted floors (push up), moving up at 1 cm/s.
  Constraints c(b.size());
  const auto held = tip_bottom_vertices(b.beam);
  ASSERT_EQ(held.size(), 3u);
  for (size_t k = 0; k < held.size(); ++k) {
    c.normals[held[k]] = Vec3(0.1 * static_cast<double>(k), -0.2, 1.0).normalized();
    c.normal_velocity[held[k]] = 0.01;
  }
  const DenseStep reference =
      dense_constrained_step(b.fem, b.beam, b.x0, b.v0, held, c.normals, c.normal_velocity);
  c.advance(b);
  std::vector<Vec3> dv(b.size());
  for (size_t i = 0; i < b.size(); ++i) dv[i] = b.beam.v[i] - b.v0[i];
  EXPECT_LE(max_difference(dv, reference.dv), 1e-9 * max_norm(reference.dv));
  EXPECT_LE(max_difference(c.forces, reference.force), 1e-7 * max_norm(reference.force));
  for (size_t i : held) {
    EXPECT_NEAR(b.beam.v[i].dot(c.normals[i]), 0.01, 1e-12);
    EXPECT_GT(c.forces[i].dot(c.normals[i]), 0.0);  // the floors push (gravity pulls the tip down)
    EXPECT_NEAR((b.beam.x[i] - b.x0[i]).dot(c.normals[i]), 5e-3 * 0.01, 1e-12);
  }
}

TEST(ConstrainedImplicitStep, KeepsTheNormalComponentsExactlyAtTheDefaultAccuracy) {
  BentBeam b(ModelSettings{});  // 20 iterations, 1e-6
  Constraints c(b.size());
  // A third of the free vertices constrained, each along its own direction and velocity; the ones
  // that would pull are released (zero force), every kept one must hold its component exactly.
  for (size_t i = 0; i < b.size(); ++i) {
    if (b.beam.fixed[i] != 0 || i % 3 != 0) continue;
    c.normals[i] = Vec3(std::sin(double(i)), std::cos(double(i)), 2.0).normalized();
    c.normal_velocity[i] = 0.02 * std::cos(3.0 * double(i));
  }
  c.advance(b);
  int kept = 0;
  for (size_t i = 0; i < b.size(); ++i) {
    if (c.normals[i].isZero() || c.forces[i].isZero()) continue;  // free, or released (it pulled)
    EXPECT_NEAR(b.beam.v[i].dot(c.normals[i]), c.normal_velocity[i], 1e-12);
    ++kept;
  }
  EXPECT_GT(kept, 3);
}

TEST(ConstrainedImplicitStep, EqualsTheUnconstrainedStepWhereNoConstraintBinds) {
  BentBeam b(precise());
  const auto [v_free, x_free] = b.free_step();
  // Prescribe exactly what the free step gives: nothing binds, the forces vanish.
  Constraints c(b.size());
  for (size_t i : tip_bottom_vertices(b.beam)) {
    c.normals[i] = Vec3(0.0, 0.3, 1.0).normalized();
    c.normal_velocity[i] = v_free[i].dot(c.normals[i]);
  }
  c.advance(b);
  EXPECT_LE(max_difference(b.beam.v, v_free), 1e-9 * max_norm(v_free));
  EXPECT_LE(max_difference(b.beam.x, x_free), 1e-12);
  // Largest free-step force scale: the tip's weight (N).
  EXPECT_LE(max_norm(c.forces), 1e-6 * b.beam.masses[tip_bottom_vertices(b.beam)[0]] * 9.81);
}

TEST(ConstrainedImplicitStep, ReleasesAConstraintThatWouldPull) {
  BentBeam b(precise());
  const auto [v_free, x_free] = b.free_step();
  // A "floor" pushing up that would have to drag the tip down faster than it falls: adhesion.
  Constraints c(b.size());
  for (size_t i : tip_bottom_vertices(b.beam)) {
    c.normals[i] = Vec3::UnitZ();
    c.normal_velocity[i] = v_free[i].z() - 0.5;
  }
  c.advance(b);
  EXPECT_EQ(max_norm(c.forces), 0.0);  // released: no constraint pulls
  EXPECT_LE(max_difference(b.beam.v, v_free), 1e-9 * max_norm(v_free));
}

// ---- The contact stage (World with ContactSettings::implicit_correction) ----

Material tissue(double young, double poisson, double mu) {
  Material m;
  m.young_modulus = young;
  m.poisson_ratio = poisson;
  m.density = 1000.0;
  m.mass_damping = 1.0;
  m.stiffness_damping = 0.01;
  m.friction = mu;
  return m;
}

// The mode's scene-key name.
const char* name(ImplicitCorrection scope) {
  switch (scope) {
    case ImplicitCorrection::off:
      return "off";
    case ImplicitCorrection::stiff_partners:
      return "stiff_partners";
    case ImplicitCorrection::all:
      return "all";
    case ImplicitCorrection::coupled:
      return "coupled";
  }
  return "?";
}

constexpr double kCellHeight = 0.01;  // m, the dropped block's cell height (20 mm in 2 cells)

// tests/support/drop_on_floor.h's drop with the correction in `scope` and held forces at
// `held_fraction`; no adhesion: every constraint force on the block pushes it up, off the floor.
double corrected_drop_ratio(const Material& m, double dt, ImplicitCorrection scope,
                            double held_fraction = 1.0) {
  ContactSettings contact;
  contact.implicit_correction = scope;
  contact.held_force_fraction = held_fraction;
  return drop_energy_ratio(m, dt, contact, [](const World& world, BodyId id) {
    for (const Vec3& f : world.implicit_contact_correction().constraint_forces(static_cast<int>(id.index))) {
      EXPECT_GE(f.z(), 0.0);
    }
  });
}

// The disabled mechanism test's case (nu 0.499, CFL 4.1: 12.7x without the correction) with the
// correction: the dent is spread over the depth the implicit step reaches, the drop loses energy.
TEST(ImplicitContactCorrection, DropOnAFloorAboveTheContactLayerCflLosesEnergy) {
  const Material m = tissue(1e4, 0.499, 0.2);
  const double dt = 1e-3;
  ASSERT_GT(m.pressure_wave_speed() * dt / kCellHeight, 4.0);
  EXPECT_LE(corrected_drop_ratio(m, dt, ImplicitCorrection::all), 1.1);
  EXPECT_LE(corrected_drop_ratio(m, dt, ImplicitCorrection::stiff_partners), 1.1);
}

// The drop's energy ratio across the contact layer's CFL number, without and with the correction
// (the correction turns held forces off; the third column asks for them off explicitly, the same
// run): the table of docs/contact-surface.md.
// Every row with the correction stays within 1.1x the release energy.
TEST(ImplicitContactCorrection, DropEnergyRatioAcrossCfl) {
  struct Row {
    double young, poisson, dt;
  };
  for (const Row& row : {Row{1e4, 0.3, 1e-3}, Row{1e5, 0.3, 1e-3}, Row{1e4, 0.3, 5e-3}, Row{1e6, 0.3, 1e-3},
                         Row{1e4, 0.499, 1e-3}, Row{1e7, 0.3, 1e-3}, Row{1e5, 0.499, 1e-3}}) {
    const Material m = tissue(row.young, row.poisson, 0.2);
    const double on = corrected_drop_ratio(m, row.dt, ImplicitCorrection::all);
    const double scoped = corrected_drop_ratio(m, row.dt, ImplicitCorrection::stiff_partners);
    // coupled: a single body on a kinematic floor has no free-free contact, so it is `all` exactly.
    EXPECT_EQ(corrected_drop_ratio(m, row.dt, ImplicitCorrection::coupled), on)
        << row.young << " " << row.poisson;
    std::printf(
        "E %.0e nu %.3f dt %.0e CFL %.2f: off %.3g  all %.3g  all, held off %.3g  stiff_partners %.3g\n",
        row.young, row.poisson, row.dt, m.pressure_wave_speed() * row.dt / kCellHeight,
        corrected_drop_ratio(m, row.dt, ImplicitCorrection::off), on,
        corrected_drop_ratio(m, row.dt, ImplicitCorrection::all, 0.0), scoped);
    EXPECT_LE(on, 1.1) << row.young << " " << row.poisson << " " << row.dt;
    // Scoped, held forces stay on (as off) and act in the steps the block leaves the floor: the
    // last row measured 1.49x (off 467x, all 0.54x); every other row equals `all`.
    EXPECT_LE(scoped, row.young == 1e5 && row.poisson == 0.499 ? 1.6 : 1.1)
        << row.young << " " << row.poisson;
  }
}

// A 30 mm block (2 x 2 x 2 cells, E 1 MPa) resting on a kinematic floor, dt 1 ms, frictionless.
struct RestingBlock {
  World world;
  BodyId block, floor;
  double mass = 0.0;
  explicit RestingBlock(bool correction, ImplicitCorrection scope = ImplicitCorrection::all) {
    world.settings().contact.implicit_correction = correction ? scope : ImplicitCorrection::off;
    world.settings().contact.friction = false;
    Material m = tissue(1e6, 0.3, 0.0);
    m.mass_damping = 0.0;
    m.stiffness_damping = 1e-3;
    BodyDef b{.name = "block", .mesh = make_box_mesh({Vec3(0.03, 0.03, 0.03), 2, 2, 2}), .material = m};
    b.pose.translation = Vec3(0.0013, -0.0007, 0.015);
    block = world.add_body(b);
    mass = world.body(block).total_mass();
    BodyDef f{.name = "floor",
              .mesh = make_box_mesh({Vec3(0.5, 0.5, 0.02), 4, 4, 1}),
              .material = m,
              .motion = BodyMotion::kinematic};
    f.pose.translation = Vec3(0, 0, -0.01);
    floor = world.add_body(f);
  }
};

// At rest the floor carries the block's weight: the reported reaction on the floor (minus the
// constraint forces) averaged over the last 0.1 s is -m g within 2%, and the block's constraint
// forces equal minus that reaction every step (Newton's third law between the reported haptic force
// and the forces the solve applied). No constraint force pulls.
TEST(ImplicitContactCorrection, ABlockAtRestOnAFloorCarriesItsWeight) {
  RestingBlock s(true);
  const double dt = 1e-3;
  Vec3 mean = Vec3::Zero();
  int counted = 0;
  double kinetic_late = 0.0;
  for (int i = 1; i <= 500; ++i) {
    const StepReport& r = s.world.step(dt);
    ASSERT_EQ(r.fault, StepFault::none) << i;
    ASSERT_EQ(r.reactions.size(), 1u);
    Vec3 on_block = Vec3::Zero();
    for (const Vec3& f :
         s.world.implicit_contact_correction().constraint_forces(static_cast<int>(s.block.index))) {
      EXPECT_GE(f.z(), 0.0) << i;
      on_block += f;
    }
    EXPECT_LE((on_block + r.reactions[0].force).norm(), 1e-12 * std::max(1.0, on_block.norm())) << i;
    if (i > 400) {
      mean += r.reactions[0].force;
      ++counted;
      kinetic_late = std::max(kinetic_late, r.energy.kinetic);
    }
  }
  mean /= counted;
  const double weight = s.mass * 9.81;
  std::printf("floor reaction %.6f %.6f %.6f N, weight %.6f N, late KE %.3g J\n", mean.x(), mean.y(),
              mean.z(), weight, kinetic_late);
  EXPECT_NEAR(mean.z(), -weight, 0.02 * weight);
  EXPECT_LE(std::hypot(mean.x(), mean.y()), 0.02 * weight);
}

// Two free blocks (no gravity, frictionless) pushed into each other, 100 steps of 1 ms, with the
// correction in `scope`. Returns the largest |p_a + p_b| over the run (N s; the reference: no
// external force acts, and the blocks bring in equal and opposite momenta, so it stays 0), and the
// largest |sum of both blocks' constraint forces| relative to the largest single one (coupled: 0
// by construction, the pair forces are equal and opposite).
// `passes`: the coupled CG's re-solve passes over the run, `capped`: steps that ended at the pass cap
// with a gap error above the tolerance.
struct HeadOn {
  double worst_momentum = 0.0, brought = 0.0, force_imbalance = 0.0;
  int corrected = 0, coupled = 0, passes = 0, capped = 0;
};
HeadOn collide_head_on(ImplicitCorrection scope, const ModelSettings& model = {}, bool block_preconditioner = true) {
  World world;
  world.settings().gravity = Vec3::Zero();
  world.settings().contact.implicit_correction = scope;
  world.settings().contact.coupled_block_preconditioner = block_preconditioner;
  world.settings().contact.friction = false;
  const Material m = tissue(1e5, 0.3, 0.0);
  const auto mesh = make_box_mesh({Vec3(0.03, 0.03, 0.03), 3, 3, 3});
  BodyDef a{.name = "a", .mesh = mesh, .material = m, .model_settings = model};
  a.pose.translation = Vec3(0.0, 0.0, 0.0);
  a.initial_velocity = Vec3(0, 0, 0.2);
  BodyDef b{.name = "b", .mesh = mesh, .material = m, .model_settings = model};
  b.pose.translation = Vec3(0.0011, -0.0007, 0.0305);
  b.initial_velocity = Vec3(0, 0, -0.2);
  const BodyId ia = world.add_body(a), ib = world.add_body(b);
  auto momentum = [&](BodyId id) {
    const Body& body = world.body(id);
    Vec3 p = Vec3::Zero();
    for (size_t v = 0; v < body.positions.size(); ++v) p += body.masses[v] * body.velocities[v];
    return p;
  };
  HeadOn out;
  out.brought = momentum(ia).norm();
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(world.step(1e-3).fault, StepFault::none) << i;
    const ImplicitContactCorrection& c = world.implicit_contact_correction();
    out.corrected += c.corrected_bodies();
    out.coupled += c.coupled_contacts();
    out.passes += c.coupled_passes();
    if (c.coupled_gap_error() > world.settings().contact.coupled_gap_tolerance) ++out.capped;
    out.worst_momentum = std::max(out.worst_momentum, (momentum(ia) + momentum(ib)).norm());
    Vec3 sum = Vec3::Zero();
    double largest = 0.0;
    for (const BodyId id : {ia, ib}) {
      for (const Vec3& f : c.constraint_forces(static_cast<int>(id.index))) {
        sum += f;
        largest = std::max(largest, f.norm());
      }
    }
    if (largest > 0.0) out.force_imbalance = std::max(out.force_imbalance, sum.norm() / largest);
  }
  std::printf(
      "%s: largest |p_a + p_b| %.3g of %.3g N s brought in, %d body re-solves, %d coupled contacts, "
      "constraint-force imbalance %.3g, %d passes, %d capped steps\n",
      name(scope), out.worst_momentum, out.brought, out.corrected, out.coupled, out.force_imbalance, out.passes,
      out.capped);
  return out;
}

// all: each body's constraint forces are solved separately, so Newton's third law between the
// bodies holds only as far as the contact surface the response found balances them: the total
// momentum stays within 1e-4 of the momentum each block brought in (measured 2.1e-9).
TEST(ImplicitContactCorrection, TwoFreeBlocksCollidingKeepTheirTotalMomentum) {
  const HeadOn all = collide_head_on(ImplicitCorrection::all);
  EXPECT_GT(all.corrected, 0);
  EXPECT_LE(all.worst_momentum, 1e-4 * all.brought);
}

// coupled: one normal force per free-free contact, equal and opposite on the two bodies: the sum of
// all constraint forces over the pair is zero to round-off, and the total momentum is kept to the
// solves' tolerance (1e-9 of the momentum brought in).
TEST(ImplicitContactCorrection, CoupledKeepsMomentumAndEqualAndOppositeForces) {
  const HeadOn coupled = collide_head_on(ImplicitCorrection::coupled, precise());
  // At the bodies' default accuracy (20 block-Jacobi iterations, 1e-6) the momentum error is the
  // solves' residual: held to the `all` test's bound.
  const HeadOn fast = collide_head_on(ImplicitCorrection::coupled);
  EXPECT_LE(fast.force_imbalance, 1e-12);
  EXPECT_LE(fast.worst_momentum, 1e-4 * fast.brought);
  EXPECT_GT(coupled.coupled, 0);
  EXPECT_LE(coupled.force_imbalance, 1e-12);
  EXPECT_LE(coupled.worst_momentum, 1e-9 * coupled.brought);
}

// Off (the default) the correction never runs (that the rest of the step is the previous path bit
// for bit is checked on the probe's tool_forces.csv against main, docs/contact-surface.md).
TEST(ImplicitContactCorrection, OffNeverRuns) {
  RestingBlock off(false);
  for (int i = 0; i < 50; ++i) {
    off.world.step(1e-3);
    EXPECT_EQ(off.world.implicit_contact_correction().corrected_bodies(), 0);
  }
}

// Two free stiff blocks (E 1 MPa, 30 mm, 2 x 2 x 2 cells) stacked on a frictionless kinematic floor,
// 700 steps of 1 ms with the correction in `scope`: the largest kinetic energy over the last 0.2 s
// (J), and the body re-solves over the run.
struct StackRun {
  double kinetic_late = 0.0, floor = 0.0;  ///< J; floor: one step of free fall, 0.5 m (g dt)^2
  int corrected = 0, passes = 0;           ///< passes: the coupled CG's re-solve passes
};
StackRun free_stack(ImplicitCorrection scope, bool block_preconditioner = true) {
  World world;
  world.settings().contact.implicit_correction = scope;
  world.settings().contact.coupled_block_preconditioner = block_preconditioner;
  world.settings().contact.friction = false;
  world.settings().contact.finishing_projection = true;
  Material m = tissue(1e6, 0.3, 0.0);
  m.mass_damping = 0.0;
  m.stiffness_damping = 1e-3;
  const auto mesh = make_box_mesh({Vec3(0.03, 0.03, 0.03), 2, 2, 2});
  double mass = 0.0;
  for (int k = 0; k < 2; ++k) {
    BodyDef block{.name = "block" + std::to_string(k), .mesh = mesh, .material = m};
    block.pose.translation = Vec3(0.003 * k, -0.002 * k, 0.015 + 0.03 * k);
    mass += world.body(world.add_body(block)).total_mass();
  }
  BodyDef floor{.name = "floor",
                .mesh = make_box_mesh({Vec3(0.5, 0.5, 0.02), 4, 4, 1}),
                .material = m,
                .motion = BodyMotion::kinematic};
  floor.pose.translation = Vec3(0, 0, -0.01);
  world.add_body(floor);
  const double dt = 1e-3;
  StackRun out;
  out.floor = 0.5 * mass * (9.81 * dt) * (9.81 * dt);
  for (int i = 1; i <= 700; ++i) {
    const StepReport& r = world.step(dt);
    EXPECT_EQ(r.fault, StepFault::none) << i;
    out.corrected += world.implicit_contact_correction().corrected_bodies();
    out.passes += world.implicit_contact_correction().coupled_passes();
    if (i > 500) out.kinetic_late = std::max(out.kinetic_late, r.energy.kinetic);
  }
  std::printf("free stack, %s: late KE %.3g J (floor %.3g J), %d re-solves, %d coupled passes\n", name(scope),
              out.kinetic_late, out.floor, out.corrected, out.passes);
  return out;
}

// KNOWN FAILURE (session 6): the free stack with `all`: each body's constraint forces come from
// its own solve, so between the two deformable blocks they are not equal and opposite; along the
// contact triangles' slightly tilted normals the difference is a steady horizontal force
// (measured: the lower block's centre of mass accelerates at ~2e-2 m/s^2 sideways, the upper one
// the other way at a seventh of that, total momentum not kept) until the stack slides apart at
// ~0.47 s (KE 1e-2 J). tests/sim/contact_resting_churn_test.cpp with
// PLIANT_CHURN_IMPLICIT_CORRECTION=1: late KE 0.169 J (0.158 J with mu 0.5) against the floor
// 2.6e-6 J. The coupled mode (below) is the fix.
TEST(ImplicitContactCorrection, DISABLED_TwoStackedBlocksRestAtOneMillisecond) {
  const StackRun all = free_stack(ImplicitCorrection::all);
  EXPECT_LT(all.kinetic_late, all.floor);
}

// Scoped (ImplicitCorrection::stiff_partners), the block on the kinematic floor is re-solved every
// contact step, held forces on: the floor's reported reaction (constraint plus held force) averaged
// over the last 0.1 s carries m g within 2%, and the block's late kinetic energy stays below that of
// one step of free fall, 0.5 m (g dt)^2.
TEST(ImplicitContactCorrection, StiffPartnersBlockAtRestOnAFloorCarriesItsWeight) {
  RestingBlock s(true, ImplicitCorrection::stiff_partners);
  const double dt = 1e-3;
  Vec3 mean = Vec3::Zero();
  int counted = 0, corrected = 0;
  double kinetic_late = 0.0;
  for (int i = 1; i <= 500; ++i) {
    const StepReport& r = s.world.step(dt);
    ASSERT_EQ(r.fault, StepFault::none) << i;
    ASSERT_EQ(r.reactions.size(), 1u);
    corrected += s.world.implicit_contact_correction().corrected_bodies();
    if (i > 400) {
      mean += r.reactions[0].force;
      ++counted;
      kinetic_late = std::max(kinetic_late, r.energy.kinetic);
    }
  }
  mean /= counted;
  const double weight = s.mass * 9.81;
  std::printf("scoped: floor reaction %.6f %.6f %.6f N, weight %.6f N, late KE %.3g J, %d re-solves\n",
              mean.x(), mean.y(), mean.z(), weight, kinetic_late, corrected);
  EXPECT_GT(corrected, 100);
  EXPECT_NEAR(mean.z(), -weight, 0.02 * weight);
  EXPECT_LE(std::hypot(mean.x(), mean.y()), 0.02 * weight);
  EXPECT_LT(kinetic_late, 0.5 * s.mass * (9.81 * dt) * (9.81 * dt));
}

// Two free stiff blocks stacked on a kinematic floor (the disabled test's case), dt 1 ms, run with
// the correction off and scoped. The lower block touches the upper one (a free deformable partner),
// so it is re-solved only in steps where no contact or held force between the blocks exists
// (measured: 1 step, the first). Reference: the off run. The off run does not meet the disabled
// test's absolute bound either (late KE 4.1e-5 J against 0.5 m (g dt)^2 = 2.6e-6 J), so the scoped
// run's late kinetic energy is held to 1.5x the off run's (measured 4.55e-5 J, 1.11x; `all`: 0.169 J).
TEST(ImplicitContactCorrection, StiffPartnersLeavesAFreeStackRestingAsWithTheCorrectionOff) {
  const StackRun off = free_stack(ImplicitCorrection::off);
  const StackRun scoped = free_stack(ImplicitCorrection::stiff_partners);
  EXPECT_LE(scoped.corrected, 5);
  EXPECT_LE(scoped.kinetic_late, 1.5 * off.kinetic_late);
}

// The free stack with the pair coupled (session 7): every step re-solves both blocks.
TEST(ImplicitContactCorrection, CoupledFreeStackRestsAtOneMillisecond) {
  const StackRun coupled = free_stack(ImplicitCorrection::coupled);
  EXPECT_GT(coupled.corrected, 600);
  EXPECT_LT(coupled.kinetic_late, coupled.floor);
}

// The contact-force CG preconditioned by the bodies' diagonal system blocks (session 8, the default)
// against session 7's mass-only scale, on the head-on impact (precise solves) and the free stack:
// the same physics bounds hold with either (momentum to 1e-9 of what was brought in, the stack
// under the one-step floor), and the block preconditioner needs fewer re-solve passes (a CG is
// invariant to a uniform scale, so this measures how much better D's per-contact ratios are).
TEST(ImplicitContactCorrection, CoupledBlockPreconditionerNeedsFewerPasses) {
  const HeadOn block = collide_head_on(ImplicitCorrection::coupled, precise(), true);
  const HeadOn mass = collide_head_on(ImplicitCorrection::coupled, precise(), false);
  for (const HeadOn* run : {&block, &mass}) {
    EXPECT_LE(run->force_imbalance, 1e-12);
    EXPECT_LE(run->worst_momentum, 1e-9 * run->brought);
  }
  EXPECT_LT(block.passes, mass.passes);
  const StackRun stack_block = free_stack(ImplicitCorrection::coupled, true);
  const StackRun stack_mass = free_stack(ImplicitCorrection::coupled, false);
  EXPECT_LT(stack_block.kinetic_late, stack_block.floor);
  EXPECT_LT(stack_mass.kinetic_late, stack_mass.floor);
  EXPECT_LE(stack_block.passes, stack_mass.passes);
}

// Two free blocks (no gravity, no other body) colliding: every contact is between two free
// deformable bodies, so the scoped correction never re-solves and the run is the off run bit for
// bit (every vertex's position and velocity after 0.1 s).
TEST(ImplicitContactCorrection, StiffPartnersOnFreeBodiesOnlyIsTheOffPathBitForBit) {
  auto run = [](ImplicitCorrection scope, int& corrected) {
    auto world = std::make_unique<World>();
    world->settings().gravity = Vec3::Zero();
    world->settings().contact.implicit_correction = scope;
    const Material m = tissue(1e5, 0.3, 0.2);
    const auto mesh = make_box_mesh({Vec3(0.03, 0.03, 0.03), 3, 3, 3});
    BodyDef a{.name = "a", .mesh = mesh, .material = m};
    a.initial_velocity = Vec3(0, 0, 0.2);
    BodyDef b{.name = "b", .mesh = mesh, .material = m};
    b.pose.translation = Vec3(0.0011, -0.0007, 0.0305);
    b.initial_velocity = Vec3(0, 0, -0.2);
    world->add_body(a);
    world->add_body(b);
    corrected = 0;
    int contact_steps = 0;
    for (int i = 0; i < 100; ++i) {
      EXPECT_EQ(world->step(1e-3).fault, StepFault::none) << i;
      corrected += world->implicit_contact_correction().corrected_bodies();
      contact_steps += world->contacts().empty() ? 0 : 1;
    }
    EXPECT_GT(contact_steps, 0);
    return world;
  };
  int corrected_off = 0, corrected_scoped = 0;
  const auto off = run(ImplicitCorrection::off, corrected_off);
  const auto scoped = run(ImplicitCorrection::stiff_partners, corrected_scoped);
  EXPECT_EQ(corrected_scoped, 0);
  for (int b = 0; b < 2; ++b) {
    const Body& x = off->body(off->body_id(b));
    const Body& y = scoped->body(scoped->body_id(b));
    for (size_t v = 0; v < x.positions.size(); ++v) {
      ASSERT_EQ(x.positions[v], y.positions[v]) << b << " " << v;
      ASSERT_EQ(x.velocities[v], y.velocities[v]) << b << " " << v;
    }
  }
}

}  // namespace
}  // namespace pliant
