// Contact inside the implicit solve (session 6, docs/contact-surface.md "Contact inside the
// implicit solve"). First the model's constrained step (filtered CG, Baraff & Witkin 1998 sec. 5.3)
// against a dense KKT solve of the same linear system and against the unconstrained step; then the
// contact stage that re-solves a body's step with its contact vertices' normal positions prescribed.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "sim/model/corotational_fem.h"
#include "support/clamped_beam.h"
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
                                 const std::vector<Vec3>& normals, const std::vector<double>& normal_velocity) {
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
        for (int r = 0; r < 3; ++r) kkt(static_cast<Eigen::Index>(3 * i) + r, col) = h * (beta + h) * column[i][r];
      }
      kkt(col, col) += (1.0 + h * alpha) * beam.masses[j];
      b(col) = h * (f[j][c] + beam.external[j][c] - alpha * beam.masses[j] * v[j][c]) - h * (beta + h) * kv[j][c];
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

// Steps the beam `steps` times unconstrained (K' exact: no reuse), leaving a bent, moving state.
void sag(CorotationalFem& fem, SaggingBeam& beam, int steps) {
  fem.set_stiffness_rotation_tolerance(0.0);
  for (int s = 0; s < steps; ++s) fem.advance(beam.x, beam.v, beam.input());
}

TEST(ConstrainedImplicitStep, MatchesADenseKktSolveAndKeepsEveryNormalComponent) {
  SaggingBeam beam;
  CorotationalFem fem(beam.mesh, beam.material, precise());
  sag(fem, beam, 6);
  const std::vector<Vec3> x0 = beam.x, v0 = beam.v;
  const size_t n = x0.size();
  // Hold the tip's bottom vertices against slightly tilted floors (push up), moving up at 1 cm/s.
  std::vector<Vec3> normals(n, Vec3::Zero());
  std::vector<double> normal_velocity(n, 0.0);
  const auto held = tip_bottom_vertices(beam);
  ASSERT_EQ(held.size(), 3u);
  for (size_t k = 0; k < held.size(); ++k) {
    normals[held[k]] = Vec3(0.1 * static_cast<double>(k), -0.2, 1.0).normalized();
    normal_velocity[held[k]] = 0.01;
  }
  const DenseStep reference = dense_constrained_step(fem, beam, x0, v0, held, normals, normal_velocity);
  std::vector<Vec3> forces(n, Vec3::Zero());
  IntegrationInput in = beam.input();
  in.constraint_normals = normals;
  in.constraint_normal_velocities = normal_velocity;
  in.constraint_forces = forces;
  fem.advance(beam.x, beam.v, in);
  std::vector<Vec3> dv(n);
  for (size_t i = 0; i < n; ++i) dv[i] = beam.v[i] - v0[i];
  EXPECT_LE(max_difference(dv, reference.dv), 1e-9 * max_norm(reference.dv));
  EXPECT_LE(max_difference(forces, reference.force), 1e-7 * max_norm(reference.force));
  for (size_t i : held) {
    EXPECT_NEAR(beam.v[i].dot(normals[i]), 0.01, 1e-12);
    EXPECT_GT(forces[i].dot(normals[i]), 0.0);  // the floors push (gravity pulls the tip down)
    EXPECT_NEAR((beam.x[i] - x0[i]).dot(normals[i]), 5e-3 * 0.01, 1e-12);
  }
}

TEST(ConstrainedImplicitStep, KeepsTheNormalComponentsExactlyAtTheDefaultAccuracy) {
  SaggingBeam beam;
  CorotationalFem fem(beam.mesh, beam.material, ModelSettings{});  // 20 iterations, 1e-6
  sag(fem, beam, 6);
  const size_t n = beam.x.size();
  std::vector<Vec3> normals(n, Vec3::Zero());
  std::vector<double> normal_velocity(n, 0.0);
  // A third of the free vertices constrained, each along its own direction and velocity; the ones
  // that would pull are released (zero force), every kept one must hold its component exactly.
  for (size_t i = 0; i < n; ++i) {
    if (beam.fixed[i] != 0 || i % 3 != 0) continue;
    normals[i] = Vec3(std::sin(double(i)), std::cos(double(i)), 2.0).normalized();
    normal_velocity[i] = 0.02 * std::cos(3.0 * double(i));
  }
  IntegrationInput in = beam.input();
  in.constraint_normals = normals;
  in.constraint_normal_velocities = normal_velocity;
  std::vector<Vec3> forces(n, Vec3::Zero());
  in.constraint_forces = forces;
  fem.advance(beam.x, beam.v, in);
  int kept = 0;
  for (size_t i = 0; i < n; ++i) {
    if (normals[i].isZero() || forces[i].isZero()) continue;  // free, or released (it pulled)
    EXPECT_NEAR(beam.v[i].dot(normals[i]), normal_velocity[i], 1e-12);
    ++kept;
  }
  EXPECT_GT(kept, 3);
}

TEST(ConstrainedImplicitStep, EqualsTheUnconstrainedStepWhereNoConstraintBinds) {
  SaggingBeam beam;
  CorotationalFem fem(beam.mesh, beam.material, precise());
  sag(fem, beam, 6);
  const std::vector<Vec3> x0 = beam.x, v0 = beam.v;
  const size_t n = x0.size();
  // The free step, on a copy of the state.
  std::vector<Vec3> x_free = x0, v_free = v0;
  fem.advance(x_free, v_free, beam.input());
  // Prescribe exactly what the free step gives: nothing binds, the forces vanish.
  std::vector<Vec3> normals(n, Vec3::Zero());
  std::vector<double> normal_velocity(n, 0.0);
  for (size_t i : tip_bottom_vertices(beam)) {
    normals[i] = Vec3(0.0, 0.3, 1.0).normalized();
    normal_velocity[i] = v_free[i].dot(normals[i]);
  }
  std::vector<Vec3> forces(n, Vec3::Zero());
  IntegrationInput in = beam.input();
  in.constraint_normals = normals;
  in.constraint_normal_velocities = normal_velocity;
  in.constraint_forces = forces;
  fem.advance(beam.x, beam.v, in);
  EXPECT_LE(max_difference(beam.v, v_free), 1e-9 * max_norm(v_free));
  EXPECT_LE(max_difference(beam.x, x_free), 1e-12);
  // Largest free-step force scale: the tip's weight (N).
  EXPECT_LE(max_norm(forces), 1e-6 * beam.masses[tip_bottom_vertices(beam)[0]] * 9.81);
}

TEST(ConstrainedImplicitStep, ReleasesAConstraintThatWouldPull) {
  SaggingBeam beam;
  CorotationalFem fem(beam.mesh, beam.material, precise());
  sag(fem, beam, 6);
  const std::vector<Vec3> x0 = beam.x, v0 = beam.v;
  const size_t n = x0.size();
  std::vector<Vec3> x_free = x0, v_free = v0;
  fem.advance(x_free, v_free, beam.input());
  // A "floor" pushing up that would have to drag the tip down faster than it falls: adhesion.
  std::vector<Vec3> normals(n, Vec3::Zero());
  std::vector<double> normal_velocity(n, 0.0);
  for (size_t i : tip_bottom_vertices(beam)) {
    normals[i] = Vec3::UnitZ();
    normal_velocity[i] = v_free[i].z() - 0.5;
  }
  std::vector<Vec3> forces(n, Vec3::Zero());
  IntegrationInput in = beam.input();
  in.constraint_normals = normals;
  in.constraint_normal_velocities = normal_velocity;
  in.constraint_forces = forces;
  fem.advance(beam.x, beam.v, in);
  EXPECT_EQ(max_norm(forces), 0.0);  // released: no constraint pulls
  EXPECT_LE(max_difference(beam.v, v_free), 1e-9 * max_norm(v_free));
}

}  // namespace
}  // namespace pliant
