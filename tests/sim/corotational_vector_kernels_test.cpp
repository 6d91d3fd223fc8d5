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
struct BlockPattern {
  std::vector<int> row_offsets{0}, cols, corners, tet_blocks, lists;
  std::vector<size_t> corner_offsets{0};
};

BlockPattern block_pattern(const std::vector<TetIndices>& tets, size_t n) {
  const size_t nt = tets.size();
  BlockPattern p;
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
  for (size_t v = 0; v < n; ++v) {
    std::vector<int> row = neighbors[v];
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
    row.insert(row.begin(), static_cast<int>(v));
    for (int t : vertex_tets[v]) {
      for (int a = 0; a < 4; ++a) {  // every corner of v (a repeated vertex has two, ascending)
        if (tets[static_cast<size_t>(t)][static_cast<size_t>(a)] != static_cast<int>(v)) continue;
        p.corners.push_back(t);
        p.corners.push_back(a);
      }
    }
    p.cols.insert(p.cols.end(), row.begin(), row.end());
    p.row_offsets.push_back(static_cast<int>(p.cols.size()));
    p.corner_offsets.push_back(p.corners.size() / 2);
  }
  p.tet_blocks.resize(16 * nt);
  for (size_t t = 0; t < nt; ++t) {
    const auto& tet = tets[t];
    for (size_t i = 0; i < 4; ++i) {
      const auto b = p.cols.begin() + p.row_offsets[static_cast<size_t>(tet[i])];
      const auto e = p.cols.begin() + p.row_offsets[static_cast<size_t>(tet[i]) + 1];
      for (size_t j = 0; j < 4; ++j) {
        p.tet_blocks[16 * t + 4 * i + j] =
            tet[j] < tet[i] ? -1 : static_cast<int>(std::find(b, e, tet[j]) - p.cols.begin());
      }
    }
  }
  p.lists.resize(kTetBlockListSize * nt);
  tet_block_lists(p.tet_blocks.data(), nt, p.lists.data());
  return p;
}

/// Random entries over 12 decades, both signs and signed zeros.
struct RandomEntries {
  explicit RandomEntries(unsigned seed) : rng(seed) {}
  double operator()() {
    const int k = pick(rng);
    if (k == 0) return 0.0;
    if (k == 1) return -0.0;
    return mantissa(rng) * std::pow(10.0, exponent(rng));
  }
  double volume() { return std::abs(mantissa(rng)) * std::pow(10.0, exponent(rng)); }
  std::mt19937 rng;
  std::uniform_real_distribution<double> mantissa{-1.0, 1.0};
  std::uniform_int_distribution<int> exponent{-6, 6}, pick{0, 19};
};

// The full K' summed tet by tet (sum_stiffness_by_tet) against the row by row kernel (sum_stiffness_row
// over every row) on the model's pattern for `tets` over n vertices (CorotationalFem's constructor:
// upper rows, diagonal first, then ascending; a tet's repeated vertex maps both of its slots to the
// diagonal block, and is listed as two corners of the row, so that the row kernel adds what the tet
// loop adds, in its order), with random gradients over 12 decades, signs and signed zeros, the blocks starting
// as garbage: true when every block is equal bit for bit (and not all zero, so not vacuously).
bool by_tet_equals_by_row(const std::vector<TetIndices>& tets, size_t n, unsigned seed) {
  const size_t nt = tets.size();
  BlockPattern p = block_pattern(tets, n);
  RandomEntries entry(seed);
  std::vector<double> gradients(9 * nt), volume(nt);
  for (double& g : gradients) g = entry();
  for (double& V : volume) V = entry.volume();
  std::vector<double> by_row(9 * p.cols.size()), by_tet(9 * p.cols.size());
  for (double& b : by_row) b = entry();
  for (double& b : by_tet) b = entry();
  StiffnessRowSystem sys{by_row.data(), gradients.data(), volume.data(), p.tet_blocks.data(), p.corners.data(),
                         3.3e4, 3e5, p.lists.data()};
  for (size_t i = 0; i < n; ++i) {
    sum_stiffness_row(sys, static_cast<size_t>(p.row_offsets[i]), static_cast<size_t>(p.row_offsets[i + 1]),
                      p.corner_offsets[i], p.corner_offsets[i + 1]);
  }
  sys.blocks = by_tet.data();
  sum_stiffness_by_tet(sys, p.cols.size(), nt);
  return std::memcmp(by_row.data(), by_tet.data(), by_row.size() * sizeof(double)) == 0 &&
         std::count_if(by_row.begin(), by_row.end(), [](double b) { return b != 0.0; }) > 0;
}

// Session 19, K' reuse's partial sum: from a full K', random tets "move" (new random gradients) and
// their blocks are flagged. Reference: the row kernel with the flags over the rows of the moved tets'
// vertices (the model's row path). Against it: the flagged blocks zeroed, the terms of every regular
// tet computed (tet_stiffness_terms, in a shuffled order and in short lists: the padded last group)
// and the cached terms of the tets around those rows added (add_stiffness_terms), ascending. Every
// block equal bit for bit (the unflagged ones untouched in both), over `rounds` rounds of moves.
bool terms_equal_flagged_rows(const std::vector<TetIndices>& tets, size_t n, unsigned seed, int rounds) {
  const size_t nt = tets.size();
  BlockPattern p = block_pattern(tets, n);
  RandomEntries entry(seed);
  std::vector<double> gradients(9 * nt), volume(nt);
  for (double& g : gradients) g = entry();
  for (double& V : volume) V = entry.volume();
  std::vector<double> by_row(9 * p.cols.size()), by_terms, terms(kTetTermsSize * nt, 0.0);
  StiffnessRowSystem sys{by_row.data(), gradients.data(), volume.data(), p.tet_blocks.data(), p.corners.data(),
                         3.3e4, 3e5, p.lists.data()};
  sum_stiffness_by_tet(sys, p.cols.size(), nt);
  by_terms = by_row;
  std::uniform_int_distribution<size_t> any_tet(0, nt - 1);
  bool equal = true;
  size_t flagged_total = 0;
  for (int round = 0; round < rounds && equal; ++round) {
    std::vector<char> moved(nt, 0), dirty(p.cols.size(), 0), row_dirty(n, 0);
    const size_t moves = 1 + any_tet(entry.rng) % (nt / 4);
    for (size_t k = 0; k < moves; ++k) moved[any_tet(entry.rng)] = 1;
    for (size_t t = 0; t < nt; ++t) {
      if (moved[t] == 0) continue;
      for (size_t k = 0; k < 9; ++k) gradients[9 * t + k] = entry();
      for (int j = 0; j < 16; ++j) {
        if (p.tet_blocks[16 * t + j] >= 0) dirty[static_cast<size_t>(p.tet_blocks[16 * t + j])] = 1;
      }
      for (int v : tets[t]) row_dirty[static_cast<size_t>(v)] = 1;
    }
    flagged_total += static_cast<size_t>(std::count(dirty.begin(), dirty.end(), 1));
    sys.blocks = by_row.data();
    for (size_t i = 0; i < n; ++i) {
      if (row_dirty[i] == 0) continue;
      sum_stiffness_row(sys, static_cast<size_t>(p.row_offsets[i]), static_cast<size_t>(p.row_offsets[i + 1]),
                        p.corner_offsets[i], p.corner_offsets[i + 1], dirty.data());
    }
    for (size_t k = 0; k < dirty.size(); ++k) {
      if (dirty[k] != 0) std::fill(by_terms.begin() + static_cast<long>(9 * k), by_terms.begin() + static_cast<long>(9 * k + 9), 0.0);
    }
    std::vector<int> regular, adding;
    for (size_t t = 0; t < nt; ++t) {
      if (p.lists[kTetBlockListSize * t] >= 0) regular.push_back(static_cast<int>(t));
      bool around = false;
      for (int v : tets[t]) around = around || row_dirty[static_cast<size_t>(v)] != 0;
      if (around) adding.push_back(static_cast<int>(t));
    }
    std::shuffle(regular.begin(), regular.end(), entry.rng);
    for (size_t k = 0; k < regular.size(); k += 7) {  // lists of up to 7: full groups and a padded one
      tet_stiffness_terms(sys, regular.data() + k, std::min<size_t>(7, regular.size() - k), terms.data());
    }
    sys.blocks = by_terms.data();
    add_stiffness_terms(sys, terms.data(), adding.data(), adding.size(), dirty.data());
    equal = std::memcmp(by_row.data(), by_terms.data(), by_row.size() * sizeof(double)) == 0;
  }
  return equal && flagged_total > 0;
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

// Session 19: K' reuse's partial sum from cached terms against the row kernel with the flags, on the
// box pattern with shuffled corners (regular tets) and with repeated vertices (their blocks from the
// gradients, in their place in the ascending order), tet counts not a multiple of four.
TEST(VectorStiffnessRows, DirtyBlocksFromCachedTermsEqualTheFlaggedRowKernelBitForBit) {
  if (!stiffness_row_kernels_available()) GTEST_SKIP() << "no AVX2 on this CPU";
  const TetMeshPtr box = make_box_mesh({Vec3(0.6, 0.1, 0.1), 9, 2, 2});
  std::mt19937 rng(19);
  for (const size_t drop : {0, 3}) {
    std::vector<TetIndices> tets(box->tets().begin(), box->tets().end() - static_cast<long>(drop));
    for (auto& tet : tets) std::shuffle(tet.begin(), tet.end(), rng);
    EXPECT_TRUE(terms_equal_flagged_rows(tets, static_cast<size_t>(box->vertex_count()), 40 + drop, 30))
        << "regular, drop " << drop;
    for (size_t t = 5; t < tets.size(); t += 37) tets[t][t % 4] = tets[t][(t + 1) % 4];  // a repeated vertex
    EXPECT_TRUE(terms_equal_flagged_rows(tets, static_cast<size_t>(box->vertex_count()), 50 + drop, 30))
        << "degenerate, drop " << drop;
  }
}

}  // namespace
}  // namespace pliant
