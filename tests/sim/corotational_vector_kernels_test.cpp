// The step's fixed part in AVX2 lanes (session 9, sim/model/stiffness_row_kernels.h) against the
// scalar code: every lane performs the scalar expression's operations in its order, so the result
// must be the scalar code's bit for bit. Reference: the same model with the kernels switched off
// (set_vector_kernels(false), the code before). Skipped on a CPU without AVX2.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "sim/mesh/box_mesh.h"
#include "sim/model/corotational_fem.h"
#include "sim/model/stiffness_row_kernels.h"
#include "support/sagging_cantilever.h"

namespace pliant {
namespace {

bool same_bits(std::span<const Vec3> a, std::span<const Vec3> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

bool same_bits(std::span<const Mat3> a, std::span<const Mat3> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Mat3)) == 0;
}

// A cantilever of 24 x 3 x 3 cells, soft (E = 1e4 Pa) so it swings through large rotations under
// gravity at 10 ms steps, fixed at x = -0.3 m.
struct Cantilever : SaggingCantilever {
  Cantilever() : SaggingCantilever(0.6, 0.06, 24, 3, 1e4) {}
};

// Steps with K' reuse (some rows summed again per step) and without (all rows), and then K' at
// random, strongly distorted positions (inverted tets included): positions, velocities, the
// system's diagonal blocks and K' p are the scalar path's bit for bit.
TEST(VectorStiffnessRows, AssembleTheScalarBlocksBitForBit) {
  if (!stiffness_row_kernels_available()) GTEST_SKIP() << "no AVX2 on this CPU";
  for (const double reuse : {kDefaultStiffnessRotationTolerance, 0.0}) {
    Cantilever a, b;
    CorotationalFem vector(a.mesh, a.m, {}), scalar(b.mesh, b.m, {});
    scalar.set_vector_kernels(false);
    vector.set_stiffness_rotation_tolerance(reuse);
    scalar.set_stiffness_rotation_tolerance(reuse);
    EXPECT_TRUE(vector.vector_kernels());
    EXPECT_FALSE(scalar.vector_kernels());
    size_t partial_steps = 0;
    for (int s = 0; s < 12; ++s) {
      a.step(vector);
      b.step(scalar);
      ASSERT_TRUE(same_bits(a.x, b.x)) << "step " << s << ", reuse " << reuse;
      ASSERT_TRUE(same_bits(a.v, b.v)) << "step " << s << ", reuse " << reuse;
      ASSERT_TRUE(same_bits(vector.diagonal_system_blocks(), scalar.diagonal_system_blocks())) << "step " << s;
      EXPECT_EQ(vector.reassembled_rows(), scalar.reassembled_rows());
      if (vector.reassembled_rows() < a.n) ++partial_steps;
    }
    // The reuse run must have exercised partial assembly (rows kept from earlier steps).
    if (reuse > 0.0) {
      EXPECT_GT(partial_steps, 0u);
    }
  }

  // K' at random positions: rest positions moved by up to 1.5 cell edges (many tets inverted).
  Cantilever a;
  CorotationalFem vector(a.mesh, a.m, {}), scalar(a.mesh, a.m, {});
  scalar.set_vector_kernels(false);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.0375, 0.0375);
  std::vector<Vec3> x = a.x, p(a.n), ya(a.n), yb(a.n);
  for (auto& xi : x) xi += Vec3(u(rng), u(rng), u(rng));
  for (auto& pi : p) pi = Vec3(u(rng), u(rng), u(rng));
  vector.update_rotations(x);
  scalar.update_rotations(x);
  ASSERT_TRUE(vector.stiffness_is_assembled());
  vector.apply_stiffness(p, ya);
  scalar.apply_stiffness(p, yb);
  EXPECT_TRUE(same_bits(ya, yb));
}

}  // namespace
}  // namespace pliant
