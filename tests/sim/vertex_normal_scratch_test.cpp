// Stage 2's scratch of vertex normals (sim/collision/vertex_normal_scratch.h) against the whole
// surface's normals of TetMesh::vertex_normals: bit for bit, across generations that switch mesh
// and pose, and for meshes large enough that indices share table slots (evicted and recomputed).
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <vector>

#include "sim/collision/vertex_normal_scratch.h"
#include "sim/collision/vertex_normal_scratch_inl.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

TEST(VertexNormalScratch, EqualsTetMeshVertexNormalsBitForBitAcrossGenerationsAndSharedSlots) {
  // One cell (8 vertices), a 4-cell block (the benchmark's bodies: 125 vertices, 192 triangles)
  // and blocks with more vertices (and triangles) than the tables have slots.
  const BoxMeshSpec specs[] = {{Vec3(1.0, 1.0, 1.0), 1, 1, 1}, {Vec3(0.4, 0.4, 0.4), 4, 4, 4},
                               {Vec3(1.0, 0.6, 0.4), 10, 6, 4}, {Vec3(2.0, 0.5, 0.5), 17, 5, 3}};
  std::vector<std::shared_ptr<const TetMesh>> meshes;
  for (const BoxMeshSpec& spec : specs) meshes.push_back(make_box_mesh(spec));
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> jitter(-1.0, 1.0);
  VertexNormalScratch scratch;
  long long compared = 0, shared_slot_meshes = 0;
  for (int generation = 0; generation < 60; ++generation) {
    // Every generation a mesh (they alternate, so consecutive generations switch meshes) at a
    // new pose: a normal kept from an earlier generation would be another pose's.
    const TetMesh& mesh = *meshes[static_cast<size_t>(generation) % meshes.size()];
    std::vector<Vec3> x = mesh.rest_positions();
    for (Vec3& p : x) p += 0.02 * Vec3(jitter(rng), jitter(rng), jitter(rng));
    std::vector<Vec3> reference(x.size());
    mesh.vertex_normals(x, reference);
    shared_slot_meshes += mesh.vertex_count() > 256;
    scratch.begin(mesh, x);
    // Surface vertices in a random order with repeats (as hits reach them), some twice in a row.
    const std::vector<int>& surface = mesh.surface_vertices();
    for (int q = 0; q < 3 * static_cast<int>(surface.size()); ++q) {
      const int v = surface[rng() % surface.size()];
      for (int twice = 0; twice < 1 + q % 2; ++twice) {
        const Vec3 n = scratch.normal(v);
        for (int k = 0; k < 3; ++k) {
          ASSERT_EQ(n[k], reference[static_cast<size_t>(v)][k])
              << "generation " << generation << " vertex " << v << " component " << k;
        }
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 20000);
  EXPECT_GT(shared_slot_meshes, 20);
}

}  // namespace
}  // namespace pliant
