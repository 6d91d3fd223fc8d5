// Procedural shapes against closed forms: counts; volume of the inscribed polyhedron (the sphere
// converges to 4/3 pi r^3 from below at O(1/n); the cylinder equals length times the area of its
// 6n-gon; the membrane is exact); closed 2-manifold surface with Euler characteristic 2; outward
// orientation by the divergence theorem; quality bounds; bad parameters rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "sim/input_error.h"
#include "sim/mesh/cylinder_mesh.h"
#include "sim/mesh/ellipsoid_mesh.h"
#include "sim/mesh/membrane_mesh.h"
#include "sim/mesh/mesh_quality.h"
#include "sim/mesh/sphere_mesh.h"

namespace pliant {
namespace {

// Closed, consistently oriented 2-manifold of genus 0, enclosing the mesh's volume.
void expect_closed_outward_surface(const TetMesh& mesh) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : mesh.surface_triangles()) {
    for (size_t k = 0; k < 3; ++k) directed[{t[k], t[(k + 1) % 3]}]++;
  }
  for (const auto& [e, count] : directed) {
    EXPECT_EQ(count, 1);
    EXPECT_EQ(directed.count({e.second, e.first}), 1u) << "edge without its twin";
  }
  const long V = static_cast<long>(mesh.surface_vertices().size());
  const long E = static_cast<long>(directed.size() / 2);
  const long F = mesh.surface_triangle_count();
  EXPECT_EQ(V - E + F, 2);
  // Divergence theorem: (1/3) sum over triangles of x . n dA = enclosed volume, positive if outward.
  double enclosed = 0.0;
  const auto& x = mesh.rest_positions();
  for (const auto& t : mesh.surface_triangles()) {
    enclosed += x[static_cast<size_t>(t[0])].dot(x[static_cast<size_t>(t[1])].cross(x[static_cast<size_t>(t[2])])) / 6.0;
  }
  EXPECT_NEAR(enclosed, mesh.total_rest_volume(), 1e-12 * mesh.total_rest_volume());
}

struct SphereCase {
  int surface_vertices;
  int shells;
};

class SphereMeshTest : public ::testing::TestWithParam<SphereCase> {};

TEST_P(SphereMeshTest, CountsSurfaceAndQuality) {
  const auto [n, shells] = GetParam();
  const double r = 0.04;
  TetMeshBuildReport report;
  const auto mesh = make_sphere_mesh({r, n, shells});
  EXPECT_EQ(mesh->vertex_count(), n * shells + 1);
  EXPECT_EQ(mesh->surface_triangle_count(), 2 * n - 4);
  EXPECT_EQ(mesh->tet_count(), (2 * n - 4) * (3 * (shells - 1) + 1));
  EXPECT_EQ(static_cast<int>(mesh->surface_vertices().size()), n);
  for (int v : mesh->surface_vertices()) EXPECT_NEAR(mesh->rest_positions()[static_cast<size_t>(v)].norm(), r, 1e-15);
  expect_closed_outward_surface(*mesh);
  EXPECT_LT(mesh->total_rest_volume(), 4.0 / 3.0 * std::numbers::pi * r * r * r);
  const MeshQuality q = compute_mesh_quality(*mesh);
  EXPECT_GT(q.min_dihedral_deg, 15.0);  // measured: >= 16.9 (n = 12), >= 26 for n >= 42
  EXPECT_LT(q.max_dihedral_deg, 150.0);
  EXPECT_GT(q.min_radius_ratio, 0.1);
}

INSTANTIATE_TEST_SUITE_P(Sizes, SphereMeshTest,
                         ::testing::Values(SphereCase{12, 1}, SphereCase{12, 3}, SphereCase{73, 1}, SphereCase{73, 2},
                                           SphereCase{150, 3}, SphereCase{400, 2}));

TEST(SphereMesh, VolumeConvergesFromBelowAtFirstOrderInTriangleArea) {
  const double exact = 4.0 / 3.0 * std::numbers::pi;
  double previous_error = 1.0;
  for (int n : {50, 200, 800, 3200}) {
    const double volume = make_sphere_mesh({1.0, n, 1})->total_rest_volume();
    const double error = exact - volume;
    EXPECT_GT(error, 0.0) << "inscribed polyhedron must be inside the ball";
    // The chord error of a triangle of area A ~ 4 pi / (2n) is O(A): quadrupling n quarters it.
    if (previous_error < 1.0) {
      EXPECT_GT(error / previous_error, 0.2);
      EXPECT_LT(error / previous_error, 0.3);
    }
    previous_error = error;
  }
  EXPECT_LT(previous_error / exact, 2e-3);
}

TEST(SphereMesh, ShellsSubdivideWithoutChangingTheVolume) {
  const double one = make_sphere_mesh({0.5, 73, 1})->total_rest_volume();
  for (int shells : {2, 3, 5}) EXPECT_NEAR(make_sphere_mesh({0.5, 73, shells})->total_rest_volume(), one, 1e-14);
}

TEST(SphereMesh, PaperSizedSoftSphere) {
  // The paper's soft sphere has about 79 vertices and 142 surface triangles: 73 surface vertices
  // give exactly 142 triangles (plus the centre: 74 vertices).
  const auto mesh = make_sphere_mesh({0.05, 73, 1});
  EXPECT_EQ(mesh->surface_triangle_count(), 142);
  EXPECT_EQ(mesh->vertex_count(), 74);
}

TEST(EllipsoidMesh, VolumeIsTheSphereVolumeTimesTheSemiAxes) {
  const Vec3 axes(0.03, 0.02, 0.01);
  const auto mesh = make_ellipsoid_mesh({axes, 200, 2});
  const double unit = make_sphere_mesh({1.0, 200, 2})->total_rest_volume();
  EXPECT_NEAR(mesh->total_rest_volume(), unit * axes.prod(), 1e-12 * unit * axes.prod());
  expect_closed_outward_surface(*mesh);
  for (int v : mesh->surface_vertices()) {
    EXPECT_NEAR(mesh->rest_positions()[static_cast<size_t>(v)].cwiseQuotient(axes).norm(), 1.0, 1e-12);
  }
  EXPECT_GT(compute_mesh_quality(*mesh).min_dihedral_deg, 5.0);
}

class CylinderMeshTest : public ::testing::TestWithParam<std::array<int, 2>> {};

TEST_P(CylinderMeshTest, VolumeIsLengthTimesPolygonArea) {
  const auto [nr, nz] = GetParam();
  const double radius = 0.02, length = 0.1;
  const auto mesh = make_cylinder_mesh({radius, length, nr, nz});
  const int disc = 1 + 3 * nr * (nr + 1);
  EXPECT_EQ(mesh->vertex_count(), disc * (nz + 1));
  EXPECT_EQ(mesh->tet_count(), 3 * 6 * nr * nr * nz);
  // Inscribed regular 6n-gon: area = (6n / 2) r^2 sin(2 pi / 6n).
  const double polygon = 3.0 * nr * radius * radius * std::sin(2.0 * std::numbers::pi / (6.0 * nr));
  EXPECT_NEAR(mesh->total_rest_volume(), length * polygon, 1e-12 * length * polygon);
  expect_closed_outward_surface(*mesh);
  const auto bounds = mesh->rest_bounds();
  EXPECT_NEAR(bounds.min.z(), -0.5 * length, 1e-15);
  EXPECT_NEAR(bounds.max.z(), 0.5 * length, 1e-15);
  EXPECT_GT(compute_mesh_quality(*mesh).min_dihedral_deg, 10.0);  // cells about as tall as wide
}

INSTANTIATE_TEST_SUITE_P(Sizes, CylinderMeshTest,
                         ::testing::Values(std::array<int, 2>{1, 3}, std::array<int, 2>{2, 4}, std::array<int, 2>{4, 10},
                                           std::array<int, 2>{8, 20}));

TEST(MembraneMesh, VolumeCountsAndThickness) {
  const auto mesh = make_membrane_mesh({0.2, 0.1, 0.002, 20, 10, 2});
  EXPECT_NEAR(mesh->total_rest_volume(), 0.2 * 0.1 * 0.002, 1e-18);
  EXPECT_EQ(mesh->vertex_count(), 21 * 11 * 3);
  EXPECT_EQ(mesh->tet_count(), 6 * 20 * 10 * 2);
  EXPECT_NEAR(mesh->rest_bounds().extent().z(), 0.002, 1e-15);
  expect_closed_outward_surface(*mesh);
}

TEST(ProceduralShapes, BadParametersAreRejected) {
  auto kind = [](auto make) {
    try {
      make();
    } catch (const InputError& e) {
      return e.kind();
    }
    return InputErrorKind::io;  // no error: fails below
  };
  EXPECT_EQ(kind([] { make_sphere_mesh({-1.0, 73, 1}); }), InputErrorKind::bad_value);
  EXPECT_EQ(kind([] { make_sphere_mesh({1.0, 5, 1}); }), InputErrorKind::bad_value);
  EXPECT_EQ(kind([] { make_sphere_mesh({1.0, 73, 0}); }), InputErrorKind::bad_value);
  EXPECT_EQ(kind([] { make_sphere_mesh({std::nan(""), 73, 1}); }), InputErrorKind::bad_value);
  EXPECT_EQ(kind([] { make_ellipsoid_mesh({Vec3(1, 0, 1), 73, 1}); }), InputErrorKind::bad_value);
  EXPECT_EQ(kind([] { make_cylinder_mesh({1.0, 0.0, 2, 2}); }), InputErrorKind::bad_value);
  EXPECT_EQ(kind([] { make_cylinder_mesh({1.0, 1.0, 0, 2}); }), InputErrorKind::bad_value);
  EXPECT_EQ(kind([] { make_membrane_mesh({1.0, 1.0, 0.0, 2, 2, 1}); }), InputErrorKind::bad_value);
  EXPECT_EQ(kind([] { make_membrane_mesh({1.0, 1.0, 0.1, 2, 2, 0}); }), InputErrorKind::bad_value);
}

}  // namespace
}  // namespace pliant
