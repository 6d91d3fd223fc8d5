// TetMesh and the procedural box against closed forms: counts, volume, closed 2-manifold surface
// (Euler characteristic 2) and outward orientation by the divergence theorem.
#include <gtest/gtest.h>

#include <map>

#include "sim/input_error.h"
#include "sim/mesh/box_mesh.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {
namespace {

class BoxMeshTest : public ::testing::TestWithParam<std::array<int, 3>> {};

TEST_P(BoxMeshTest, CountsVolumeManifoldAndOrientation) {
  const auto [nx, ny, nz] = GetParam();
  const Vec3 size(0.3, 0.2, 0.1);
  const auto mesh = make_box_mesh({size, nx, ny, nz});
  EXPECT_EQ(mesh->vertex_count(), (nx + 1) * (ny + 1) * (nz + 1));
  EXPECT_EQ(mesh->tet_count(), 6 * nx * ny * nz);
  EXPECT_EQ(mesh->surface_triangle_count(), 4 * (nx * ny + ny * nz + nz * nx));
  EXPECT_NEAR(mesh->total_rest_volume(), size.prod(), 1e-15);

  // Every surface edge is shared by exactly two triangles, once in each direction.
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : mesh->surface_triangles()) {
    for (int k = 0; k < 3; ++k) directed[{t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]}]++;
  }
  for (const auto& [e, count] : directed) {
    EXPECT_EQ(count, 1);
    EXPECT_EQ(directed.count({e.second, e.first}), 1u) << "edge without its twin";
  }
  const long V = static_cast<long>(mesh->surface_vertices().size());
  const long E = static_cast<long>(directed.size() / 2);
  const long F = mesh->surface_triangle_count();
  EXPECT_EQ(V - E + F, 2);

  // Divergence theorem: the signed volume enclosed by the outward surface equals the tet volume.
  double enclosed = 0.0;
  const auto& x = mesh->rest_positions();
  for (const auto& t : mesh->surface_triangles()) {
    enclosed += x[static_cast<size_t>(t[0])].dot(x[static_cast<size_t>(t[1])].cross(x[static_cast<size_t>(t[2])])) / 6.0;
  }
  EXPECT_NEAR(enclosed, size.prod(), 1e-14);

  // Lumped masses sum to density * volume.
  const auto m = mesh->lumped_masses(1000.0);
  double total = 0.0;
  for (double mi : m) total += mi;
  EXPECT_NEAR(total, 1000.0 * size.prod(), 1e-12);

  // Vertex normals of the corner (-,-,-) point along (-1,-1,-1) directions' octant.
  std::vector<Vec3> normals(x.size());
  mesh->vertex_normals(x, normals);
  EXPECT_LT(normals[0].x(), 0.0);
  EXPECT_LT(normals[0].y(), 0.0);
  EXPECT_LT(normals[0].z(), 0.0);
  EXPECT_NEAR(normals[0].norm(), 1.0, 1e-12);

  // Surface area shares add up to the box's area.
  double area = 0.0;
  for (int v : mesh->surface_vertices()) area += mesh->vertex_surface_area(x, v);
  EXPECT_NEAR(area, 2.0 * (size.x() * size.y() + size.y() * size.z() + size.z() * size.x()), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Resolutions, BoxMeshTest,
                         ::testing::Values(std::array<int, 3>{1, 1, 1}, std::array<int, 3>{2, 3, 4},
                                           std::array<int, 3>{5, 5, 5}));

TEST(TetMesh, ReorientsNegativeTetsAndReportsThem) {
  std::vector<Vec3> x{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  TetMeshBuildReport report;
  const auto mesh = TetMesh::build(x, {{0, 2, 1, 3}}, "t", &report);
  ASSERT_EQ(report.reoriented_tets.size(), 1u);
  EXPECT_NEAR(mesh->rest_volumes()[0], 1.0 / 6.0, 1e-15);
}

InputErrorKind kind_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.kind();
  }
  ADD_FAILURE() << "no InputError thrown";
  return InputErrorKind::io;
}

TEST(TetMesh, RejectsBadInputWithItsKind) {
  std::vector<Vec3> x{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}};
  EXPECT_EQ(kind_of([&] { TetMesh::build(x, {{0, 1, 2, 7}}); }), InputErrorKind::index_out_of_range);
  EXPECT_EQ(kind_of([&] { TetMesh::build(x, {{0, 1, 2, 4}}); }), InputErrorKind::degenerate_element);
  EXPECT_EQ(kind_of([&] { TetMesh::build(x, {{0, 1, 1, 3}}); }), InputErrorKind::degenerate_element);
  auto bad = x;
  bad[2].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(kind_of([&] { TetMesh::build(bad, {{0, 1, 2, 3}}); }), InputErrorKind::non_finite);
  EXPECT_EQ(kind_of([&] { TetMesh::build(x, {}); }), InputErrorKind::bad_value);
  // A face shared by three tets is not a manifold.
  std::vector<Vec3> y{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, -1}, {0.3, 0.3, 0.5}};
  EXPECT_EQ(kind_of([&] { TetMesh::build(y, {{0, 1, 2, 3}, {0, 2, 1, 4}, {0, 1, 2, 5}}); }), InputErrorKind::topology);
}

TEST(TetMesh, ErrorNamesTheTet) {
  std::vector<Vec3> x{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}};
  try {
    TetMesh::build(x, {{0, 1, 2, 3}, {0, 1, 2, 4}}, "cube.ele");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cube.ele"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("tetrahedron 1"), std::string::npos);
  }
}

}  // namespace
}  // namespace pliant
