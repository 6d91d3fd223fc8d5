// The end-of-step evaluation pass (session 5): it no longer stores every tet's rotated shape
// gradients R Dm^-T; their readers (K' assembly, K' reuse, the matrix-free product) fill them on
// demand from the stored rotations. Reference: with the rotations frozen, the warped-stiffness force
// f(x) = -sum R K_e (R^T x_e - X_e) is linear in x, so f(x + p) - f(x) = -K' p up to round-off: a
// second method for K' p that never reads the gradients. Checked after a step (rotations from the
// pass, gradients stale: the matrix-free path and the next advance's K' must refill them) and
// after a local refresh (a few vertices moved after a full pass).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numeric>
#include <random>

#include "sim/model/corotational_fem.h"
#include "sim/model/rotation_batch_avx512.h"
#include "support/clamped_beam.h"
#include "support/vec_compare.h"

namespace pliant {
namespace {

/// Swings sideways and sags: every free vertex pushed by m (0, 4, -9.81) N.
struct SwingingBeam : ClampedBeam {
  SwingingBeam() : ClampedBeam(16, [](const Vec3&, double m) { return Vec3(m * Vec3(0.0, 4.0, -9.81)); }) {}
};

/// -(f(x + p) - f(x)) with the model's current rotations frozen: K' p by the linear force law.
std::vector<Vec3> stiffness_by_frozen_forces(CorotationalFem& model, std::span<const Vec3> x,
                                             std::span<const Vec3> p) {
  const size_t n = x.size();
  std::vector<int> all(n);
  std::iota(all.begin(), all.end(), 0);
  std::vector<Vec3> xp(x.begin(), x.end()), f0(n), f1(n), kp(n);
  for (size_t i = 0; i < n; ++i) xp[i] += p[i];
  model.internal_forces_at_frozen_rotations(x, all, f0);
  model.internal_forces_at_frozen_rotations(xp, all, f1);
  for (size_t i = 0; i < n; ++i) kp[i] = -(f1[i] - f0[i]);
  return kp;
}

std::vector<Vec3> probe_direction(size_t n) {
  std::vector<Vec3> p(n);
  for (size_t i = 0; i < n; ++i) {
    const double s = static_cast<double>(i);
    p[i] = 1e-4 * Vec3(std::sin(0.7 * s), std::cos(1.3 * s), std::sin(2.1 * s + 0.4));
  }
  return p;
}

/// Evaluates the model's linearisation state at x the way World's stages do: a full force query
/// (the energy query no longer does since session 6: it is read-only).
void evaluate_state(CorotationalFem& model, std::span<const Vec3> x) {
  std::vector<Vec3> f(x.size());
  model.internal_forces(x, f);
}

void expect_close(std::span<const Vec3> a, std::span<const Vec3> b, double relative) {
  std::vector<Vec3> d(a.size());
  for (size_t i = 0; i < a.size(); ++i) d[i] = a[i] - b[i];
  EXPECT_LE(field_norm(d), relative * field_norm(b));
}

// After steps with K' reuse, the pass at the step's result leaves the gradients stale; the
// matrix-free product refills them from the pass's rotations (the beam swings, so they moved).
TEST(CorotationalEvaluationPass, MatrixFreeProductAfterThePassMatchesTheLinearForceLaw) {
  SwingingBeam beam;
  CorotationalFem model(beam.mesh, beam.material, {});
  for (int step = 0; step < 40; ++step) {
    model.advance(beam.x, beam.v, beam.input());
    evaluate_state(model, beam.x);  // the deferred pass at x_{n+1}
  }
  ASSERT_FALSE(model.stiffness_is_assembled());
  double max_angle = 0.0;
  for (int t = 0; t < beam.mesh->tet_count(); ++t) {
    max_angle = std::max(max_angle, Eigen::AngleAxisd(model.element_rotation(t)).angle());
  }
  ASSERT_GT(max_angle, 0.05);  // rotations far from the rest gradients
  const auto p = probe_direction(beam.x.size());
  std::vector<Vec3> kp(beam.x.size());
  model.apply_stiffness(p, kp);
  expect_close(kp, stiffness_by_frozen_forces(model, beam.x, p), 1e-9);
  // The assembled K' at the same state (a full pass that assembles) gives the same product.
  CorotationalFem assembled = model;
  assembled.update_rotations(beam.x);
  ASSERT_TRUE(assembled.stiffness_is_assembled());
  std::vector<Vec3> ka(beam.x.size());
  assembled.apply_stiffness(p, ka);
  expect_close(ka, kp, 1e-12);
}

// A local refresh after the full pass (a contact edit of a few vertices) re-extracts only the tets
// around them; the gradients read afterwards must be those of the refreshed rotations.
TEST(CorotationalEvaluationPass, GradientsAfterALocalRefreshFollowItsRotations) {
  SwingingBeam beam;
  CorotationalFem model(beam.mesh, beam.material, {});
  for (int step = 0; step < 20; ++step) model.advance(beam.x, beam.v, beam.input());
  evaluate_state(model, beam.x);
  std::vector<Vec3> moved = beam.x;
  for (size_t i = moved.size() - 4; i < moved.size(); ++i) moved[i] += Vec3(0.0, 0.02, 0.01);
  evaluate_state(model, moved);  // local refresh
  const auto p = probe_direction(moved.size());
  std::vector<Vec3> kp(moved.size());
  model.apply_stiffness(p, kp);
  expect_close(kp, stiffness_by_frozen_forces(model, moved, p), 1e-9);
}

// K' reuse reads the gradients of the tets that left the tolerance from the pass's rotations: a
// step from the same state by a model whose pass also assembled K' (update_rotations, gradients
// current) and a fresh model at tolerance 0 agree to the exact path's bound; at tolerance 0 both
// paths give the same step bit for bit.
TEST(CorotationalEvaluationPass, StepAfterThePassEqualsTheStepAfterAnAssemblingPass) {
  SwingingBeam beam;
  CorotationalFem lazy(beam.mesh, beam.material, {});
  lazy.set_stiffness_rotation_tolerance(0.0);
  for (int step = 0; step < 30; ++step) lazy.advance(beam.x, beam.v, beam.input());
  CorotationalFem assembling = lazy;
  evaluate_state(lazy, beam.x);  // pass without K': gradients stale
  assembling.update_rotations(beam.x);  // pass with K': gradients current
  std::vector<Vec3> xa = beam.x, va = beam.v;
  lazy.advance(beam.x, beam.v, beam.input());
  assembling.advance(xa, va, beam.input());
  for (size_t i = 0; i < xa.size(); ++i) {
    ASSERT_EQ(beam.x[i], xa[i]) << i;
    ASSERT_EQ(beam.v[i], va[i]) << i;
  }
}

// Session 17: the pass's rotations eight tets at a time in AVX-512 lanes. Every lane repeats the
// scalar extraction's operations, so the pass must be bit for bit the 4-lane pass's (AVX2) and the
// scalar code's (vector kernels off): rotations, forces, energy. Meshes of 1..17 and 40 separate tets
// (every tail of a batch of eight and of four, and whole batches), deformed tet by tet by a rotation
// times a stretch of one of the kinds the FEM meets: small strains, large stretches and shears,
// inverted and near-degenerate (1e-9 sliver) tets; three passes per mesh, each warm-started by the
// one before (one and many iterations per lane, lanes of one batch stopping at different counts).
TEST(CorotationalEvaluationPass, EightLanePassEqualsTheFourLaneAndTheScalarPassBitForBit) {
  if (!rotation_batch_avx512_available()) GTEST_SKIP() << "no AVX-512 on this CPU or build";
  std::mt19937_64 rng(20261128);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto random_rotation = [&] {
    Quat q(u(rng), u(rng), u(rng), u(rng));
    q.normalize();
    return Mat3(q.toRotationMatrix());
  };
  const auto random_matrix = [&](double scale) {
    Mat3 m;
    for (int k = 0; k < 9; ++k) m.data()[k] = scale * u(rng);
    return m;
  };
  Material material;
  material.young_modulus = 3e4;
  int passes = 0;
  for (int n = 1; n <= 41; n = n < 17 ? n + 1 : n + 23) {
    // n separate tets, each its own four vertices (a regular-ish rest shape of 1 cm edges).
    std::vector<Vec3> rest;
    std::vector<TetIndices> tets;
    for (int t = 0; t < n; ++t) {
      const Vec3 origin(0.05 * t, 0.0, 0.0);
      const Mat3 edges = 0.01 * (Mat3::Identity() + random_matrix(0.2));
      rest.push_back(origin);
      for (int k = 0; k < 3; ++k) rest.push_back(origin + edges.col(k));
      tets.push_back({4 * t, 4 * t + 1, 4 * t + 2, 4 * t + 3});
    }
    const TetMeshPtr mesh = TetMesh::build(rest, tets);
    CorotationalFem eight(mesh, material, {}), four(mesh, material, {}), scalar(mesh, material, {});
    ASSERT_TRUE(eight.avx512_lanes());
    four.set_avx512_lanes(false);
    scalar.set_vector_kernels(false);
    ASSERT_FALSE(four.avx512_lanes());
    ASSERT_FALSE(scalar.avx512_lanes());
    const size_t nv = rest.size();
    std::vector<Vec3> x(nv), f8(nv), f4(nv), fs(nv);
    for (int pass = 0; pass < 3; ++pass) {
      for (int t = 0; t < n; ++t) {
        const auto tv = static_cast<size_t>(4 * t);
        Mat3 S = Mat3::Identity() + random_matrix(pass == 0 ? 1e-3 : 0.3);
        switch ((t + pass) % 4) {
          case 1:
            S.col(2) = -S.col(2);  // inverted
            break;
          case 2:
            S.col(1) *= 1e-9;  // sliver
            break;
          default:
            break;
        }
        const Mat3 F = random_rotation() * S;
        x[tv] = mesh->rest_positions()[tv] + Vec3(u(rng), u(rng), u(rng));
        for (size_t k = 1; k < 4; ++k) x[tv + k] = x[tv] + F * (mesh->rest_positions()[tv + k] - mesh->rest_positions()[tv]);
      }
      eight.internal_forces(x, f8);
      four.internal_forces(x, f4);
      scalar.internal_forces(x, fs);
      ASSERT_EQ(std::memcmp(f8.data(), f4.data(), nv * sizeof(Vec3)), 0) << n << " tets, pass " << pass;
      ASSERT_EQ(std::memcmp(f8.data(), fs.data(), nv * sizeof(Vec3)), 0) << n << " tets, pass " << pass;
      const double e8 = eight.elastic_energy(x), e4 = four.elastic_energy(x), es = scalar.elastic_energy(x);
      ASSERT_EQ(std::memcmp(&e8, &e4, sizeof(double)), 0) << n << " tets, pass " << pass << ": " << e8 << " vs " << e4;
      ASSERT_EQ(std::memcmp(&e8, &es, sizeof(double)), 0) << n << " tets, pass " << pass;
      for (int t = 0; t < n; ++t) {
        const Mat3 r8 = eight.element_rotation(t), r4 = four.element_rotation(t), rs = scalar.element_rotation(t);
        ASSERT_EQ(std::memcmp(r8.data(), r4.data(), sizeof(Mat3)), 0) << n << " tets, pass " << pass << ", tet " << t;
        ASSERT_EQ(std::memcmp(r8.data(), rs.data(), sizeof(Mat3)), 0) << n << " tets, pass " << pass << ", tet " << t;
      }
      // The energy query at moved positions: a full pass from the cached rotations into the pass memo
      // (warm starts read from one array, rotations written to another).
      std::vector<Vec3> moved = x;
      for (size_t i = 0; i < nv; ++i) moved[i] += 1e-4 * Vec3(u(rng), u(rng), u(rng));
      const double m8 = eight.elastic_energy(moved), m4 = four.elastic_energy(moved), ms = scalar.elastic_energy(moved);
      ASSERT_EQ(std::memcmp(&m8, &m4, sizeof(double)), 0) << n << " tets, pass " << pass << ", moved";
      ASSERT_EQ(std::memcmp(&m8, &ms, sizeof(double)), 0) << n << " tets, pass " << pass << ", moved";
      ASSERT_NE(m8, e8);
      // The rotations are polar rotations: R^T F symmetric at convergence (a check that the pass
      // compared above did extract rotations, not merely agree with itself; for det F > 0: from an
      // inverted tet the iteration climbs slowly, by the paper's gradient step, and may stop at its cap).
      for (int t = 0; t < n; ++t) {
        const Mat3 F = eight.deformation_gradient(x, t);
        if (!(F.determinant() > 0.0)) continue;
        const Mat3 G = eight.element_rotation(t).transpose() * F;
        EXPECT_LT((G - G.transpose()).norm(), 1e-8 * (1.0 + F.norm())) << n << " tets, pass " << pass << ", tet " << t;
      }
      ++passes;
    }
  }
  EXPECT_EQ(passes, 3 * 18);
}

}  // namespace
}  // namespace pliant
