// The batched rotation extraction (kRotationBatchLanes tets per call, and since session 9 four
// AVX2 lanes chosen at run time) against the scalar extract_rotation, the
// reference it must equal bit for bit: every lane repeats the scalar's operations in the scalar's
// order, and a lane that stopped must not move while the others go on. Inputs cover what the FEM
// meets: small strains of rotated tets with nearby warm starts (one or two Newton steps), large
// stretches and shears, inverted and near-degenerate elements (1e-12 slivers), warm starts facing
// away (the SVD start), a zero F, and iteration caps 1..3 that stop lanes at the cap. In a
// PLIANT_NATIVE build with FMA the two codes fuse multiply-adds differently: there they must agree
// to 1e-12 (and the iteration count to one).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "sim/model/query_stress_kernels.h"
#include "sim/model/rotation_batch_avx2.h"
#include "sim/model/rotation_batch_avx512.h"
#include "sim/model/rotation_extraction.h"

namespace pliant {
namespace {

bool same_bits(const Quat& a, const Quat& b) { return std::memcmp(a.coeffs().data(), b.coeffs().data(), 4 * sizeof(double)) == 0; }

Quat random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Quat q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  return q;
}

Mat3 random_matrix(std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Mat3 m;
  for (int i = 0; i < 9; ++i) m.data()[i] = scale * u(rng);
  return m;
}

/// One deformation gradient and warm start of kind `kind` (0..6).
void make_case(std::mt19937_64& rng, int kind, Mat3& F, Quat& warm) {
  const Quat R = random_rotation(rng);
  const Mat3 Rm = R.toRotationMatrix();
  std::uniform_real_distribution<double> angle(-1.0, 1.0);
  const Quat small(Eigen::AngleAxisd(1e-3 * angle(rng), Vec3::UnitX()) * Eigen::AngleAxisd(1e-3 * angle(rng), Vec3::UnitY()));
  switch (kind) {
    case 0:  // small strain, warm start one probe step away
      F = Rm * (Mat3::Identity() + random_matrix(rng, 1e-3));
      warm = R * small;
      break;
    case 1:  // large stretch and shear, warm start far away
      F = Rm * (Mat3::Identity() + random_matrix(rng, 0.6));
      warm = random_rotation(rng);
      break;
    case 2: {  // inverted: one axis flipped
      Mat3 S = Mat3::Identity() + random_matrix(rng, 0.2);
      S.col(2) = -S.col(2);
      F = Rm * S;
      warm = R * small;
      break;
    }
    case 3: {  // sliver: a singular value of 1e-12
      Mat3 S = Mat3::Identity() + random_matrix(rng, 0.1);
      S.col(1) = 1e-12 * S.col(1);
      F = Rm * S;
      warm = R;
      break;
    }
    case 4:  // warm start facing away: the SVD start
      F = Rm * (Mat3::Identity() + random_matrix(rng, 1e-2));
      warm = R * Quat(Eigen::AngleAxisd(3.1, Vec3::UnitZ()));
      break;
    case 5:  // zero F
      F = Mat3::Zero();
      warm = R;
      break;
    default:  // a pure rotation, identity warm start
      F = Rm;
      warm = Quat::Identity();
      break;
  }
}

/// 20,000 batches of L lanes through `batch` (a batched extraction), each lane against the scalar.
template <int L, class Batch>
void expect_every_lane_equals_the_scalar(Batch batch_extraction) {
  std::mt19937_64 rng(20261121);
  std::uniform_int_distribution<int> kinds(0, 6);
  int compared = 0, iterations_seen = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Mat3 F[L];
    Quat batch[L], scalar[L];
    int iterations[L], scalar_iterations[L];
    // Mixed kinds within a batch (lanes stop at different iterations) and uniform batches.
    const int uniform = trial % 3 == 0 ? kinds(rng) : -1;
    int kind_of[L];
    for (int l = 0; l < L; ++l) {
      kind_of[l] = uniform >= 0 ? uniform : kinds(rng);
      make_case(rng, kind_of[l], F[l], batch[l]);
      scalar[l] = batch[l];
    }
    const int cap = trial % 10 == 0 ? 1 + trial / 10 % 3 : kElementRotationIterations;
    const double tolerance = trial % 7 == 0 ? 1e-13 : kElementRotationTolerance;
    batch_extraction(F, batch, cap, tolerance, iterations);
    for (int l = 0; l < L; ++l) {
      scalar_iterations[l] = extract_rotation(F[l], scalar[l], cap, tolerance);
#ifdef __FMA__
      // -march=native with FMA (PLIANT_NATIVE): the compiler fuses multiply-adds differently in
      // the two codes (and Eigen's kernels fuse explicitly), so only the last bits may differ.
      ASSERT_LT((batch[l].coeffs() - scalar[l].coeffs()).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
      ASSERT_LE(std::abs(iterations[l] - scalar_iterations[l]), 1) << "trial " << trial;
      iterations_seen += iterations[l];
      ++compared;
      continue;
#endif
      ASSERT_TRUE(same_bits(batch[l], scalar[l]))
          << "trial " << trial << " lane " << l << " kind " << kind_of[l] << " cap " << cap << " it " << iterations[l] << "/" << scalar_iterations[l] << ": " << batch[l].coeffs().transpose() << " vs "
          << scalar[l].coeffs().transpose();
      ASSERT_EQ(iterations[l], scalar_iterations[l]) << "trial " << trial << " lane " << l;
      iterations_seen += iterations[l];
      ++compared;
    }
  }
  EXPECT_EQ(compared, 20000 * L);
  EXPECT_GT(iterations_seen, compared);  // more than one iteration per lane on average: the loop ran
}

TEST(RotationExtractionBatch, EveryLaneEqualsTheScalarExtractionBitForBit) {
  expect_every_lane_equals_the_scalar<kRotationBatchLanes>(
      [](const Mat3* F, Quat* q, int cap, double tolerance, int* iterations) {
        extract_rotations_batch(F, q, cap, tolerance, iterations);
      });
}

// Session 9: the same template in four AVX2 lanes, chosen at run time (rotation_batch_avx2.h).
TEST(RotationExtractionBatch, AvxLanesEqualTheScalarExtractionBitForBit) {
  if (!rotation_batch_avx2_available()) GTEST_SKIP() << "no AVX2 on this CPU";
  expect_every_lane_equals_the_scalar<kRotationBatchLanesAvx2>(
      [](const Mat3* F, Quat* q, int cap, double tolerance, int* iterations) {
        extract_rotations_batch_avx2(F, q, cap, tolerance, iterations);
      });
}

// Session 17: the same template in eight AVX-512 lanes (rotation_batch_avx512.h, compiled without
// contraction): every lane the scalar's bits and count, as the four AVX2 lanes'.
TEST(RotationExtractionBatch, Avx512LanesEqualTheScalarExtractionBitForBit) {
  if (!rotation_batch_avx512_available()) GTEST_SKIP() << "no AVX-512 on this CPU or build";
  expect_every_lane_equals_the_scalar<kRotationBatchLanesAvx512>(
      [](const Mat3* F, Quat* q, int cap, double tolerance, int* iterations) {
        extract_rotations_batch_avx512(F, q, cap, tolerance, iterations);
      });
}

// Eight lanes run until the slowest stops: one lane that needs many iterations (a far warm start on a
// large stretch, or an inverted element) among seven that stop after one or two must not move the
// seven once they stopped, whichever lane is the slow one; and a batch stopped at the iteration cap
// leaves every lane at the scalar's result for that cap.
TEST(RotationExtractionBatch, Avx512LanesThatStoppedStayWhileOneLaneIterates) {
  if (!rotation_batch_avx512_available()) GTEST_SKIP() << "no AVX-512 on this CPU or build";
  constexpr int L = kRotationBatchLanesAvx512;
  std::mt19937_64 rng(20261128);
  int slow_iterations = 0, fast_iterations = 0, fast_lanes = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    Mat3 F[L];
    Quat batch[L], scalar[L];
    int iterations[L];
    const int slow = trial % L;
    for (int l = 0; l < L; ++l) {
      make_case(rng, l == slow ? (trial % 2 == 0 ? 1 : 2) : (trial % 3 == 0 ? 6 : 0), F[l], batch[l]);
      scalar[l] = batch[l];
    }
    const int cap = trial % 5 == 0 ? 1 + trial / 5 % 4 : kElementRotationIterations;
    extract_rotations_batch_avx512(F, batch, cap, kElementRotationTolerance, iterations);
    for (int l = 0; l < L; ++l) {
      const int expected = extract_rotation(F[l], scalar[l], cap, kElementRotationTolerance);
#ifdef __FMA__
      ASSERT_LT((batch[l].coeffs() - scalar[l].coeffs()).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
      continue;
#endif
      ASSERT_TRUE(same_bits(batch[l], scalar[l])) << "trial " << trial << " lane " << l << " slow lane " << slow;
      ASSERT_EQ(iterations[l], expected) << "trial " << trial << " lane " << l;
      if (cap != kElementRotationIterations) continue;
      if (l == slow) {
        slow_iterations += iterations[l];
      } else {
        fast_iterations += iterations[l];
        ++fast_lanes;
      }
    }
  }
  // The mix is what the test is about: the slow lanes iterate several times longer than the others.
  EXPECT_GT(slow_iterations * 7, 2 * fast_iterations);
  EXPECT_GT(fast_lanes, 0);
}

// Session 17: the evaluation pass's 8-lane kernel (evaluate_tets_avx512) computes F from the
// positions, the rotation and the element forces in the same lanes: against the scalar pass's
// operations per tet (CorotationalFem::deformation_gradient's Ds * Dm^-1, extract_rotation from the
// warm start, evaluate_tet_batch's energy and H = (-V P) Dm^-T), bit for bit. Each tet's F is one of
// the cases above through a random full rest shape (volumes and Lame parameters over four decades),
// its four vertices numbered at random in a shared position array.
TEST(RotationExtractionBatch, Avx512PassKernelEqualsTheScalarPassExpressionsBitForBit) {
  if (!rotation_batch_avx512_available()) GTEST_SKIP() << "no AVX-512 on this CPU or build";
  constexpr int L = kRotationBatchLanesAvx512;
  std::mt19937_64 rng(20261129);
  std::uniform_int_distribution<int> kinds(0, 6);
  std::uniform_real_distribution<double> decade(-2.0, 2.0), coordinate(-0.05, 0.05);
  int compared = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    std::vector<int> numbers(4 * L);
    for (int v = 0; v < 4 * L; ++v) numbers[static_cast<size_t>(v)] = v;
    std::shuffle(numbers.begin(), numbers.end(), rng);
    TetIndices tets[L];
    std::vector<Vec3> x(4 * L);
    Mat3 Dm_inv[L], H[L];
    Quat batch[L], warm[L];
    double volume[L], energy[L];
    const int uniform = trial % 3 == 0 ? kinds(rng) : -1;
    for (int l = 0; l < L; ++l) {
      Mat3 target;
      make_case(rng, uniform >= 0 ? uniform : kinds(rng), target, warm[l]);
      batch[l] = warm[l];
      const Mat3 rest_shape = 0.02 * (Mat3::Identity() + random_matrix(rng, 0.3));
      Dm_inv[l] = rest_shape.inverse();
      const Mat3 Ds = target * rest_shape;
      const Vec3 x0(coordinate(rng), coordinate(rng), coordinate(rng));
      for (size_t k = 0; k < 4; ++k) {
        const int v = numbers[static_cast<size_t>(4 * l) + k];
        tets[l][k] = v;
        x[static_cast<size_t>(v)] = k == 0 ? x0 : Vec3(x0 + Ds.col(static_cast<int>(k) - 1));
      }
      volume[l] = std::pow(10.0, decade(rng) - 6.0);
    }
    const double mu = 3e4 * std::pow(10.0, decade(rng)), lambda = 1e5 * std::pow(10.0, decade(rng));
    const int cap = trial % 10 == 0 ? 1 + trial / 10 % 3 : kElementRotationIterations;
    // Warm starts read from one array and the rotations written to another (the energy query's pass),
    // or both the same array (linearise's), alternately.
    Quat out[L];
    Quat* const rotations = trial % 2 == 0 ? batch : out;
    evaluate_tets_avx512(x.data()->data(), tets, Dm_inv, volume, mu, lambda, cap, kElementRotationTolerance, batch,
                         rotations, energy, H);
    if (rotations == out) {
      for (int l = 0; l < L; ++l) ASSERT_TRUE(same_bits(batch[l], warm[l])) << "warm start " << l << " rewritten";
    }
    for (int l = 0; l < L; ++l) {
      const Vec3& x0 = x[static_cast<size_t>(tets[l][0])];
      Mat3 Ds;  // CorotationalFem::deformation_gradient's expressions
      for (int k = 0; k < 3; ++k) Ds.col(k) = x[static_cast<size_t>(tets[l][static_cast<size_t>(k) + 1])] - x0;
      const Mat3 F = Ds * Dm_inv[l];
      Quat scalar = warm[l];
      extract_rotation(F, scalar, cap, kElementRotationTolerance);
      const Mat3 R = scalar.toRotationMatrix();  // evaluate_tet_batch's expressions
      const double trace = R.cwiseProduct(F).sum() - 3.0;
      const Mat3 FmR = F - R;
      const double expected_energy = volume[l] * (mu * FmR.squaredNorm() + 0.5 * lambda * trace * trace);
      const Mat3 P = 2.0 * mu * FmR + lambda * trace * R;
      const Mat3 expected_H = -volume[l] * P * Dm_inv[l].transpose();
#ifdef __FMA__
      ASSERT_LT((H[l] - expected_H).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + expected_H.cwiseAbs().maxCoeff()));
      ++compared;
      continue;
#endif
      ASSERT_TRUE(same_bits(rotations[l], scalar)) << "trial " << trial << " lane " << l;
      ASSERT_EQ(std::memcmp(&energy[l], &expected_energy, sizeof(double)), 0)
          << "trial " << trial << " lane " << l << ": " << energy[l] << " vs " << expected_energy;
      ASSERT_EQ(std::memcmp(H[l].data(), expected_H.data(), sizeof(Mat3)), 0)
          << "trial " << trial << " lane " << l << ":\n" << H[l] << "\nvs\n" << expected_H;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 20000 * L);
}

// Session 13: the local queries take R from the extraction's lanes (normalised and built there)
// instead of q.toRotationMatrix() per tet: q and R must be the scalar extraction's q and its
// toRotationMatrix() bit for bit, over the same cases and iteration caps as above.
TEST(RotationExtractionBatch, AvxRotationMatricesEqualTheScalarsBitForBit) {
  if (!rotation_batch_avx2_available()) GTEST_SKIP() << "no AVX2 on this CPU";
  constexpr int L = kRotationBatchLanesAvx2;
  std::mt19937_64 rng(20261122);
  std::uniform_int_distribution<int> kinds(0, 6);
  int compared = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Mat3 F[L], R[L];
    Quat batch[L], scalar[L];
    const int uniform = trial % 3 == 0 ? kinds(rng) : -1;
    for (int l = 0; l < L; ++l) {
      make_case(rng, uniform >= 0 ? uniform : kinds(rng), F[l], batch[l]);
      scalar[l] = batch[l];
    }
    const int cap = trial % 10 == 0 ? 1 + trial / 10 % 3 : kElementRotationIterations;
    extract_rotation_matrices_batch_avx2(F, batch, R, cap, kElementRotationTolerance);
    for (int l = 0; l < L; ++l) {
      extract_rotation(F[l], scalar[l], cap, kElementRotationTolerance);
      const Mat3 expected = scalar[l].toRotationMatrix();
#ifdef __FMA__
      ASSERT_LT((R[l] - expected).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
      ++compared;
      continue;
#endif
      ASSERT_TRUE(same_bits(batch[l], scalar[l])) << "trial " << trial << " lane " << l;
      ASSERT_EQ(std::memcmp(R[l].data(), expected.data(), 9 * sizeof(double)), 0)
          << "trial " << trial << " lane " << l << ":\n" << R[l] << "\nvs\n" << expected;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 20000 * L);
}

// Session 14: the exact query's whole batches compute F = Ds Dm^-1 in the extraction's lanes, then
// R and P there (exact_query_stresses_avx2). Against the scalar query's operations per tet:
// CorotationalFem::deformation_gradient's Ds * Dm^-1 from the positions, extract_rotation from the
// warm start, toRotationMatrix and first_piola's P, bit for bit. Each lane's F is one of the cases
// above (through a random rest shape, so Dm^-1 is full and every term of Eigen's row order counts),
// its tet a random one of a small mesh with shuffled vertex numbers.
TEST(RotationExtractionBatch, ExactQueryStressesFromPositionsEqualTheScalarQueryBitForBit) {
  if (!query_stress_kernels_available()) GTEST_SKIP() << "no exact AVX2 kernels in this build or CPU";
  constexpr int L = kRotationBatchLanesAvx2;
  constexpr int kTets = 6;
  const double mu = 3.4e4, lambda = 1.6e5;  // Pa
  std::mt19937_64 rng(20261123);
  std::uniform_int_distribution<int> kinds(0, 6);
  std::uniform_real_distribution<double> coordinate(-0.05, 0.05);
  int compared = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    // kTets tets over 4 kTets vertices numbered in a random order; the batch takes L of them.
    std::vector<int> numbers(4 * kTets);
    for (int v = 0; v < 4 * kTets; ++v) numbers[static_cast<size_t>(v)] = v;
    std::shuffle(numbers.begin(), numbers.end(), rng);
    std::vector<TetIndices> mesh_tets(kTets);
    std::vector<Mat3> rest_shape_inverse(kTets);
    std::vector<Vec3> x(4 * kTets);
    std::vector<Quat> warm(kTets);
    for (int t = 0; t < kTets; ++t) {
      Mat3 target;
      make_case(rng, kinds(rng), target, warm[static_cast<size_t>(t)]);
      const Mat3 rest_shape = 0.02 * (Mat3::Identity() + random_matrix(rng, 0.3));
      rest_shape_inverse[static_cast<size_t>(t)] = rest_shape.inverse();
      const Mat3 Ds = target * rest_shape;
      const Vec3 x0(coordinate(rng), coordinate(rng), coordinate(rng));
      for (int j = 0; j < 4; ++j) {
        const int v = numbers[static_cast<size_t>(4 * t + j)];
        mesh_tets[static_cast<size_t>(t)][static_cast<size_t>(j)] = v;
        x[static_cast<size_t>(v)] = j == 0 ? x0 : Vec3(x0 + Ds.col(j - 1));
      }
    }
    std::vector<int> order(kTets);
    for (int t = 0; t < kTets; ++t) order[static_cast<size_t>(t)] = t;
    std::shuffle(order.begin(), order.end(), rng);
    const int cap = trial % 10 == 0 ? 1 + trial / 10 % 3 : kElementRotationIterations;
    Quat q[L];
    Mat3 F[L], R[L], P[L];
    Mat3 *F_out[L], *R_out[L];
    for (int l = 0; l < L; ++l) {
      q[l] = warm[static_cast<size_t>(order[static_cast<size_t>(l)])];
      F_out[l] = &F[l];
      R_out[l] = &R[l];
    }
    exact_query_stresses_avx2(x.data()->data(), mesh_tets.data(), rest_shape_inverse.data(), order.data(), q, mu,
                              lambda, cap, kElementRotationTolerance, F_out, R_out, P);
    for (int l = 0; l < L; ++l) {
      const auto t = static_cast<size_t>(order[static_cast<size_t>(l)]);
      const TetIndices& tet = mesh_tets[t];
      const Vec3& x0 = x[static_cast<size_t>(tet[0])];
      Mat3 Ds;  // CorotationalFem::deformation_gradient's expressions
      Ds.col(0) = x[static_cast<size_t>(tet[1])] - x0;
      Ds.col(1) = x[static_cast<size_t>(tet[2])] - x0;
      Ds.col(2) = x[static_cast<size_t>(tet[3])] - x0;
      const Mat3 expected_F = Ds * rest_shape_inverse[t];
      Quat scalar = warm[t];
      extract_rotation(expected_F, scalar, cap, kElementRotationTolerance);
      const Mat3 expected_R = scalar.toRotationMatrix();
      const double trace = expected_R.cwiseProduct(expected_F).sum() - 3.0;  // first_piola's
      const Mat3 expected_P = 2.0 * mu * (expected_F - expected_R) + lambda * trace * expected_R;
#ifdef __FMA__
      ASSERT_LT((P[l] - expected_P).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + expected_P.cwiseAbs().maxCoeff()));
      ++compared;
      continue;
#endif
      ASSERT_EQ(std::memcmp(F[l].data(), expected_F.data(), 9 * sizeof(double)), 0)
          << "trial " << trial << " lane " << l << ":\n" << F[l] << "\nvs\n" << expected_F;
      ASSERT_EQ(std::memcmp(R[l].data(), expected_R.data(), 9 * sizeof(double)), 0) << "trial " << trial << " lane " << l;
      ASSERT_EQ(std::memcmp(P[l].data(), expected_P.data(), 9 * sizeof(double)), 0)
          << "trial " << trial << " lane " << l << ":\n" << P[l] << "\nvs\n" << expected_P;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 20000 * L);
}

}  // namespace
}  // namespace pliant
