// The coarse (two-level) correction of the SSOR-PCG (session 13, sim/model/coarse_correction.h).
// References: dense matrices built from the same blocks (Z, A, Z^T A Z, and the projections'
// defining identities), a closed form (Z reproduces rigid translations), and on the model the
// exact sweeps' solve at 1e-12 (a second method) and their iteration count at the default 1e-6.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstdio>
#include <random>
#include <vector>

#include "sim/mesh/box_mesh.h"
#include "sim/model/coarse_correction.h"
#include "sim/model/corotational_fem.h"
#include "support/sagging_cantilever.h"
#include "support/vec_compare.h"

namespace pliant {
namespace {

// A clamped block (6 x 4 x 3 cells, fixed at x = min) with a stiffness-like SPD block system on its
// edges: K = sum over edges of k_e (e e^T) on the 2 x 2 vertex pattern (a spring network), stored
// as the sweeps store it (upper-triangle block rows, K_ii first), D_i = m_i I + s K_ii.
struct ClampedBlockSystem {
  TetMeshPtr mesh = make_box_mesh({Vec3(0.6, 0.4, 0.3), 6, 4, 3});
  size_t n = static_cast<size_t>(mesh->vertex_count());
  std::vector<char> fixed;
  std::vector<int> offsets, cols;
  std::vector<double> blocks;
  std::vector<Mat3> D;
  double s = 0.37;

  ClampedBlockSystem() {
    const auto& X = mesh->rest_positions();
    fixed.assign(n, 0);
    for (size_t i = 0; i < n; ++i) fixed[i] = X[i].x() < -0.3 + 1e-12 ? 1 : 0;
    std::vector<std::vector<std::pair<int, Mat3>>> rows(n);
    for (size_t i = 0; i < n; ++i) rows[i].push_back({static_cast<int>(i), Mat3::Zero()});
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> stiffness(0.5, 2.0);
    for (const Edge& e : mesh->edges()) {
      const int a = std::min(e.a, e.b), b = std::max(e.a, e.b);
      const Vec3 d = (X[static_cast<size_t>(b)] - X[static_cast<size_t>(a)]).normalized();
      const Mat3 k = stiffness(rng) * (d * d.transpose() + 0.1 * Mat3::Identity());
      rows[static_cast<size_t>(a)][0].second += k;
      rows[static_cast<size_t>(b)][0].second += k;
      rows[static_cast<size_t>(a)].push_back({b, Mat3(-k)});
    }
    offsets.push_back(0);
    for (size_t i = 0; i < n; ++i) {
      for (const auto& [j, k] : rows[i]) {
        cols.push_back(j);
        blocks.insert(blocks.end(), k.data(), k.data() + 9);
      }
      offsets.push_back(static_cast<int>(cols.size()));
      D.push_back(fixed[i] != 0 ? Mat3::Identity() : Mat3(0.01 * Mat3::Identity() + s * rows[i][0].second));
    }
  }
  BlockSystemView view() const { return {blocks.data(), cols.data(), offsets.data(), D.data(), fixed.data(), s, n}; }
  /// Dense A with fixed rows and columns zero (their diagonal 1, as the sweeps decouple them).
  Eigen::MatrixXd dense_a() const {
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * n, 3 * n);
    for (size_t i = 0; i < n; ++i) {
      A.block<3, 3>(3 * i, 3 * i) = D[i];
      if (fixed[i] != 0) continue;
      for (int b = offsets[i] + 1; b < offsets[i + 1]; ++b) {
        const auto j = static_cast<size_t>(cols[static_cast<size_t>(b)]);
        if (fixed[j] != 0) continue;
        const Mat3 k = s * Eigen::Map<const Mat3>(blocks.data() + 9 * static_cast<size_t>(b));
        A.block<3, 3>(3 * i, 3 * j) = k;
        A.block<3, 3>(3 * j, 3 * i) = k.transpose();
      }
    }
    return A;
  }
  /// Dense (D + L^T): the upper blocks only (fixed rows the identity).
  Eigen::MatrixXd dense_upper() const {
    const Eigen::MatrixXd A = dense_a();
    Eigen::MatrixXd U = A.triangularView<Eigen::Upper>();
    for (size_t i = 0; i < n; ++i) U.block<3, 3>(3 * i, 3 * i) = D[i];
    return U;
  }
  Eigen::MatrixXd dense_z(const CoarseSpace& c) const {
    Eigen::MatrixXd Z = Eigen::MatrixXd::Zero(3 * n, 3 * c.aggregate_count());
    for (size_t i = 0; i < n; ++i) {
      const int a = c.aggregate_of()[i];
      if (a >= 0) Z.block<3, 3>(3 * i, 3 * a) = Mat3::Identity();
    }
    return Z;
  }
};

Eigen::VectorXd flat(const std::vector<Vec3>& v) {
  Eigen::VectorXd f(3 * v.size());
  for (size_t i = 0; i < v.size(); ++i) f.segment<3>(3 * i) = v[i];
  return f;
}

std::vector<Vec3> random_field(const ClampedBlockSystem& sys, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<Vec3> v(sys.n);
  for (size_t i = 0; i < sys.n; ++i) v[i] = sys.fixed[i] != 0 ? Vec3::Zero() : Vec3(g(rng), g(rng), g(rng));
  return v;
}

// Every free vertex is in exactly one aggregate and every aggregate is used; a translation given
// to every aggregate comes back as that translation at every free vertex and zero at fixed ones.
TEST(CoarseCorrection, ProlongationReproducesRigidTranslationsOnAClampedBlock) {
  ClampedBlockSystem sys;
  CoarseSpace coarse;
  coarse.build_aggregates(sys.mesh->rest_positions(), sys.fixed, 12);
  ASSERT_GT(coarse.aggregate_count(), 4);
  std::vector<int> members(static_cast<size_t>(coarse.aggregate_count()), 0);
  for (size_t i = 0; i < sys.n; ++i) {
    const int a = coarse.aggregate_of()[i];
    EXPECT_EQ(a < 0, sys.fixed[i] != 0) << i;
    if (a >= 0) ++members[static_cast<size_t>(a)];
  }
  for (int m : members) EXPECT_GT(m, 0);
  const Vec3 t(0.3, -1.25, 2.0);
  std::vector<double> c;
  for (int a = 0; a < coarse.aggregate_count(); ++a) c.insert(c.end(), t.data(), t.data() + 3);
  std::vector<Vec3> out(sys.n, Vec3::Constant(9.0));
  coarse.prolong(c, out);
  for (size_t i = 0; i < sys.n; ++i) EXPECT_EQ(out[i], sys.fixed[i] != 0 ? Vec3::Zero() : t) << i;
  EXPECT_TRUE(coarse.built_for(sys.fixed, 12));
  EXPECT_FALSE(coarse.built_for(sys.fixed, 13));
}

// E from the sparse assembly equals Z^T A Z from the dense matrices, is symmetric positive
// definite (the coarse solve's Cholesky succeeds), and so is every x^T E x on random x.
TEST(CoarseCorrection, GalerkinMatrixIsTheDenseZtAZAndPositiveDefinite) {
  ClampedBlockSystem sys;
  CoarseSpace coarse;
  coarse.build_aggregates(sys.mesh->rest_positions(), sys.fixed, 12);
  ASSERT_TRUE(coarse.assemble(sys.view()));
  const Eigen::MatrixXd Z = sys.dense_z(coarse);
  const Eigen::MatrixXd E = Z.transpose() * sys.dense_a() * Z;
  EXPECT_LT((coarse.galerkin_matrix() - E).norm(), 1e-12 * E.norm());
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  for (int k = 0; k < 20; ++k) {
    Eigen::VectorXd x(E.rows()), y(E.rows());
    for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = g(rng), y[i] = g(rng);
    EXPECT_GT(x.dot(coarse.galerkin_matrix() * x), 0.0);
    EXPECT_NEAR(x.dot(coarse.galerkin_matrix() * y), y.dot(coarse.galerkin_matrix() * x), 1e-12 * E.norm() * x.norm() * y.norm());
  }
}

// The deflation's identities against the dense matrices: the corrected start's residual is
// b - A dv and orthogonal to Z; a projected direction is A-orthogonal to Z and its p^ is still
// (D + L^T) p, whatever p^ and p were (the same correction subtracted from both).
TEST(CoarseCorrection, StartCorrectionAndProjectionMatchTheDenseDeflation) {
  ClampedBlockSystem sys;
  CoarseSpace coarse;
  coarse.build_aggregates(sys.mesh->rest_positions(), sys.fixed, 12);
  ASSERT_TRUE(coarse.assemble(sys.view()));
  const Eigen::MatrixXd A = sys.dense_a(), Z = sys.dense_z(coarse), U = sys.dense_upper();
  const Eigen::VectorXd b = flat(random_field(sys, 11));
  std::vector<Vec3> dv = random_field(sys, 12), r(sys.n);
  const Eigen::VectorXd r0 = b - A * flat(dv);
  for (size_t i = 0; i < sys.n; ++i) r[i] = r0.segment<3>(3 * i);
  coarse.correct_start(dv, r);
  const Eigen::VectorXd r1 = flat(r);
  EXPECT_LT((r1 - (b - A * flat(dv))).norm(), 1e-12 * b.norm() * A.norm());
  EXPECT_LT((Z.transpose() * r1).norm(), 1e-12 * r0.norm());
  EXPECT_GT(r0.norm() - r1.norm(), 0.0);  // the coarse part of a random residual is not zero

  std::vector<Vec3> p = random_field(sys, 13), p_hat(sys.n);
  const Eigen::VectorXd ph0 = U * flat(p);
  for (size_t i = 0; i < sys.n; ++i) p_hat[i] = ph0.segment<3>(3 * i);
  coarse.project_direction(p, p_hat);
  const Eigen::VectorXd p1 = flat(p);
  EXPECT_LT((Z.transpose() * A * p1).norm(), 1e-12 * A.norm() * p1.norm() * std::sqrt(Z.cols()));
  EXPECT_LT((flat(p_hat) - U * p1).norm(), 1e-12 * U.norm() * p1.norm());
}

ModelSettings settings(int iterations, double tolerance, int aggregate) {
  ModelSettings s;
  s.accuracy.max_solver_iterations = iterations;
  s.accuracy.solver_tolerance = tolerance;
  s.fused_sweeps = false;
  s.coarse_aggregate_size = aggregate;
  return s;
}

// A cantilever of 40 x 4 x 4 cells (1,025 vertices), fixed at one end, sagging under gravity.
struct Cantilever : SaggingCantilever {
  Cantilever() : SaggingCantilever(0.5, 0.05, 40, 4, 1e5) {}
};

// Solved to 1e-12, the deflated solve and the plain SSOR solve (exact sweeps) give the same steps
// (to 1e-9 of |v|): the coarse correction changes the path, not the system. At the default 1e-6
// the deflated solve meets the tolerance (true residual) in fewer iterations, step by step and in
// sum (printed).
TEST(CoarseCorrection, DeflatedSolveIsTheSameStepInFewerIterations) {
  {
    Cantilever a, b;
    CorotationalFem coarse(a.mesh, a.m, settings(5000, 1e-12, 40)), plain(b.mesh, b.m, settings(5000, 1e-12, 0));
    for (int s = 0; s < 6; ++s) {
      const IntegrationResult ra = a.step(coarse), rb = b.step(plain);
      ASSERT_TRUE(ra.converged && rb.converged) << s;
      EXPECT_LT(max_difference(a.v, b.v), 1e-9 * max_norm(b.v)) << s;
    }
    EXPECT_GT(coarse.coarse_aggregates(), 10);
    EXPECT_EQ(plain.coarse_aggregates(), 0);
  }
  Cantilever a, b;
  CorotationalFem coarse(a.mesh, a.m, settings(500, 1e-6, 40)), plain(b.mesh, b.m, settings(500, 1e-6, 0));
  int coarse_sum = 0, plain_sum = 0;
  for (int s = 0; s < 10; ++s) {
    const IntegrationResult ra = a.step(coarse), rb = b.step(plain);
    ASSERT_TRUE(ra.converged && rb.converged) << s;
    EXPECT_LE(ra.solver_residual, 1e-6) << s;
    EXPECT_LT(ra.solver_iterations, rb.solver_iterations) << s;
    coarse_sum += ra.solver_iterations;
    plain_sum += rb.solver_iterations;
  }
  std::printf("10 steps to 1e-6: deflated %d iterations, plain SSOR %d\n", coarse_sum, plain_sum);
}

}  // namespace
}  // namespace pliant
