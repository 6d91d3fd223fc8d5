#include "sim/mesh/sphere_mesh.h"

#include <cmath>
#include <numbers>

#include "sim/input_error.h"
#include "sim/mesh/prism_split.h"
#include "sim/mesh/sphere_surface.h"

namespace pliant {

double sphere_shell_radius_fraction(int surface_vertices, int k) {
  // Mean edge length of the unit-sphere triangulation: 2n - 4 equilateral triangles cover 4 pi.
  const double triangle_area = 4.0 * std::numbers::pi / (2.0 * surface_vertices - 4.0);
  const double edge = std::sqrt(4.0 * triangle_area / std::sqrt(3.0));
  // Each shell is `edge` (scaled by its radius) thinner: r_{k+1} = r_k (1 - kThickness * edge).
  constexpr double kThickness = 0.8;
  const double ratio = std::max(0.3, 1.0 - kThickness * edge);
  return std::pow(ratio, k);
}

TetMeshPtr make_sphere_mesh(const SphereMeshSpec& spec) {
  if (!std::isfinite(spec.radius) || !(spec.radius > 0.0)) {  // isfinite first: NaN > 0 traps
    throw InputError(InputErrorKind::bad_value, "sphere", "radius must be positive and finite");
  }
  if (spec.surface_vertices < 12 || spec.surface_vertices > 200000) {
    throw InputError(InputErrorKind::bad_value, "sphere", "surface_vertices must be in [12, 200000]");
  }
  if (spec.shells < 1 || static_cast<long>(spec.shells) * spec.surface_vertices > 2000000) {
    throw InputError(InputErrorKind::bad_value, "sphere", "shells must be at least 1 (and the mesh not huge)");
  }
  const SphereTriangulation surface = fibonacci_sphere_triangulation(spec.surface_vertices);
  const int n = spec.surface_vertices;
  std::vector<Vec3> x;
  x.reserve(static_cast<size_t>(n) * static_cast<size_t>(spec.shells) + 1);
  for (int k = 0; k < spec.shells; ++k) {
    const double r = spec.radius * sphere_shell_radius_fraction(n, k);
    for (const Vec3& p : surface.points) x.push_back(r * p);
  }
  const int centre = static_cast<int>(x.size());
  x.push_back(Vec3::Zero());

  std::vector<TetIndices> tets;
  tets.reserve(surface.triangles.size() * (3 * static_cast<size_t>(spec.shells) - 2));
  for (int k = 0; k + 1 < spec.shells; ++k) {
    const int outer = k * n, inner = (k + 1) * n;
    for (const auto& t : surface.triangles) {
      split_prism({inner + t[0], inner + t[1], inner + t[2], outer + t[0], outer + t[1], outer + t[2]}, x, tets);
    }
  }
  const int innermost = (spec.shells - 1) * n;
  for (const auto& t : surface.triangles) {
    TetIndices tet{centre, innermost + t[0], innermost + t[1], innermost + t[2]};
    orient_tet_positively(tet, x);
    tets.push_back(tet);
  }
  return TetMesh::build(std::move(x), std::move(tets), "sphere");
}

}  // namespace pliant
