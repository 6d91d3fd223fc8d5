// Corotational FEM against references: the patch test (uniform F, no net interior force), K' equals
// the finite-difference Hessian at rest, the assembled and matrix-free K' agree, a cantilever under
// its own weight converges to Euler-Bernoulli (+ Timoshenko shear), energy never grows without
// damping, inverted and flattened elements recover, and a stiff body at a large step stays finite.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "sim/mesh/box_mesh.h"
#include "sim/model/corotational_fem.h"
#include "support/vec_compare.h"

namespace pliant {
namespace {

Material material(double E, double nu, double alpha = 0.0, double beta = 0.0) {
  Material m;
  m.young_modulus = E;
  m.poisson_ratio = nu;
  m.density = 1000.0;
  m.mass_damping = alpha;
  m.stiffness_damping = beta;
  return m;
}

ModelSettings precise(int iterations = 5000, double tolerance = 1e-12) {
  ModelSettings s;
  s.accuracy.max_solver_iterations = iterations;
  s.accuracy.solver_tolerance = tolerance;
  return s;
}

double norm(std::span<const Vec3> f) {
  double s = 0.0;
  for (const auto& v : f) s += v.squaredNorm();
  return std::sqrt(s);
}

std::vector<Vec3> random_field(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> p(n);
  for (auto& v : p) v = Vec3(u(rng), u(rng), u(rng));
  return p;
}

TEST(CorotationalFem, PatchTestUniformStrainGivesUniformStressAndNoInteriorForce) {
  const auto mesh = make_box_mesh({Vec3(0.3, 0.2, 0.25), 3, 3, 3});
  CorotationalFem model(mesh, material(1e5, 0.35), {});
  Mat3 A;
  A << 1.05, 0.03, -0.02, 0.01, 0.97, 0.04, -0.03, 0.02, 1.08;
  const Mat3 Q = Eigen::AngleAxisd(0.8, Vec3(1, 1, 0).normalized()).toRotationMatrix();
  const Mat3 G = Q * A;  // a rotated linear field x = G X + b
  std::vector<Vec3> x = mesh->rest_positions();
  for (auto& p : x) p = G * p + Vec3(0.1, 0.2, 0.3);
  std::vector<Vec3> f(x.size());
  model.internal_forces(x, f);
  for (int t = 0; t < mesh->tet_count(); ++t) {
    EXPECT_LT((model.deformation_gradient(x, t) - G).norm(), 1e-12) << "tet " << t;
    EXPECT_LT((model.element_rotation(t) - model.element_rotation(0)).norm(), 1e-9) << "tet " << t;
  }
  double boundary_force = 0.0;
  for (int v : mesh->surface_vertices()) boundary_force = std::max(boundary_force, f[static_cast<size_t>(v)].norm());
  ASSERT_GT(boundary_force, 1.0);
  for (int v = 0; v < mesh->vertex_count(); ++v) {
    if (!mesh->is_surface_vertex(v)) {
      EXPECT_LT(f[static_cast<size_t>(v)].norm(), 1e-10 * boundary_force) << "vertex " << v;
    }
  }
  // The boundary forces are the traction of the uniform stress: their sum is zero, and so is their moment.
  Vec3 sum = Vec3::Zero(), moment = Vec3::Zero();
  for (size_t i = 0; i < x.size(); ++i) {
    sum += f[i];
    moment += x[i].cross(f[i]);
  }
  EXPECT_LT(sum.norm(), 1e-10 * boundary_force);
  EXPECT_LT(moment.norm(), 1e-8 * boundary_force * 0.3);  // R is found to ~1e-11 rad
}

TEST(CorotationalFem, StiffnessEqualsForceDerivativeAtRotatedRestAndBothProductsAgree) {
  const auto mesh = make_box_mesh({Vec3(0.1, 0.1, 0.1), 2, 2, 2});
  const Material m = material(1e4, 0.4);
  CorotationalFem free_model(mesh, m, {}, StiffnessProduct::matrix_free);
  CorotationalFem assembled(mesh, m, {}, StiffnessProduct::assembled);
  const Mat3 Q = Eigen::AngleAxisd(1.3, Vec3(0.2, -1, 0.5).normalized()).toRotationMatrix();
  std::vector<Vec3> x = mesh->rest_positions();
  for (auto& p : x) p = Q * p;
  const auto n = x.size();
  const std::vector<Vec3> p = random_field(n, 5);
  free_model.update_rotations(x);
  std::vector<Vec3> y(n), y2(n), fp(n), fm(n);
  free_model.apply_stiffness(p, y);
  // The assembled K' is filled by advance(); at rest with no load a step leaves x where it is.
  {
    std::vector<Vec3> xa = x, va(n, Vec3::Zero());
    const std::vector<double> masses = mesh->lumped_masses(1000.0);
    const std::vector<char> fixed(n, 0);
    const std::vector<Vec3> ext(n, Vec3::Zero());
    assembled.advance(xa, va, {masses, fixed, ext, 1e-3});
    for (size_t i = 0; i < n; ++i) ASSERT_LT((xa[i] - x[i]).norm(), 1e-14);
    assembled.update_rotations(xa);  // advance defers the state at its result: evaluate it, K' included
  }
  ASSERT_TRUE(assembled.stiffness_is_assembled());
  assembled.apply_stiffness(p, y2);
  std::vector<Vec3> diff(n);
  for (size_t i = 0; i < n; ++i) diff[i] = y[i] - y2[i];
  EXPECT_LT(norm(diff), 1e-12 * norm(y));
  // At a rotated rest shape K' is the exact Hessian: K' p = -(f(x + e p) - f(x - e p)) / 2e.
  const double e = 1e-7;
  std::vector<Vec3> xp = x, xm = x;
  for (size_t i = 0; i < n; ++i) {
    xp[i] += e * p[i];
    xm[i] -= e * p[i];
  }
  CorotationalFem probe(mesh, m, {});
  probe.internal_forces(xp, fp);
  probe.internal_forces(xm, fm);
  for (size_t i = 0; i < n; ++i) diff[i] = y[i] + (fp[i] - fm[i]) / (2.0 * e);
  EXPECT_LT(norm(diff), 1e-6 * norm(y));
}

// Mean vertical displacement of the free end of a cantilever (clamped at x = -L/2) under gravity,
// solved statically by implicit steps with a huge dt (each is a Newton step on the statics).
double cantilever_tip_deflection(int k, double L, double H, const Material& m) {
  const auto mesh = make_box_mesh({Vec3(L, H, H), 10 * k, k, k});
  CorotationalFem model(mesh, m, precise(20000, 1e-9));
  const auto n = static_cast<size_t>(mesh->vertex_count());
  std::vector<Vec3> x = mesh->rest_positions(), v(n, Vec3::Zero());
  const std::vector<double> masses = mesh->lumped_masses(m.density);
  std::vector<char> fixed(n, 0);
  std::vector<Vec3> ext(n);
  for (size_t i = 0; i < n; ++i) {
    fixed[i] = x[i].x() < -0.5 * L + 1e-12 ? 1 : 0;
    ext[i] = masses[i] * Vec3(0, 0, -9.81);
  }
  for (int step = 0; step < 3; ++step) {
    model.advance(x, v, {masses, fixed, ext, 100.0});
    std::fill(v.begin(), v.end(), Vec3::Zero());
  }
  double tip = 0.0;
  int count = 0;
  for (size_t i = 0; i < n; ++i) {
    if (mesh->rest_positions()[i].x() > 0.5 * L - 1e-12) {
      tip += mesh->rest_positions()[i].z() - x[i].z();
      ++count;
    }
  }
  return tip / count;
}

TEST(CorotationalFem, CantileverUnderOwnWeightConvergesToBeamTheory) {
  const double L = 1.0, H = 0.1;
  const Material m = material(1.5e8, 0.0);  // nu = 0: no Poisson stiffening at the clamp
  const double q = m.density * 9.81 * H * H;  // load per length (N/m)
  const double I = H * H * H * H / 12.0;
  const double G = m.lame_mu(), kappa = 5.0 / 6.0;
  // Euler-Bernoulli q L^4 / (8 E I) plus Timoshenko shear q L^2 / (2 kappa G A) (0.8% here).
  const double reference = q * std::pow(L, 4) / (8.0 * m.young_modulus * I) + q * L * L / (2.0 * kappa * G * H * H);
  double previous = 0.0;
  for (int k : {2, 4, 6}) {
    const double tip = cantilever_tip_deflection(k, L, H, m);
    // Linear tets lock in bending: too stiff when coarse, converging from below.
    EXPECT_GT(tip, previous) << "k = " << k;
    EXPECT_LT(tip, 1.01 * reference) << "k = " << k;
    previous = tip;
  }
  EXPECT_NEAR(previous, reference, 0.1 * reference);  // finest mesh: 60 x 6 x 6 cells
}

double total_energy(CorotationalFem& model, std::span<const Vec3> x, std::span<const Vec3> v,
                    std::span<const double> masses) {
  double kinetic = 0.0;
  for (size_t i = 0; i < x.size(); ++i) kinetic += 0.5 * masses[i] * v[i].squaredNorm();
  return kinetic + model.elastic_energy(x);
}

TEST(CorotationalFem, EnergyNeverGrowsWithoutExternalWork) {
  const auto mesh = make_box_mesh({Vec3(0.2, 0.1, 0.1), 4, 2, 2});
  const Material m = material(1e4, 0.3);
  CorotationalFem model(mesh, m, precise(2000, 1e-12));
  const auto n = static_cast<size_t>(mesh->vertex_count());
  const std::vector<double> masses = mesh->lumped_masses(m.density);
  const std::vector<char> fixed(n, 0);
  const std::vector<Vec3> ext(n, Vec3::Zero());
  // A large twist and stretch plus a spin: strongly non-linear, with no damping at all.
  std::vector<Vec3> x = mesh->rest_positions(), v(n);
  for (size_t i = 0; i < n; ++i) {
    const double a = 2.0 * x[i].x();
    x[i] = Vec3(1.2 * x[i].x(), std::cos(a) * x[i].y() - std::sin(a) * x[i].z(), std::sin(a) * x[i].y() + std::cos(a) * x[i].z());
    v[i] = Vec3(0.0, 0.0, 3.0).cross(x[i]);
  }
  double previous = total_energy(model, x, v, masses);
  const double initial = previous;
  for (int step = 0; step < 300; ++step) {
    model.advance(x, v, {masses, fixed, ext, step < 150 ? 1e-3 : 1e-2});
    const double energy = total_energy(model, x, v, masses);
    ASSERT_LE(energy, previous * (1.0 + 1e-9)) << "step " << step;
    previous = energy;
  }
  EXPECT_LT(previous, initial);
}

TEST(CorotationalFem, InvertedAndFlattenedElementsRecover) {
  // A single tet with its apex pushed through the opposite face, then a box mesh squashed flat and
  // through itself; both are released at rest and must come back to positive volume.
  for (double squash : {-1.0, 0.0, -0.3}) {
    const bool single = squash == -1.0;
    const auto mesh = single ? TetMesh::build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}, {{0, 1, 2, 3}})
                             : make_box_mesh({Vec3(0.1, 0.1, 0.1), 2, 2, 2});
    const Material m = material(1e4, 0.3, 5.0, 0.01);
    CorotationalFem model(mesh, m, {});
    const auto n = static_cast<size_t>(mesh->vertex_count());
    std::vector<Vec3> x = mesh->rest_positions(), v(n, Vec3::Zero());
    for (auto& p : x) p.z() *= single ? -1.0 : squash;
    const std::vector<double> masses = mesh->lumped_masses(m.density);
    const std::vector<char> fixed(n, 0);
    const std::vector<Vec3> ext(n, Vec3::Zero());
    for (int step = 0; step < 500; ++step) model.advance(x, v, {masses, fixed, ext, 1e-2});
    for (int t = 0; t < mesh->tet_count(); ++t) {
      const auto& tet = mesh->tets()[static_cast<size_t>(t)];
      const double V = signed_tet_volume(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                         x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
      EXPECT_NEAR(V, mesh->rest_volumes()[static_cast<size_t>(t)], 1e-3 * mesh->rest_volumes()[static_cast<size_t>(t)])
          << "squash " << squash << " tet " << t;
    }
  }
}

TEST(CorotationalFem, StiffBodyAtLargeStepStaysFiniteAndSettles) {
  // E = 1e8 Pa at dt = 20 ms with the default 20 CG iterations (explicit would need ~1e-5 s). The
  // column must settle where a precise static solve (huge-dt implicit steps, tight CG) puts it.
  const double size = 0.1;
  const auto mesh = make_box_mesh({Vec3(size, size, 2 * size), 2, 2, 4});
  const Material m = material(1e8, 0.45, 0.0, 0.01);
  const auto n = static_cast<size_t>(mesh->vertex_count());
  const std::vector<double> masses = mesh->lumped_masses(m.density);
  std::vector<char> fixed(n, 0);
  std::vector<Vec3> ext(n);
  for (size_t i = 0; i < n; ++i) {
    fixed[i] = mesh->rest_positions()[i].z() < -size + 1e-12 ? 1 : 0;
    ext[i] = masses[i] * Vec3(0, 0, -9.81) + Vec3(2.0, 0, 0);  // plus a sideways push (N)
  }
  CorotationalFem model(mesh, m, {});
  std::vector<Vec3> x = mesh->rest_positions(), v(n, Vec3::Zero());
  for (int step = 0; step < 100; ++step) model.advance(x, v, {masses, fixed, ext, 2e-2});

  CorotationalFem statics(mesh, m, precise(5000, 1e-12));
  std::vector<Vec3> xs = mesh->rest_positions(), vs(n, Vec3::Zero());
  for (int step = 0; step < 4; ++step) {
    statics.advance(xs, vs, {masses, fixed, ext, 100.0});
    std::fill(vs.begin(), vs.end(), Vec3::Zero());
  }
  double max_static = 0.0, max_error = 0.0, max_speed = 0.0;
  for (size_t i = 0; i < n; ++i) {
    ASSERT_TRUE(x[i].allFinite() && v[i].allFinite());
    max_static = std::max(max_static, (xs[i] - mesh->rest_positions()[i]).norm());
    max_error = std::max(max_error, (x[i] - xs[i]).norm());
    max_speed = std::max(max_speed, v[i].norm());
    if (fixed[i]) {
      EXPECT_EQ(x[i], mesh->rest_positions()[i]);
      EXPECT_EQ(v[i], Vec3::Zero());
    }
  }
  ASSERT_GT(max_static, 1e-7);
  EXPECT_LT(max_error, 1e-2 * max_static);
  EXPECT_LT(max_speed * 2e-2, 1e-2 * max_static);
}

TEST(CorotationalFem, AccuracyCapsSolverIterations) {
  const auto mesh = make_box_mesh({Vec3(0.2, 0.1, 0.1), 4, 2, 2});
  CorotationalFem model(mesh, material(1e6, 0.3), precise());
  ModelAccuracy low;
  low.max_solver_iterations = 3;
  low.solver_tolerance = 1e-12;
  model.set_accuracy(low);
  EXPECT_EQ(model.accuracy().max_solver_iterations, 3);
  const auto n = static_cast<size_t>(mesh->vertex_count());
  std::vector<Vec3> x = mesh->rest_positions(), v(n, Vec3::Zero());
  const std::vector<double> masses = mesh->lumped_masses(1000.0);
  std::vector<char> fixed(n, 0);
  std::vector<Vec3> ext(n);
  for (size_t i = 0; i < n; ++i) {
    fixed[i] = x[i].x() < -0.1 + 1e-12 ? 1 : 0;
    ext[i] = masses[i] * Vec3(0, 0, -9.81);
  }
  IntegrationResult r = model.advance(x, v, {masses, fixed, ext, 1e-2});
  EXPECT_EQ(r.solver_iterations, 3);
  EXPECT_FALSE(r.converged);
  model.set_accuracy(precise().accuracy);
  r = model.advance(x, v, {masses, fixed, ext, 1e-2});
  EXPECT_TRUE(r.converged);
  EXPECT_LE(r.solver_residual, 1e-12);
}


// A cantilever of 20 x 2 x 2 cells sagging under gravity for a few implicit steps: strained and
// rotated elements (the state the cached-state and frozen-rotation tests start from).
struct SaggingBeam {
  TetMeshPtr mesh = make_box_mesh({Vec3(0.5, 0.05, 0.05), 20, 2, 2});
  Material m = material(1e5, 0.45, 0.0, 0.01);
  size_t n = static_cast<size_t>(mesh->vertex_count());
  std::vector<double> masses = mesh->lumped_masses(m.density);
  std::vector<char> fixed = std::vector<char>(n, 0);
  std::vector<Vec3> ext = std::vector<Vec3>(n);
  std::vector<Vec3> x = mesh->rest_positions(), v = std::vector<Vec3>(n, Vec3::Zero());
  SaggingBeam() {
    for (size_t i = 0; i < n; ++i) {
      fixed[i] = x[i].x() < -0.25 + 1e-12 ? 1 : 0;
      ext[i] = masses[i] * Vec3(0, 0, -9.81);
    }
  }
  IntegrationResult step(DeformationModel& model) { return model.advance(x, v, {masses, fixed, ext, 1e-2}); }
  /// Free surface vertices near the tip, where the contact stage would push.
  std::vector<int> tip_vertices() const {
    std::vector<int> out;
    for (int i : mesh->surface_vertices()) {
      if (mesh->rest_positions()[static_cast<size_t>(i)].x() > 0.2 && out.size() < 6) out.push_back(i);
    }
    return out;
  }
};

// The implicit step's CG with symmetric block Gauss-Seidel (Eisenstat's form, the default with the
// assembled K') solves the same system as with block-Jacobi: both converged to 1e-12 give the same
// steps (a second method). At the default tolerance the residual it reports is the true one,
// |rhs - A dv| / |rhs|, recomputed here from the model's public forces and K' product, and it needs
// fewer iterations than block-Jacobi for it.
TEST(CorotationalFem, SsorAndBlockJacobiSolveTheSameStepAndTheReportedResidualIsTrue) {
  SaggingBeam a, b;
  CorotationalFem ssor(a.mesh, a.m, precise()), jacobi(b.mesh, b.m, precise());
  jacobi.set_preconditioner(Preconditioner::block_jacobi);
  EXPECT_EQ(ssor.preconditioner(), Preconditioner::ssor);
  for (int s = 0; s < 4; ++s) {
    const IntegrationResult ra = a.step(ssor), rb = b.step(jacobi);
    EXPECT_TRUE(ra.converged);
    EXPECT_TRUE(rb.converged);
    EXPECT_LT(ra.solver_iterations, rb.solver_iterations);
    EXPECT_LT(max_difference(a.v, b.v), 1e-8 * max_norm(b.v)) << s;
    EXPECT_LT(max_difference(a.x, b.x), 1e-8 * max_norm(b.v) * 1e-2) << s;
  }
  // One step at the default tolerance (1e-6, cap 200): the true residual of the system
  // ((1 + h alpha) M + h (beta + h) K') dv = h (f + f_ext - alpha M v) - h (beta + h) K' v.
  for (auto kind : {Preconditioner::ssor, Preconditioner::block_jacobi}) {
    SaggingBeam beam;
    CorotationalFem model(beam.mesh, beam.m, precise(200, 1e-6));
    model.set_preconditioner(kind);
    // The system of the exact linearisation at x_n: no K' reuse between steps (with the default
    // 1e-3 rad reuse the solve's K' is the reused one, 2.4e-3 relative residual against this one;
    // its own bound is tested in corotational_stiffness_reuse_test.cpp).
    model.set_stiffness_rotation_tolerance(0.0);
    for (int s = 0; s < 3; ++s) beam.step(model);
    CorotationalFem reference = model;
    reference.update_rotations(beam.x);
    const double h = 1e-2, scale = h * (beam.m.stiffness_damping + h), mass_scale = 1.0 + h * beam.m.mass_damping;
    std::vector<Vec3> f(beam.n), kv(beam.n), kdv(beam.n), dv(beam.n);
    reference.internal_forces(beam.x, f);
    reference.apply_stiffness(beam.v, kv);
    const std::vector<Vec3> v0 = beam.v;
    const IntegrationResult r = beam.step(model);
    for (size_t i = 0; i < beam.n; ++i) dv[i] = beam.v[i] - v0[i];
    reference.apply_stiffness(dv, kdv);
    double rhs_sq = 0.0, res_sq = 0.0;
    for (size_t i = 0; i < beam.n; ++i) {
      if (beam.fixed[i] != 0) continue;
      const Vec3 rhs = h * (f[i] + beam.ext[i] - beam.m.mass_damping * beam.masses[i] * v0[i]) - scale * kv[i];
      const Vec3 lhs = mass_scale * beam.masses[i] * dv[i] + scale * kdv[i];
      rhs_sq += rhs.squaredNorm();
      res_sq += (rhs - lhs).squaredNorm();
    }
    const double true_residual = std::sqrt(res_sq / rhs_sq);
    std::printf("%s: %d iterations, reported residual %.3e, true %.3e\n",
                kind == Preconditioner::ssor ? "ssor" : "block-Jacobi", r.solver_iterations, r.solver_residual,
                true_residual);
    EXPECT_TRUE(r.converged);
    EXPECT_LE(true_residual, 1e-6 * 1.01);
    EXPECT_NEAR(r.solver_residual, true_residual, 1e-2 * true_residual + 1e-12);
  }
}

// The model caches energy, forces and rotations at the positions of its last evaluation (advance
// ends by evaluating at its result) and updates only the tets around a few moved vertices. Whatever
// path a query takes, it must return what a fresh model evaluates at the same positions.
TEST(CorotationalFem, CachedStateEqualsAFreshEvaluationAtThePositionsAsked) {
  SaggingBeam beam;
  CorotationalFem model(beam.mesh, beam.m, {});
  for (int s = 0; s < 8; ++s) beam.step(model);
  const auto check = [&](const std::vector<Vec3>& x, const char* what) {
    CorotationalFem fresh(beam.mesh, beam.m, {});
    std::vector<Vec3> f(beam.n), f_fresh(beam.n);
    const double e_fresh = fresh.elastic_energy(x);
    fresh.internal_forces(x, f_fresh);
    ASSERT_GT(e_fresh, 0.0) << what;
    EXPECT_NEAR(model.elastic_energy(x), e_fresh, 1e-12 * e_fresh) << what;
    model.internal_forces(x, f);
    EXPECT_LT(max_difference(f, f_fresh), 1e-10 * max_norm(f_fresh)) << what;
    EXPECT_NEAR(model.elastic_energy(x), e_fresh, 1e-12 * e_fresh) << what << " (asked twice)";
    for (int t = 0; t < beam.mesh->tet_count(); ++t) {
      ASSERT_LT((model.element_rotation(t) - fresh.element_rotation(t)).norm(), 1e-10) << what << " tet " << t;
    }
    // K' (assembled and updated tet by tet, or matrix-free) against the fresh matrix-free product.
    const std::vector<Vec3> p = random_field(beam.n, 7);
    std::vector<Vec3> y(beam.n), y_fresh(beam.n);
    model.apply_stiffness(p, y);
    fresh.apply_stiffness(p, y_fresh);
    EXPECT_LT(max_difference(y, y_fresh), 1e-10 * max_norm(y_fresh)) << what;
  };
  check(beam.x, "state left by advance");
  // A full pass with K' assembled (advance defers its result's state, and queries do not assemble),
  // so that the local update below has assembled blocks to keep current.
  model.update_rotations(beam.x);
  std::vector<Vec3> x = beam.x;
  for (int v : beam.tip_vertices()) x[static_cast<size_t>(v)] += Vec3(0.0, 1e-3, -2e-3);  // a contact edit
  check(x, "six vertices moved");
  EXPECT_TRUE(model.stiffness_is_assembled());  // kept current through the local update
  for (auto& p : x) p += Vec3(1e-4, 0.0, 0.0);  // every vertex moved: a full pass
  check(x, "all vertices moved");
  // The step after a contact edit starts from the edited positions (its cache is updated there).
  std::vector<Vec3> v = beam.v;
  CorotationalFem reference(beam.mesh, beam.m, {});
  reference.update_rotations(beam.x);  // reaches x by a full pass, `model` by its cache
  std::vector<Vec3> x_ref = x, v_ref = v;
  model.set_accuracy(precise().accuracy);  // the CG warm starts differ: solve both to round-off
  reference.set_accuracy(precise().accuracy);
  model.advance(x, v, {beam.masses, beam.fixed, beam.ext, 1e-2});
  reference.advance(x_ref, v_ref, {beam.masses, beam.fixed, beam.ext, 1e-2});
  EXPECT_LT(max_difference(x, x_ref), 1e-9 * max_difference(x, beam.x));
}

// The frozen-rotation query f_e = -R K_e (R^T x_e - X_e), R from the state advance left, against
// the exact query: equal at that state; near it the difference is small against the force change it
// approximates and shrinks at least linearly with the displacement (measured: quadratically).
TEST(CorotationalFem, FrozenRotationQueryEqualsExactAtTheStepStateAndIsFirstOrderNearIt) {
  SaggingBeam beam;
  CorotationalFem model(beam.mesh, beam.m, {});
  for (int s = 0; s < 8; ++s) beam.step(model);
  const std::vector<int> vertices = beam.tip_vertices();
  ASSERT_EQ(vertices.size(), 6u);
  std::vector<Vec3> exact(vertices.size()), frozen(vertices.size()), at_state(vertices.size());
  model.internal_forces_at(beam.x, vertices, at_state);
  model.internal_forces_at_frozen_rotations(beam.x, vertices, frozen);
  // Equal up to the rotations' tolerance (1e-11 rad; the exact query warm-starts from the previous
  // step's rotations, the frozen one uses those extracted at the step's result): relative to the
  // body's elastic forces, not to the tip vertices' net force, which nearly cancels at this nearly
  // static state (0.014 N against 6.6 N in the body; measured difference 7e-11 N, 4e-14 N when the
  // 20 capped block-Jacobi iterations left the beam further from equilibrium).
  std::vector<Vec3> body_forces(beam.n);
  model.internal_forces(beam.x, body_forces);
  EXPECT_LT(max_difference(frozen, at_state), 1e-10 * max_norm(body_forces));
  const double edge = 0.025;  // cell size (m)
  double previous_error = 0.0, ratio = 0.0;
  for (double fraction : {0.2, 0.1, 0.05, 0.025, 0.0125}) {
    std::vector<Vec3> x = beam.x;
    for (size_t k = 0; k < vertices.size(); ++k) {
      x[static_cast<size_t>(vertices[k])] += fraction * edge * Vec3(0.3, 0.5, -1.0).normalized();
    }
    model.internal_forces_at(x, vertices, exact);
    model.internal_forces_at_frozen_rotations(x, vertices, frozen);
    std::vector<Vec3> change(vertices.size());
    for (size_t k = 0; k < vertices.size(); ++k) change[k] = exact[k] - at_state[k];
    const double error = max_difference(frozen, exact), scale = max_norm(change);
    std::printf("displacement %.4f edge: frozen-rotation error %.3e N, force change %.3e N, ratio %.3e\n",
                fraction, error, scale, error / scale);
    // Measured 7.5% (0.2 edge) to 0.54% (0.0125 edge) of the force change on this pre-stressed
    // beam (session 2's unsymmetrised stress 2 mu (F - R): 1.7% .. 6.6%, see the test below).
    EXPECT_LT(error, 0.1 * scale) << fraction;
    if (previous_error > 0.0) ratio = previous_error / error;
    previous_error = error;
  }
  EXPECT_GT(ratio, 1.6);  // at least first order (measured 3.96: the error quarters as d halves)
}

// Mueller & Gross's K_e is the stiffness of the linear (symmetric) strain, so -R K_e (R^T x - X)
// exerts no force for an infinitesimal rigid rotation of an unstressed body (closed form: zero to
// first order in the angle). A stress 2 mu (F - R) with R frozen would resist it like a stretch of
// the same size (session 2's query did: 0.13 of the stretch's force, against < 1e-4 now).
TEST(CorotationalFem, FrozenRotationQueryExertsNoForceForAnInfinitesimalRotationAtRest) {
  SaggingBeam beam;  // at rest: the cached rotations are the identity
  CorotationalFem model(beam.mesh, beam.m, {});
  std::vector<Vec3> forces(beam.n);
  model.internal_forces(beam.x, forces);  // caches the state at the rest positions
  const double angle = 1e-6;              // rad
  const Mat3 rotation = Eigen::AngleAxisd(angle, Vec3(0.3, 0.5, -1.0).normalized()).toRotationMatrix();
  const Mat3 stretch = Mat3::Identity() + angle * Vec3(0.3, 0.5, -1.0).normalized() * Vec3(0.3, 0.5, -1.0).normalized().transpose();
  std::vector<Vec3> rotated(beam.n), stretched(beam.n);
  for (size_t i = 0; i < beam.n; ++i) {
    rotated[i] = rotation * beam.x[i];
    stretched[i] = stretch * beam.x[i];
  }
  const std::vector<int> vertices = beam.tip_vertices();
  std::vector<Vec3> f_rotated(vertices.size()), f_stretched(vertices.size());
  model.internal_forces_at_frozen_rotations(rotated, vertices, f_rotated);
  model.internal_forces_at_frozen_rotations(stretched, vertices, f_stretched);
  ASSERT_GT(max_norm(f_stretched), 0.0);
  EXPECT_LT(max_norm(f_rotated), 1e-4 * max_norm(f_stretched));
}


// Maximum over 400 steps of (kinetic + elastic + gravitational energy) / (m g h) for a block
// 0.08 x 0.08 x 0.04 m on a fixed base under gravity, released at rest (total 0 at the start).
double block_on_base_max_energy(double E, double nu, double dt, double alpha, double beta, int cg_cap) {
  const auto mesh = make_box_mesh({Vec3(0.08, 0.08, 0.04), 6, 6, 3});
  const Material m = material(E, nu, alpha, beta);
  const auto n = static_cast<size_t>(mesh->vertex_count());
  const std::vector<double> masses = mesh->lumped_masses(m.density);
  std::vector<char> fixed(n, 0);
  std::vector<Vec3> ext(n);
  double mass = 0.0;
  for (size_t i = 0; i < n; ++i) {
    fixed[i] = mesh->rest_positions()[i].z() < -0.02 + 1e-12 ? 1 : 0;
    ext[i] = masses[i] * Vec3(0, 0, -9.81);
    mass += masses[i];
  }
  CorotationalFem model(mesh, m, precise(cg_cap, 1e-6));
  std::vector<Vec3> x = mesh->rest_positions(), v(n, Vec3::Zero());
  double max_energy = 0.0;
  for (int step = 0; step < 400; ++step) {
    model.advance(x, v, {masses, fixed, ext, dt});
    double e = model.elastic_energy(x);
    for (size_t i = 0; i < n; ++i) {
      e += 0.5 * masses[i] * v[i].squaredNorm() + masses[i] * 9.81 * (x[i].z() - mesh->rest_positions()[i].z());
    }
    max_energy = std::max(max_energy, e);
  }
  return max_energy / (mass * 9.81 * 0.04);
}

// docs/stability.md F7 asked whether the FEM alone gains energy in a nearly incompressible block at
// dt = 20 ms. The stiff block (E = 3e5 Pa) does not, with the default CG cap or without damping.
// (The same function with E <= 100 Pa gives 1.3x-4.5x the scale even with CG converged: the
// linearly implicit step's, not the CG cap's; docs/deformation-models.md has the table.)
TEST(CorotationalFem, StiffNearlyIncompressibleBlockOnFixedBaseGainsNoEnergy) {
  EXPECT_LE(block_on_base_max_energy(3e5, 0.499, 2e-2, 1.0, 0.01, 20), 1e-9);
  EXPECT_LE(block_on_base_max_energy(3e5, 0.499, 2e-2, 0.0, 0.0, 20), 1e-9);
}
}  // namespace
}  // namespace pliant
