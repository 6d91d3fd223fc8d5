// The per-tet 3x3 products in AVX2 lanes (session 10, sim/model/tet_gradient_kernels.h) against the
// scalar code: every lane performs Eigen's multiplications and additions in Eigen's order, so the
// results must be the scalar code's bit for bit. References: the scalar Eigen expressions of
// CorotationalFem (Ds Dm^-1, R Dm^-T, (-V P) Dm^-T) on random matrices over many magnitudes, and the
// same model with the kernels switched off (set_vector_kernels(false), the code before). Skipped
// where the kernels do not run (no AVX2, or a -march=native build).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "sim/model/corotational_fem.h"
#include "sim/model/tet_gradient_kernels.h"
#include "sim/material.h"
#include "sim/mesh/box_mesh.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {
namespace {

bool same_bits(const Mat3& a, const Mat3& b) { return std::memcmp(a.data(), b.data(), sizeof(Mat3)) == 0; }

bool same_bits(std::span<const Vec3> a, std::span<const Vec3> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

// Entries spread over 24 decades with random signs, some exact zeros and negative zeros: sums whose
// order matters (cancellation, absorption) are common.
struct RandomEntries {
  std::mt19937_64 rng{10};
  std::uniform_real_distribution<double> unit{-1.0, 1.0};
  std::uniform_int_distribution<int> decade{-12, 12};
  std::uniform_int_distribution<int> kind{0, 31};
  double operator()() {
    const int k = kind(rng);
    if (k == 0) return 0.0;
    if (k == 1) return -0.0;
    return unit(rng) * std::pow(10.0, decade(rng));
  }
  Mat3 matrix() {
    Mat3 A;
    for (int i = 0; i < 9; ++i) A.data()[i] = (*this)();
    return A;
  }
};

TEST(TetGradientKernels, DeformationGradientEqualsTheScalarProductBitForBit) {
  if (!tet_gradient_kernels_available()) GTEST_SKIP() << "kernels off (no AVX2, or a native build)";
  RandomEntries r;
  std::uniform_int_distribution<int> vertex(0, 5);
  std::vector<Vec3> x(6);
  for (int s = 0; s < 100000; ++s) {
    for (auto& xi : x) xi = Vec3(r(), r(), r());
    // Distinct vertices mostly; repeated ones (degenerate tets) too.
    const TetIndices tet{vertex(r.rng), vertex(r.rng), vertex(r.rng), vertex(r.rng)};
    const Mat3 Dm_inv = r.matrix();
    Mat3 Ds;
    Ds.col(0) = x[static_cast<size_t>(tet[1])] - x[static_cast<size_t>(tet[0])];
    Ds.col(1) = x[static_cast<size_t>(tet[2])] - x[static_cast<size_t>(tet[0])];
    Ds.col(2) = x[static_cast<size_t>(tet[3])] - x[static_cast<size_t>(tet[0])];
    const Mat3 expected = Ds * Dm_inv;
    Mat3 F;
    deformation_gradients_avx2(x.data()->data(), &tet, &Dm_inv, 1, &F);
    ASSERT_TRUE(same_bits(F, expected)) << "sample " << s << "\n" << F - expected;
  }
}

TEST(TetGradientKernels, RotatedGradientAndElementForcesEqualTheScalarProductsBitForBit) {
  if (!tet_gradient_kernels_available()) GTEST_SKIP() << "kernels off (no AVX2, or a native build)";
  RandomEntries r;
  for (int s = 0; s < 100000; ++s) {
    Quat q(r.unit(r.rng), r.unit(r.rng), r.unit(r.rng), r.unit(r.rng));
    q.normalize();
    const Mat3 Dm_inv = r.matrix(), F = r.matrix();
    Mat3 G;
    rotated_gradients_avx2(&q, &Dm_inv, 1, &G);
    const Mat3 R = q.toRotationMatrix();
    ASSERT_TRUE(same_bits(G, Mat3(R * Dm_inv.transpose()))) << "sample " << s;
    // evaluate_tet_batch's expressions with random material and volume
    const double mu = std::abs(r()), lambda = std::abs(r()), volume = std::abs(r());
    const double trace = R.cwiseProduct(F).sum() - 3.0;
    const Mat3 FmR = F - R;
    const double expected_energy = volume * (mu * FmR.squaredNorm() + 0.5 * lambda * trace * trace);
    const Mat3 P = 2.0 * mu * FmR + lambda * trace * R;
    const Mat3 expected = -volume * P * Dm_inv.transpose();
    Mat3 H;
    double energy = 0.0;
    element_forces_avx2(&q, &F, &Dm_inv, &volume, mu, lambda, 1, &energy, &H);
    ASSERT_EQ(std::memcmp(&energy, &expected_energy, sizeof(double)), 0) << "sample " << s;
    ASSERT_TRUE(same_bits(H, expected)) << "sample " << s << "\n" << H - expected;
  }
}

// Session 11: element_forces_avx2 runs four tets at a time with one tet per lane (R from the
// quaternion, trace, |F - R|^2, energy, P and H = (-V P) Dm^-T in the lanes), the rest of a batch
// one by one. Batches of 1 to 9 tets (both paths and their seam), every tet against the scalar
// expressions of evaluate_tet_batch.
TEST(TetGradientKernels, ElementForcesInTetLanesEqualTheScalarExpressionsBitForBit) {
  if (!tet_gradient_kernels_available()) GTEST_SKIP() << "kernels off (no AVX2, or a native build)";
  RandomEntries r;
  std::uniform_int_distribution<int> batch(1, 9);
  constexpr int kMaxBatch = 9;
  for (int s = 0; s < 30000; ++s) {
    const auto count = static_cast<size_t>(batch(r.rng));
    const double mu = std::abs(r()), lambda = std::abs(r());
    Quat q[kMaxBatch];
    Mat3 F[kMaxBatch], Dm_inv[kMaxBatch], H[kMaxBatch];
    double volume[kMaxBatch], energy[kMaxBatch];
    for (size_t l = 0; l < count; ++l) {
      q[l] = Quat(r.unit(r.rng), r.unit(r.rng), r.unit(r.rng), r.unit(r.rng));
      q[l].normalize();
      F[l] = r.matrix();
      Dm_inv[l] = r.matrix();
      volume[l] = std::abs(r());
    }
    element_forces_avx2(q, F, Dm_inv, volume, mu, lambda, count, energy, H);
    for (size_t l = 0; l < count; ++l) {
      const Mat3 R = q[l].toRotationMatrix();
      const double trace = R.cwiseProduct(F[l]).sum() - 3.0;
      const Mat3 FmR = F[l] - R;
      const double expected_energy = volume[l] * (mu * FmR.squaredNorm() + 0.5 * lambda * trace * trace);
      const Mat3 P = 2.0 * mu * FmR + lambda * trace * R;
      const Mat3 expected = -volume[l] * P * Dm_inv[l].transpose();
      ASSERT_EQ(std::memcmp(&energy[l], &expected_energy, sizeof(double)), 0)
          << "sample " << s << " tet " << l << " of " << count << ": " << energy[l] << " vs " << expected_energy;
      ASSERT_TRUE(same_bits(H[l], expected)) << "sample " << s << " tet " << l << " of " << count << "\n"
                                             << H[l] - expected;
    }
  }
}

// Session 11: rotated_gradients_avx2 and rotated_gradients_at_avx2 (the K' reuse step's moved tets,
// by index) run four tets per call in lanes; batches of 1 to 9 (lanes, the tail and their seam),
// indices drawn without repetition from 16 tets, every gradient against the scalar R Dm^-T and the
// tets not asked for untouched.
TEST(TetGradientKernels, RotatedGradientsInTetLanesEqualTheScalarProductBitForBit) {
  if (!tet_gradient_kernels_available()) GTEST_SKIP() << "kernels off (no AVX2, or a native build)";
  RandomEntries r;
  std::uniform_int_distribution<int> batch(1, 9);
  constexpr size_t kTets = 16;
  std::vector<int> order(kTets);
  for (int s = 0; s < 20000; ++s) {
    Quat q[kTets];
    Mat3 Dm_inv[kTets], expected[kTets], G[kTets], G_at[kTets];
    for (size_t t = 0; t < kTets; ++t) {
      q[t] = Quat(r.unit(r.rng), r.unit(r.rng), r.unit(r.rng), r.unit(r.rng));
      q[t].normalize();
      Dm_inv[t] = r.matrix();
      expected[t] = q[t].toRotationMatrix() * Dm_inv[t].transpose();
      G[t] = G_at[t] = Mat3::Constant(7.0);
    }
    const auto count = static_cast<size_t>(batch(r.rng));
    rotated_gradients_avx2(q, Dm_inv, count, G);
    for (size_t t = 0; t < kTets; ++t) {
      ASSERT_TRUE(same_bits(G[t], t < count ? expected[t] : Mat3(Mat3::Constant(7.0))))
          << "sample " << s << " tet " << t << " of " << count;
    }
    for (size_t t = 0; t < kTets; ++t) order[t] = static_cast<int>(t);
    std::shuffle(order.begin(), order.end(), r.rng);
    rotated_gradients_at_avx2(q, Dm_inv, order.data(), count, G_at);
    std::vector<char> asked(kTets, 0);
    for (size_t l = 0; l < count; ++l) asked[static_cast<size_t>(order[l])] = 1;
    for (size_t t = 0; t < kTets; ++t) {
      ASSERT_TRUE(same_bits(G_at[t], asked[t] != 0 ? expected[t] : Mat3(Mat3::Constant(7.0))))
          << "sample " << s << " tet " << t << " (by index), " << count << " asked";
    }
  }
}

TEST(TetGradientKernels, ScatterEqualsTheScalarScatterBitForBit) {
  if (!tet_gradient_kernels_available()) GTEST_SKIP() << "kernels off (no AVX2, or a native build)";
  RandomEntries r;
  std::uniform_int_distribution<int> vertex(0, 5);
  std::vector<Vec3> f(6), expected(6);
  for (int s = 0; s < 100000; ++s) {
    for (auto& fi : f) fi = Vec3(r(), r(), r());
    expected = f;
    // A batch of four tets sharing vertices (repeats inside a tet too), scattered in order.
    TetIndices tets[4];
    Mat3 H[4];
    for (int l = 0; l < 4; ++l) {
      tets[l] = {vertex(r.rng), vertex(r.rng), vertex(r.rng), vertex(r.rng)};
      H[l] = r.matrix();
      // CorotationalFem's scatter_tet
      const TetIndices& tet = tets[l];
      expected[static_cast<size_t>(tet[0])] -= H[l].col(0) + H[l].col(1) + H[l].col(2);
      for (int j = 0; j < 3; ++j) expected[static_cast<size_t>(tet[static_cast<size_t>(j + 1)])] += H[l].col(j);
    }
    scatter_element_forces_avx2(tets, H, 4, f.data()->data());
    ASSERT_TRUE(same_bits(f, expected)) << "sample " << s;
  }
}

// The model with the kernels on and off, on a box mesh whose rest vertices are jittered by up to a
// fifth of a cell (a regular mesh's Dm^-1 has zeros and equal entries, where the order of a sum
// cannot show), at positions moved by up to 1.5 cell edges (many tets inverted): the forces, the
// energy and K' p bit for bit. (Steps, where the rotated gradients enter K', are
// corotational_vector_kernels_test's: the model with every kernel on against the scalar one.)
TEST(TetGradientKernels, ModelWithKernelsEqualsTheScalarModelBitForBit) {
  if (!tet_gradient_kernels_available()) GTEST_SKIP() << "kernels off (no AVX2, or a native build)";
  const TetMeshPtr box = make_box_mesh({Vec3(0.6, 0.06, 0.06), 24, 3, 3});  // cells 0.025 x 0.02 x 0.02 m
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-0.004, 0.004), u(-0.0375, 0.0375);
  std::vector<Vec3> rest = box->rest_positions();
  for (auto& r : rest) r += Vec3(jitter(rng), jitter(rng), jitter(rng));
  const TetMeshPtr mesh = TetMesh::build(rest, box->tets());
  Material m;
  m.young_modulus = 1e4;
  m.poisson_ratio = 0.45;
  CorotationalFem vector(mesh, m, {}), scalar(mesh, m, {});
  scalar.set_vector_kernels(false);
  ASSERT_TRUE(vector.vector_kernels());
  std::vector<Vec3> x = rest, fa(rest.size()), fb(rest.size()), p(rest.size());
  for (auto& xi : x) xi += Vec3(u(rng), u(rng), u(rng));
  for (auto& pi : p) pi = Vec3(u(rng), u(rng), u(rng));
  vector.internal_forces(x, fa);
  scalar.internal_forces(x, fb);
  EXPECT_TRUE(same_bits(fa, fb));
  const double ea = vector.elastic_energy(x), eb = scalar.elastic_energy(x);
  EXPECT_EQ(std::memcmp(&ea, &eb, sizeof(double)), 0);
  // K' p after the rotations at x: the assembly reads the rotated shape gradients.
  vector.update_rotations(x);
  scalar.update_rotations(x);
  ASSERT_TRUE(vector.stiffness_is_assembled());
  vector.apply_stiffness(p, fa);
  scalar.apply_stiffness(p, fb);
  EXPECT_TRUE(same_bits(fa, fb));
}

}  // namespace
}  // namespace pliant
