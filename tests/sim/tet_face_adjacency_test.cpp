// Tet-face adjacency of TetMesh against brute force: for every face of every tet, the tets holding
// the same three vertices are found by scanning all tets; an interior face is shared by exactly two
// tets (each names the other), a boundary face by one, and that face is exactly one surface
// triangle with the same outward winding.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <set>

#include "sim/mesh/box_mesh.h"
#include "sim/mesh/cylinder_mesh.h"
#include "sim/mesh/sphere_mesh.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {
namespace {

std::array<int, 3> sorted_face(const TetIndices& tet, int k) {
  std::array<int, 3> f{};
  for (int i = 0; i < 3; ++i) f[static_cast<size_t>(i)] = tet[static_cast<size_t>(TetMesh::kTetFaceCorners[k][i])];
  std::sort(f.begin(), f.end());
  return f;
}

// Same triangle up to a cyclic rotation (same winding).
bool same_winding(const TriIndices& a, const TriIndices& b) {
  for (int s = 0; s < 3; ++s) {
    if (a[0] == b[static_cast<size_t>(s)] && a[1] == b[static_cast<size_t>((s + 1) % 3)] &&
        a[2] == b[static_cast<size_t>((s + 2) % 3)]) {
      return true;
    }
  }
  return false;
}

void check_against_brute_force(const TetMesh& mesh) {
  const auto& tets = mesh.tets();
  const auto& nb = mesh.tet_face_neighbors();
  const auto& tri = mesh.tet_face_triangles();
  ASSERT_EQ(nb.size(), tets.size());
  ASSERT_EQ(tri.size(), tets.size());
  std::vector<int> triangle_uses(static_cast<size_t>(mesh.surface_triangle_count()), 0);
  int interior = 0, boundary = 0;
  for (int t = 0; t < mesh.tet_count(); ++t) {
    for (int k = 0; k < 4; ++k) {
      const auto face = sorted_face(tets[static_cast<size_t>(t)], k);
      std::vector<int> sharing;  // other tets holding this face, by brute force
      for (int u = 0; u < mesh.tet_count(); ++u) {
        if (u == t) continue;
        for (int j = 0; j < 4; ++j) {
          if (sorted_face(tets[static_cast<size_t>(u)], j) == face) sharing.push_back(u);
        }
      }
      ASSERT_LE(sharing.size(), 1u) << "tet " << t << " face " << k;
      const int n = nb[static_cast<size_t>(t)][static_cast<size_t>(k)];
      const int s = tri[static_cast<size_t>(t)][static_cast<size_t>(k)];
      if (sharing.size() == 1) {
        ++interior;
        EXPECT_EQ(n, sharing[0]) << "tet " << t << " face " << k;
        EXPECT_EQ(s, -1);
        // The neighbour names this tet across the same face.
        int back = 0;
        for (int j = 0; j < 4; ++j) {
          if (nb[static_cast<size_t>(n)][static_cast<size_t>(j)] == t) {
            ++back;
            EXPECT_EQ(sorted_face(tets[static_cast<size_t>(n)], j), face);
          }
        }
        EXPECT_EQ(back, 1);
      } else {
        ++boundary;
        EXPECT_EQ(n, -1);
        ASSERT_GE(s, 0) << "tet " << t << " face " << k;
        ASSERT_LT(s, mesh.surface_triangle_count());
        ++triangle_uses[static_cast<size_t>(s)];
        const TriIndices oriented{tets[static_cast<size_t>(t)][static_cast<size_t>(TetMesh::kTetFaceCorners[k][0])],
                                  tets[static_cast<size_t>(t)][static_cast<size_t>(TetMesh::kTetFaceCorners[k][1])],
                                  tets[static_cast<size_t>(t)][static_cast<size_t>(TetMesh::kTetFaceCorners[k][2])]};
        EXPECT_TRUE(same_winding(oriented, mesh.surface_triangles()[static_cast<size_t>(s)]));
        EXPECT_EQ(mesh.surface_triangle_tets()[static_cast<size_t>(s)], t);
      }
    }
  }
  // Every surface triangle is exactly one boundary face; interior faces counted from both sides.
  for (int uses : triangle_uses) EXPECT_EQ(uses, 1);
  EXPECT_EQ(boundary, mesh.surface_triangle_count());
  EXPECT_EQ(interior % 2, 0);
  std::set<std::array<int, 3>> distinct;  // distinct faces by brute force
  for (const auto& tet : tets) {
    for (int k = 0; k < 4; ++k) distinct.insert(sorted_face(tet, k));
  }
  EXPECT_EQ(static_cast<size_t>(interior / 2 + boundary), distinct.size());
}

TEST(TetFaceAdjacency, BoxMeshesMatchBruteForce) {
  check_against_brute_force(*make_box_mesh({Vec3(1.0, 1.0, 1.0), 1, 1, 1}));
  check_against_brute_force(*make_box_mesh({Vec3(0.3, 0.2, 0.1), 3, 2, 4}));
}

TEST(TetFaceAdjacency, SphereAndCylinderMatchBruteForce) {
  check_against_brute_force(*make_sphere_mesh({1.0, 73, 2}));
  check_against_brute_force(*make_cylinder_mesh({}));
}

TEST(TetFaceAdjacency, SingleTetIsAllBoundary) {
  const auto mesh = TetMesh::build({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}, {{0, 1, 2, 3}});
  check_against_brute_force(*mesh);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(mesh->tet_face_neighbors()[0][static_cast<size_t>(k)], -1);
}

}  // namespace
}  // namespace pliant
