// The local force queries with the full pass's AVX2 kernels (session 11,
// sim/model/corotational_local_query.cpp: four-lane rotation batches, F, P and the per-vertex sums
// -V P g_j in lanes, query_stress_kernels.h; the search's K' products, stiffness_product_kernels.h)
// against the same
// queries with the kernels switched off (set_vector_kernels(false), the code before): each lane is
// the scalar code's operations in its order, so the forces must be the scalar path's bit for bit,
// whatever the number of tets a query touches (short last batches are filled up with copies) and
// wherever the warm start faces away (inverted tets: the SVD start). Skipped without AVX2. Session 18:
// on a CPU with AVX-512 both queries take eight tets per batch (exact_query_stresses_avx512 and the
// 8-lane extraction, rotation_batch_avx512.h) before the four-lane batches, so there the test
// compares those against the scalar code too.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "sim/model/corotational_fem.h"
#include "sim/model/query_stress_kernels.h"
#include "sim/model/rotation_batch_avx2.h"
#include "sim/model/rotation_batch_avx512.h"
#include "sim/model/stiffness_product_kernels.h"
#include "support/sagging_cantilever.h"

namespace pliant {
namespace {

bool same_bits(std::span<const Vec3> a, std::span<const Vec3> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

// A soft cantilever (E = 1e4 Pa) swinging under gravity: large rotations, so the queries'
// extractions take several Newton iterations from the stored warm starts.
struct Cantilever : SaggingCantilever {
  Cantilever() : SaggingCantilever(0.6, 0.06, 24, 3, 1e4) {}
};

// The same cantilever with its rest positions jittered by up to 0.15 cell edges (the fixed end
// plane kept): a box mesh's rest shape gradients have at most two non-zero components, so the order
// of the three-term sums in -V P g_j shows only on a mesh like this one.
struct JitteredCantilever : SaggingCantilever {
  JitteredCantilever() : SaggingCantilever(0.6, 0.06, 24, 3, 1e4) {
    std::vector<Vec3> rest = mesh->rest_positions();
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-0.0033, 0.0033);
    for (auto& p : rest) {
      const bool end = fixed[static_cast<size_t>(&p - rest.data())] != 0;
      p += Vec3(end ? 0.0 : u(rng), u(rng), u(rng));
    }
    mesh = TetMesh::build(rest, mesh->tets());
    x = mesh->rest_positions();
    masses = mesh->lumped_masses(m.density);
    for (size_t i = 0; i < n; ++i) ext[i] = masses[i] * Vec3(0, 0, -9.81);
  }
};

template <class Body>
void expect_vector_queries_are_the_scalar_queries() {
  Body a, b;
  CorotationalFem vector(a.mesh, a.m, {}), scalar(b.mesh, b.m, {});
  scalar.set_vector_kernels(false);
  ASSERT_TRUE(vector.vector_kernels());
  // The 8-lane batches run wherever the CPU has them (the model's default).
  ASSERT_EQ(vector.avx512_lanes(), rotation_batch_avx512_available());
  std::mt19937 rng(11);
  for (int s = 0; s < 6; ++s) {
    a.step(vector);
    b.step(scalar);
    ASSERT_TRUE(same_bits(a.x, b.x)) << "step " << s;
    {  // K' d at moved rows (the search's later iterations), every vertex moved or a random half
      std::uniform_real_distribution<double> u(-1e-4, 1e-4);
      std::bernoulli_distribution half(0.5);
      std::vector<int> moved;
      for (int i = 0; i < static_cast<int>(a.n); ++i) {
        if (s % 2 == 0 || half(rng)) moved.push_back(i);
      }
      std::vector<Vec3> d(moved.size()), ya(moved.size()), yb(moved.size());
      for (auto& di : d) di = Vec3(u(rng), u(rng), u(rng));
      ASSERT_TRUE(vector.stiffness_product_at(moved, d, moved, ya, 1e9));
      ASSERT_TRUE(scalar.stiffness_product_at(moved, d, moved, yb, 1e9));
      ASSERT_TRUE(same_bits(ya, yb)) << "stiffness product, step " << s;
    }
    for (const double move : {1e-5, 3e-3, 4e-2}) {  // 4e-2 m: beyond a cell edge, tets inverted
      std::uniform_real_distribution<double> u(-move, move);
      for (size_t count = 1; count <= 37; count += (count < 9 ? 1 : 7)) {
        std::vector<int> vertices;
        std::uniform_int_distribution<int> pick(0, static_cast<int>(a.n) - 1);
        for (size_t k = 0; k < count; ++k) vertices.push_back(pick(rng));
        std::sort(vertices.begin(), vertices.end());
        vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
        std::vector<Vec3> x = a.x;
        for (const int v : vertices) x[static_cast<size_t>(v)] += Vec3(u(rng), u(rng), u(rng));
        std::vector<Vec3> fa(vertices.size()), fb(vertices.size());
        vector.internal_forces_at(x, vertices, fa);
        scalar.internal_forces_at(x, vertices, fb);
        ASSERT_TRUE(same_bits(fa, fb)) << "exact query, step " << s << ", move " << move << ", " << count;
        // Moved again by a tenth: the nearby query reuses some remembered rotations, re-extracts others.
        for (const int v : vertices) x[static_cast<size_t>(v)] += 0.1 * Vec3(u(rng), u(rng), u(rng));
        vector.internal_forces_at_nearby_rotations(x, vertices, fa, 1e-3);
        scalar.internal_forces_at_nearby_rotations(x, vertices, fb, 1e-3);
        ASSERT_TRUE(same_bits(fa, fb)) << "nearby query, step " << s << ", move " << move << ", " << count;
        // Moved again by the whole move: most tets leave the tolerance, so the nearby query extracts
        // many at once (whole batches of eight where the CPU has them, session 18).
        for (const int v : vertices) x[static_cast<size_t>(v)] += Vec3(u(rng), u(rng), u(rng));
        vector.internal_forces_at_nearby_rotations(x, vertices, fa, 1e-3);
        scalar.internal_forces_at_nearby_rotations(x, vertices, fb, 1e-3);
        ASSERT_TRUE(same_bits(fa, fb)) << "nearby query after a whole move, step " << s << ", move " << move << ", "
                                       << count;
      }
    }
  }
}

TEST(LocalQueryVectorKernels, ExactAndNearbyQueriesAreTheScalarQueriesBitForBit) {
  if (!rotation_batch_avx2_available() || !query_stress_kernels_available() || !stiffness_product_kernels_available()) {
    GTEST_SKIP() << "no AVX2 on this CPU";
  }
  expect_vector_queries_are_the_scalar_queries<Cantilever>();
  expect_vector_queries_are_the_scalar_queries<JitteredCantilever>();
}

}  // namespace
}  // namespace pliant
