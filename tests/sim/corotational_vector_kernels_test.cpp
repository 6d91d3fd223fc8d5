// The step's fixed part in AVX2 lanes (session 9, sim/model/stiffness_row_kernels.h) against the
// scalar code: every lane performs the scalar expression's operations in its order, so the result
// must be the scalar code's bit for bit. Reference: the same model with the kernels switched off
// (set_vector_kernels(false), the code before). Skipped on a CPU without AVX2.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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

// The full K' summed tet by tet (sum_stiffness_by_tet) against the row by row kernel (sum_stiffness_row
// over every row) on the model's pattern for `tets` over n vertices (CorotationalFem's constructor:
// upper rows, diagonal first, then ascending; a tet's repeated vertex maps both of its slots to the
// diagonal block, and is listed as two corners of the row, so that the row kernel adds what the tet
// loop adds, in its order), with random gradients over 12 decades, signs and signed zeros, the blocks starting
// as garbage: true when every block is equal bit for bit (and not all zero, so not vacuously).
bool by_tet_equals_by_row(const std::vector<TetIndices>& tets, size_t n, unsigned seed) {
  const size_t nt = tets.size();
  std::vector<std::vector<int>> vertex_tets(n), neighbors(n);
  for (size_t t = 0; t < nt; ++t) {
    for (int v : tets[t]) {
      auto& around = vertex_tets[static_cast<size_t>(v)];
      if (around.empty() || around.back() != static_cast<int>(t)) around.push_back(static_cast<int>(t));
      for (int j : tets[t]) {
        if (j > v) neighbors[static_cast<size_t>(v)].push_back(j);
      }
    }
  }
  std::vector<int> row_offsets{0}, cols, corners;
  std::vector<size_t> corner_offsets{0};
  for (size_t v = 0; v < n; ++v) {
    std::vector<int> row = neighbors[v];
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
    row.insert(row.begin(), static_cast<int>(v));
    for (int t : vertex_tets[v]) {
      for (int a = 0; a < 4; ++a) {  // every corner of v (a repeated vertex has two, ascending)
        if (tets[static_cast<size_t>(t)][static_cast<size_t>(a)] != static_cast<int>(v)) continue;
        corners.push_back(t);
        corners.push_back(a);
      }
    }
    cols.insert(cols.end(), row.begin(), row.end());
    row_offsets.push_back(static_cast<int>(cols.size()));
    corner_offsets.push_back(corners.size() / 2);
  }
  std::vector<int> tet_blocks(16 * nt);
  for (size_t t = 0; t < nt; ++t) {
    const auto& tet = tets[t];
    for (size_t i = 0; i < 4; ++i) {
      const auto b = cols.begin() + row_offsets[static_cast<size_t>(tet[i])];
      const auto e = cols.begin() + row_offsets[static_cast<size_t>(tet[i]) + 1];
      for (size_t j = 0; j < 4; ++j) {
        tet_blocks[16 * t + 4 * i + j] =
            tet[j] < tet[i] ? -1 : static_cast<int>(std::find(b, e, tet[j]) - cols.begin());
      }
    }
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-6, 6), pick(0, 19);
  const auto entry = [&] {
    const int k = pick(rng);
    if (k == 0) return 0.0;
    if (k == 1) return -0.0;
    return mantissa(rng) * std::pow(10.0, exponent(rng));
  };
  std::vector<double> gradients(9 * nt), volume(nt);
  for (double& g : gradients) g = entry();
  for (double& V : volume) V = std::abs(mantissa(rng)) * std::pow(10.0, exponent(rng));
  std::vector<double> by_row(9 * cols.size()), by_tet(9 * cols.size());
  for (double& b : by_row) b = entry();
  for (double& b : by_tet) b = entry();
  std::vector<int> lists(kTetBlockListSize * nt);
  tet_block_lists(tet_blocks.data(), nt, lists.data());
  StiffnessRowSystem sys{by_row.data(), gradients.data(), volume.data(), tet_blocks.data(), corners.data(),
                         3.3e4, 3e5, lists.data()};
  for (size_t i = 0; i < n; ++i) {
    sum_stiffness_row(sys, static_cast<size_t>(row_offsets[i]), static_cast<size_t>(row_offsets[i + 1]),
                      corner_offsets[i], corner_offsets[i + 1]);
  }
  sys.blocks = by_tet.data();
  sum_stiffness_by_tet(sys, cols.size(), nt);
  return std::memcmp(by_row.data(), by_tet.data(), by_row.size() * sizeof(double)) == 0 &&
         std::count_if(by_row.begin(), by_row.end(), [](double b) { return b != 0.0; }) > 0;
}

// Session 14: on a box mesh's pattern, and a vertex in no tet (its diagonal block only).
TEST(VectorStiffnessRows, SummedByTetEqualsRowByRowBitForBit) {
  if (!stiffness_row_kernels_available()) GTEST_SKIP() << "no AVX2 on this CPU";
  const TetMeshPtr box = make_box_mesh({Vec3(0.6, 0.1, 0.1), 9, 2, 2});
  EXPECT_TRUE(by_tet_equals_by_row(box->tets(), static_cast<size_t>(box->vertex_count()) + 1, 14));
}

// Session 16: the by-tet sum runs four regular tets per call in lanes, each lane choosing per corner
// pair which of (a, b) and (b, a) is stored. Here every tet's corners are shuffled (so the lanes of
// one call choose differently), some tets repeat a vertex (both slots of that pair on the diagonal
// block: such a group of four falls back to the tet-by-tet loop), and the tet count is not a multiple
// of four (the last ones one by one): every block still the row kernel's bit for bit.
TEST(VectorStiffnessRows, SummedByTetInLanesEqualsRowByRowForAnyCornerOrderBitForBit) {
  if (!stiffness_row_kernels_available()) GTEST_SKIP() << "no AVX2 on this CPU";
  const TetMeshPtr box = make_box_mesh({Vec3(0.6, 0.1, 0.1), 9, 2, 2});
  std::mt19937 rng(16);
  for (const size_t drop : {0, 1, 2, 3}) {
    std::vector<TetIndices> tets(box->tets().begin(), box->tets().end() - static_cast<long>(drop));
    for (auto& tet : tets) std::shuffle(tet.begin(), tet.end(), rng);
    EXPECT_TRUE(by_tet_equals_by_row(tets, static_cast<size_t>(box->vertex_count()), 20 + drop))
        << "regular, drop " << drop;
    for (size_t t = 5; t < tets.size(); t += 37) tets[t][t % 4] = tets[t][(t + 1) % 4];  // a repeated vertex
    EXPECT_TRUE(by_tet_equals_by_row(tets, static_cast<size_t>(box->vertex_count()), 30 + drop))
        << "degenerate, drop " << drop;
  }
}

}  // namespace
}  // namespace pliant
